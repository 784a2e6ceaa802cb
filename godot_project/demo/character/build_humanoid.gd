extends SceneTree
## Builds `res://demo/character/humanoid.tscn`: a Skeleton3D with Godot's SkeletonProfileHumanoid
## bone names and parents (Root, Hips, Spine, Chest, UpperChest, Neck, Head, Left/Right Shoulder,
## UpperArm, LowerArm, Hand, UpperLeg, LowerLeg, Foot, Toes; no fingers), its proportions read from
## a CMU motion-capture skeleton (BVH, Debian's assimp-testmodels), and a mannequin body: one mesh
## per bone on a BoneAttachment3D. Rerun after changing this file; the scene it writes is committed.
##
##   scripts/godot --headless --path godot_project --script res://demo/character/build_humanoid.gd \
##       [-- --bvh=/usr/share/assimp/models/BVH/01_01.bvh]
##
## What comes from where:
## - Bone lengths and offsets: the BVH's OFFSETs (CMU subject 01), in CMU units of 1/0.45 inch
##   (0.056444 m), left and right averaged (the mocap's two sides differ by a few millimetres).
## - Directions: a standing T-pose as in the profile (legs straight down, arms along ±X), because
##   the CMU rest has the thighs 20° apart (its frames rotate them back).
## - Bone frames: the profile's reference pose (`get_reference_pose`), turned by the smallest
##   rotation that puts each bone's +Y on the direction to its child. So the knees and elbows
##   bend about their own +X as on every skeleton Godot retargets to this profile.
## - CMU has no UpperChest and no clavicle offset: UpperChest splits Spine1→Neck1 in half, and
##   each Shoulder starts 0.5 units beside the midline at the upper arm's height.
## - The lower spine (Hips→Spine→Chest) stands upright at CMU's lengths (see _upright).

const OUT := "res://demo/character/humanoid.tscn"
const DEFAULT_BVH := "/usr/share/assimp/models/BVH/01_01.bvh"
## CMU's length unit: the ASF files' `length 0.45` means 1 unit = 1/0.45 inch.
const CMU_UNIT := 0.0254 / 0.45
## Height of the ankle joint above the sole when standing (m); the BVH has no ground contact.
const ANKLE_HEIGHT := 0.07

## The bones built, parent before child: name, parent.
const BONES := [
	["Root", ""], ["Hips", "Root"], ["Spine", "Hips"], ["Chest", "Spine"], ["UpperChest", "Chest"],
	["Neck", "UpperChest"], ["Head", "Neck"],
	["LeftShoulder", "UpperChest"], ["LeftUpperArm", "LeftShoulder"], ["LeftLowerArm", "LeftUpperArm"], ["LeftHand", "LeftLowerArm"],
	["RightShoulder", "UpperChest"], ["RightUpperArm", "RightShoulder"], ["RightLowerArm", "RightUpperArm"], ["RightHand", "RightLowerArm"],
	["LeftUpperLeg", "Hips"], ["LeftLowerLeg", "LeftUpperLeg"], ["LeftFoot", "LeftLowerLeg"], ["LeftToes", "LeftFoot"],
	["RightUpperLeg", "Hips"], ["RightLowerLeg", "RightUpperLeg"], ["RightFoot", "RightLowerLeg"], ["RightToes", "RightFoot"],
]
## The child each bone's +Y points at (bones not listed keep the profile's frame).
const AIM_CHILD := {
	"Hips": "Spine", "Spine": "Chest", "Chest": "UpperChest", "UpperChest": "Neck", "Neck": "Head",
	"LeftShoulder": "LeftUpperArm", "LeftUpperArm": "LeftLowerArm", "LeftLowerArm": "LeftHand",
	"RightShoulder": "RightUpperArm", "RightUpperArm": "RightLowerArm", "RightLowerArm": "RightHand",
	"LeftUpperLeg": "LeftLowerLeg", "LeftLowerLeg": "LeftFoot", "LeftFoot": "LeftToes",
	"RightUpperLeg": "RightLowerLeg", "RightLowerLeg": "RightFoot", "RightFoot": "RightToes",
}


func _init() -> void:
	var bvh_path := DEFAULT_BVH
	for arg in OS.get_cmdline_user_args():
		if arg.begins_with("--bvh="):
			bvh_path = arg.get_slice("=", 1)
	var offsets := read_bvh_offsets(bvh_path)
	if offsets.is_empty():
		push_error("build_humanoid: no skeleton read from %s (is assimp-testmodels installed?)" % bvh_path)
		quit(1)
		return
	var positions := humanoid_positions(offsets)
	var root := build_scene(positions, bvh_path)
	var packed := PackedScene.new()
	var err := packed.pack(root)
	if err == OK:
		err = ResourceSaver.save(packed, OUT)
	root.free()
	if err == OK:
		err = _strip_node_ids(OUT)
	if err != OK:
		push_error("build_humanoid: could not write %s (error %d)" % [OUT, err])
	else:
		print("build_humanoid: wrote %s from %s" % [OUT, bvh_path])
	quit(0 if err == OK else 1)


## Removes the random `unique_id=` Godot 4.6 writes on each node line, so that a rebuild writes
## the same file (Godot reads scenes without them and adds them when the editor saves).
static func _strip_node_ids(path: String) -> int:
	var text := FileAccess.get_file_as_string(path)
	var ids := RegEx.create_from_string(" unique_id=[0-9]+")
	var file := FileAccess.open(path, FileAccess.WRITE)
	if file == null:
		return FileAccess.get_open_error()
	file.store_string(ids.sub(text, "", true))
	return OK


## The BVH's HIERARCHY as {joint name: OFFSET (Vector3, CMU units)}; an End Site is "<joint>_End".
static func read_bvh_offsets(path: String) -> Dictionary:
	var file := FileAccess.open(path, FileAccess.READ)
	if file == null:
		return {}
	var offsets := {}
	var stack: Array[String] = []
	var pending := ""
	while not file.eof_reached():
		var words := file.get_line().strip_edges().split(" ", false)
		if words.is_empty():
			continue
		match words[0]:
			"ROOT", "JOINT":
				pending = words[1]
			"End":
				pending = stack.back() + "_End"
			"{":
				stack.append(pending)
			"}":
				stack.pop_back()
			"OFFSET":
				offsets[stack.back()] = Vector3(words[1].to_float(), words[2].to_float(), words[3].to_float())
			"MOTION":
				break
	return offsets


## Each humanoid bone's origin in the skeleton's space (m, facing +Z, the character's left on +X,
## the soles at y = 0), from the CMU offsets in a standing T-pose.
static func humanoid_positions(o: Dictionary) -> Dictionary:
	var s := CMU_UNIT
	var side := func(left: String, right: String) -> Vector3:  # mirrored average, left side
		var l: Vector3 = o[left]
		var r: Vector3 = o[right]
		return Vector3(0.5 * (l.x - r.x), 0.5 * (l.y + r.y), 0.5 * (l.z + r.z))
	var hip: Vector3 = side.call("LeftUpLeg", "RightUpLeg") * s
	var thigh: float = side.call("LeftLeg", "RightLeg").length() * s
	var shin: float = side.call("LeftFoot", "RightFoot").length() * s
	var foot: Vector3 = side.call("LeftToeBase", "RightToeBase") * s
	var toe: Vector3 = side.call("LeftToeBase_End", "RightToeBase_End") * s
	var arm: Vector3 = side.call("LeftArm", "RightArm") * s
	var upper_arm: float = side.call("LeftForeArm", "RightForeArm").length() * s
	var forearm: float = side.call("LeftHand", "RightHand").length() * s
	var hips_y := ANKLE_HEIGHT + shin + thigh - hip.y
	var p := {}
	p["Root"] = Vector3.ZERO
	p["Hips"] = Vector3(0, hips_y, 0)
	p["Spine"] = p["Hips"] + _upright(o["Spine"] * s)
	p["Chest"] = p["Spine"] + _upright(o["Spine1"] * s)
	var neck1: Vector3 = _mid(o["Neck1"] * s)
	p["UpperChest"] = p["Chest"] + 0.5 * neck1
	p["Neck"] = p["Chest"] + neck1
	p["Head"] = p["Neck"] + _mid(o["Head"] * s)
	for sign_name in [[1.0, "Left"], [-1.0, "Right"]]:
		var k: float = sign_name[0]
		var n: String = sign_name[1]
		var shoulder_joint: Vector3 = p["Chest"] + Vector3(k * arm.x, arm.y, arm.z)
		p[n + "Shoulder"] = Vector3(k * 0.5 * s, shoulder_joint.y, shoulder_joint.z)
		p[n + "UpperArm"] = shoulder_joint
		p[n + "LowerArm"] = shoulder_joint + Vector3(k * upper_arm, 0, 0)
		p[n + "Hand"] = p[n + "LowerArm"] + Vector3(k * forearm, 0, 0)
		var hip_joint: Vector3 = p["Hips"] + Vector3(k * hip.x, hip.y, hip.z)
		p[n + "UpperLeg"] = hip_joint
		p[n + "LowerLeg"] = hip_joint - Vector3(0, thigh, 0)
		p[n + "Foot"] = hip_joint - Vector3(0, thigh + shin, 0)
		p[n + "Toes"] = p[n + "Foot"] + Vector3(k * 0.0, foot.y, foot.z)
		p[n + "ToesEnd"] = p[n + "Toes"] + Vector3(0, toe.y, toe.z)
		p[n + "HandEnd"] = p[n + "Hand"] + Vector3(k * 0.17, 0, 0)  # a hand-sized hand (see the mesh)
	p["HeadTop"] = p["Head"] + Vector3(0, 0.2, 0)
	return p


## The lower spine's offsets stand upright at their CMU length: in the subject's T-pose they lean
## back 5° and 1°, which makes a walking figure look as if it leaned back.
static func _upright(v: Vector3) -> Vector3:
	return Vector3(0, v.length(), 0)


## A spine offset without its small sideways part (the mocap's one subject leans a little).
static func _mid(v: Vector3) -> Vector3:
	return Vector3(0, v.y, v.z)


## The profile's reference frames in the skeleton's space, by bone name.
static func profile_frames() -> Dictionary:
	var profile := SkeletonProfileHumanoid.new()
	var frames := {}
	for i in profile.bone_size:
		var parent := profile.get_bone_parent(i)
		var local := profile.get_reference_pose(i)
		frames[str(profile.get_bone_name(i))] = frames[str(parent)] * local if parent != &"" else local
	return frames


static func build_scene(p: Dictionary, bvh_path: String) -> Node3D:
	var root := Node3D.new()
	root.name = "Humanoid"
	root.set_meta("source", "proportions from %s (CMU mocap, mocap.cs.cmu.edu), built by build_humanoid.gd" % bvh_path.get_file())
	var skeleton := Skeleton3D.new()
	skeleton.name = "Skeleton3D"
	root.add_child(skeleton)
	skeleton.owner = root
	var profile := profile_frames()
	var global_rest := {}
	for entry in BONES:
		var name: String = entry[0]
		var basis: Basis = (profile[name] as Transform3D).basis
		if AIM_CHILD.has(name):
			var along: Vector3 = (p[AIM_CHILD[name]] - p[name]).normalized()
			basis = _turn_onto(basis.y, along) * basis
		global_rest[name] = Transform3D(basis.orthonormalized(), p[name])
	for entry in BONES:
		var name: String = entry[0]
		var parent: String = entry[1]
		var i := skeleton.add_bone(name)
		var local: Transform3D = global_rest[name]
		if parent != "":
			skeleton.set_bone_parent(i, skeleton.find_bone(parent))
			local = (global_rest[parent] as Transform3D).affine_inverse() * local
		skeleton.set_bone_rest(i, local)
	skeleton.reset_bone_poses()
	Body.new(skeleton, global_rest, p, root).build()
	return root


## The smallest rotation taking unit vector `from` onto unit vector `to`.
static func _turn_onto(from: Vector3, to: Vector3) -> Basis:
	var axis := from.cross(to)
	if axis.length() < 1e-9:
		return Basis()
	return Basis(axis.normalized(), from.angle_to(to))


## The mannequin: tapered limbs, ball joints, an ellipsoid torso and head, box hands and feet.
class Body:
	var skeleton: Skeleton3D
	var rest: Dictionary
	var p: Dictionary
	var owner: Node
	var skin := _material("skin", Color(0.87, 0.69, 0.55), 0.6)
	var shirt := _material("shirt", Color(0.2, 0.42, 0.68), 0.8)
	var trousers := _material("trousers", Color(0.2, 0.22, 0.27), 0.85)
	var shoes := _material("shoes", Color(0.35, 0.2, 0.12), 0.5)
	var dark := _material("dark", Color(0.08, 0.08, 0.1), 0.3)

	func _init(s: Skeleton3D, r: Dictionary, positions: Dictionary, o: Node) -> void:
		skeleton = s
		rest = r
		p = positions
		owner = o

	static func _material(name: String, color: Color, roughness: float) -> StandardMaterial3D:
		var m := StandardMaterial3D.new()
		m.resource_scene_unique_id = name
		m.albedo_color = color
		m.roughness = roughness
		return m

	func build() -> void:
		# Torso: pelvis, belly, rib cage; the hips' and chest's shapes are wider than deep.
		_blob("Hips", "Pelvis", p["Hips"] + Vector3(0, -0.04, 0.0), Vector3(0.17, 0.12, 0.12), trousers)
		_blob("Spine", "Belly", (p["Spine"] + p["Chest"]) * 0.5, Vector3(0.145, 0.13, 0.105), shirt)
		_blob("Chest", "Ribs", p["Chest"] + Vector3(0, 0.05, 0.005), Vector3(0.16, 0.14, 0.11), shirt)
		_blob("UpperChest", "Chest", p["UpperChest"] + Vector3(0, -0.01, 0.0), Vector3(0.175, 0.12, 0.1), shirt)
		_limb("Neck", "Neck", p["Neck"], p["Head"] + Vector3(0, 0.02, 0), 0.045, 0.042, skin)
		_blob("Head", "Skull", p["Head"] + Vector3(0, 0.095, 0.01), Vector3(0.082, 0.108, 0.095), skin)
		_blob("Head", "Hair", p["Head"] + Vector3(0, 0.125, -0.012), Vector3(0.086, 0.09, 0.093), dark)
		_blob("Head", "Nose", p["Head"] + Vector3(0, 0.085, 0.1), Vector3(0.014, 0.022, 0.02), skin)
		for k in [1.0, -1.0]:
			_blob("Head", "Eye", p["Head"] + Vector3(k * 0.032, 0.11, 0.085), Vector3(0.012, 0.012, 0.01), dark)
		for side in ["Left", "Right"]:
			_limb(side + "Shoulder", "Clavicle", p[side + "Shoulder"], p[side + "UpperArm"], 0.05, 0.05, shirt)
			_ball(side + "UpperArm", "Deltoid", p[side + "UpperArm"], 0.056, shirt)
			_limb(side + "UpperArm", "Arm", p[side + "UpperArm"], p[side + "LowerArm"], 0.048, 0.038, shirt)
			_ball(side + "LowerArm", "Elbow", p[side + "LowerArm"], 0.037, skin)
			_limb(side + "LowerArm", "Forearm", p[side + "LowerArm"], p[side + "Hand"], 0.036, 0.027, skin)
			_hand(side)
			_ball(side + "UpperLeg", "HipBall", p[side + "UpperLeg"], 0.082, trousers)
			_limb(side + "UpperLeg", "Thigh", p[side + "UpperLeg"], p[side + "LowerLeg"], 0.08, 0.055, trousers)
			_ball(side + "LowerLeg", "Knee", p[side + "LowerLeg"], 0.054, trousers)
			_limb(side + "LowerLeg", "Shin", p[side + "LowerLeg"], p[side + "Foot"], 0.054, 0.038, trousers)
			_foot(side)

	## A mesh on a BoneAttachment3D of `bone`; `at` is the mesh's frame in the skeleton's space.
	func _attach(bone: String, part: String, mesh: Mesh, at: Transform3D, material: Material) -> void:
		var attachment := skeleton.get_node_or_null(bone) as BoneAttachment3D
		if attachment == null:
			attachment = BoneAttachment3D.new()
			attachment.name = bone
			skeleton.add_child(attachment)
			attachment.owner = owner
			attachment.bone_name = bone
		var mi := MeshInstance3D.new()
		mi.name = part
		var i := 2
		while attachment.has_node(NodePath(mi.name)):
			mi.name = "%s%d" % [part, i]
			i += 1
		# Fixed ids (not Godot's random ones): a rebuild writes the same file.
		mesh.resource_scene_unique_id = "%s_%s" % [bone, mi.name]
		mi.mesh = mesh
		mi.material_override = material
		mi.transform = (rest[bone] as Transform3D).affine_inverse() * at
		attachment.add_child(mi)
		mi.owner = owner

	func _blob(bone: String, part: String, center: Vector3, radii: Vector3, material: Material) -> void:
		var sphere := SphereMesh.new()
		sphere.radius = 1.0
		sphere.height = 2.0
		sphere.radial_segments = 24
		sphere.rings = 12
		var basis := Basis.from_scale(radii)
		_attach(bone, part, sphere, Transform3D(basis, center), material)

	func _ball(bone: String, part: String, center: Vector3, radius: float, material: Material) -> void:
		_blob(bone, part, center, Vector3.ONE * radius, material)

	## A tapered cylinder from `a` (radius ra) to `b` (radius rb).
	func _limb(bone: String, part: String, a: Vector3, b: Vector3, ra: float, rb: float, material: Material) -> void:
		var cylinder := CylinderMesh.new()
		cylinder.bottom_radius = ra
		cylinder.top_radius = rb
		cylinder.height = a.distance_to(b)
		cylinder.radial_segments = 20
		cylinder.rings = 1
		var along := (b - a).normalized()
		var basis := _turn(Vector3.UP, along)
		_attach(bone, part, cylinder, Transform3D(basis, (a + b) * 0.5), material)

	static func _turn(from: Vector3, to: Vector3) -> Basis:
		var axis := from.cross(to)
		if axis.length() < 1e-9:
			return Basis() if from.dot(to) > 0.0 else Basis(Vector3.RIGHT, PI)
		return Basis(axis.normalized(), from.angle_to(to))

	func _box(bone: String, part: String, center: Vector3, size: Vector3, material: Material) -> void:
		var box := BoxMesh.new()
		box.size = size
		_attach(bone, part, box, Transform3D(Basis(), center), material)

	func _hand(side: String) -> void:
		var k := 1.0 if side == "Left" else -1.0
		var wrist: Vector3 = p[side + "Hand"]
		_box(side + "Hand", "Palm", wrist + Vector3(k * 0.05, 0, 0), Vector3(0.1, 0.03, 0.085), skin)
		_box(side + "Hand", "Fingers", wrist + Vector3(k * 0.135, -0.004, -0.004), Vector3(0.08, 0.022, 0.077), skin)
		_box(side + "Hand", "Thumb", wrist + Vector3(k * 0.06, -0.008, 0.05), Vector3(0.06, 0.022, 0.024), skin)

	func _foot(side: String) -> void:
		var ankle: Vector3 = p[side + "Foot"]
		var toes: Vector3 = p[side + "Toes"]
		var toe_end: Vector3 = p[side + "ToesEnd"]
		_ball(side + "Foot", "Ankle", ankle, 0.042, shoes)
		var heel_z := ankle.z - 0.06
		var top := ankle.y + 0.02
		_box(side + "Foot", "Shoe", Vector3(ankle.x, top * 0.5, (heel_z + toes.z) * 0.5),
				Vector3(0.095, top, toes.z - heel_z), shoes)
		var toe_top := toes.y + 0.01
		_box(side + "Toes", "ToeCap", Vector3(toes.x, toe_top * 0.5, (toes.z + toe_end.z) * 0.5),
				Vector3(0.09, toe_top, toe_end.z - toes.z), shoes)
