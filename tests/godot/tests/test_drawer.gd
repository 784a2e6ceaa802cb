# The IKChain gizmo's drawing (addons/ikchain/ik_chain_drawer.gd) and its run-time view
# (ik_chain_debug_draw.gd). The geometry is checked against the test arm's own forward kinematics
# and Godot's Vector3.rotated() (not the drawer's formulas), first on a stand-in node that exposes
# IKChain's public API (node_api.md) so the drawing is tested whatever the node's state, then on
# the real IKChain: that case fails, naming what is missing, until the node has that API.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")
const DebugDraw := preload("res://addons/ikchain/ik_chain_debug_draw.gd")

const EPS := 1e-4
const N := 3
## Rotations of j0, j1, j2 (not the rest pose, so rest frames and posed frames differ).
static var ROTATIONS := [Quaternion(Vector3(0, 0, 1), 0.5), Quaternion(Vector3(1, 0, 0), 0.7),
		Quaternion(Vector3(0.3, 1, 0).normalized(), -0.4)]


## Stands for IKChain: the properties and methods of node_api.md the drawer reads.
class FakeChain extends Node3D:
	var root_bone := "j0"
	var tip_bone := "tip"
	var extend_tip_bone := false
	var tip_extension_axis := 2
	var tip_extension_length := 0.0
	var target := NodePath()
	var target_transform := Transform3D()
	var goal_mode := 0
	var pole_target := NodePath()
	var joints: Array = []
	var goals: Array = []
	var chain_bones := PackedInt32Array()

	func get_chain_bones() -> PackedInt32Array:
		return chain_bones


class FakeJoint extends Resource:
	var bone_name := ""
	var type := 0
	var hinge_axis := Vector3(1, 0, 0)
	var hinge_limit_enabled := false
	var hinge_min := 0.0
	var hinge_max := 0.0
	var cone_limit_enabled := false
	var cone_angle := 0.0
	var twist_limit_enabled := false
	var twist_min := 0.0
	var twist_max := 0.0
	var twist_axis := Vector3(0, 1, 0)


class FakeGoal extends Resource:
	var bone_name := ""
	var kind := 0
	var target := NodePath()
	var weight := 1.0
	var aim_axis := Vector3(0, 1, 0)


## case_root ─ Skeleton (arm, posed with ROTATIONS) ─ IK (FakeChain), plus Target/Pole/Goal markers.
func _make_rig(extend_tip := false) -> Dictionary:
	var skel := Arm.make_skeleton(N)
	Arm.pose_joints(skel, ROTATIONS)
	var ik := FakeChain.new()
	ik.name = "IK"
	ik.extend_tip_bone = extend_tip
	for i in N:
		ik.chain_bones.append(skel.find_bone("j%d" % i))
	if extend_tip:
		ik.chain_bones.append(skel.find_bone("tip"))
	skel.add_child(ik)
	case_root.add_child(skel)
	var markers := {}
	for m in [["Target", Vector3(0.4, 1.2, -1.5), Basis(Vector3(0, 1, 0), 0.6)],
			["Pole", Vector3(1.5, 1.0, -2.5), Basis()], ["GoalTarget", Vector3(0.9, 0.8, -1.8), Basis()]]:
		var marker := Marker3D.new()
		marker.name = m[0]
		marker.transform = Transform3D(m[2], m[1])
		case_root.add_child(marker)
		markers[m[0]] = marker
	return {"skeleton": skel, "ik": ik, "markers": markers}


## World frames of [base, j0, j1, j2, tip] from the arm's own forward kinematics.
func _fk_world() -> Array:
	var out := []
	for t in Arm.fk_chain(N, ROTATIONS):
		out.append(Arm.SKELETON_TRANSFORM * (t as Transform3D))
	return out


func _segments(lines: PackedVector3Array) -> int:
	return lines.size() / 2


func _check_point(got: Vector3, want: Vector3, what: String) -> void:
	check(got.distance_to(want) < EPS, "%s: %s, expected %s" % [what, got, want])


func test_bones_follow_the_posed_chain() -> void:
	var rig := _make_rig()
	var lines := Drawer.build(rig["ik"])
	check_eq(lines["problems"], PackedStringArray(), "problems")
	var fk := _fk_world()
	var bones: PackedVector3Array = lines["bones"]
	check_eq(_segments(bones), N, "one bone segment per joint")
	for k in N:
		_check_point(bones[2 * k], fk[k + 1].origin, "bone %d start (joint j%d)" % [k, k])
		_check_point(bones[2 * k + 1], fk[k + 2].origin, "bone %d end" % k)
	for c in ["limits", "pole", "goals"]:
		check_eq(_segments(lines[c]), 0, "nothing set, no %s lines" % c)
	# No target node: the node reaches for target_transform (identity by default), drawn there.
	var t: PackedVector3Array = lines["target"]
	check_eq(_segments(t), 3, "a cross at target_transform")
	_check_point((t[0] + t[1]) * 0.5, Vector3.ZERO, "the cross at target_transform's origin")


func test_limited_hinge_arc() -> void:
	var rig := _make_rig()
	var j := FakeJoint.new()
	j.bone_name = "j1"
	j.type = Drawer.JOINT_HINGE
	j.hinge_axis = Vector3(1, 0, 0.5)
	j.hinge_limit_enabled = true
	j.hinge_min = -0.4
	j.hinge_max = 1.2
	rig["ik"].joints = [j]
	var limits: PackedVector3Array = Drawer.build(rig["ik"])["limits"]
	var fk := _fk_world()
	# j1's rest frame = its parent j0's posed frame (the arm's rests have no rotation).
	var rest_basis: Basis = fk[1].basis
	var o: Vector3 = fk[2].origin
	var axis := (rest_basis * Vector3(1, 0, 0.5)).normalized()
	var bone_dir := rest_basis * Vector3(0, 1, 0)  # j1's bone runs along its own +Y
	var zero := (bone_dir - axis * bone_dir.dot(axis)).normalized()
	var r: float = Drawer.LIMIT_RADIUS * Arm.lengths(N)[1]
	var arc := ceili(1.6 / (PI / 16))
	check_eq(_segments(limits), arc + 2, "arc segments + 2 radii")
	for p in limits.slice(0, 2 * arc):
		check_near(p.distance_to(o), r, EPS, "arc point at the radius")
		check_near((p - o).dot(axis), 0.0, EPS, "arc point in the plane perpendicular to the hinge axis")
	_check_point(limits[0], o + zero.rotated(axis, -0.4) * r, "arc starts at hinge_min")
	_check_point(limits[2 * arc - 1], o + zero.rotated(axis, 1.2) * r, "arc ends at hinge_max")
	_check_point(limits[2 * arc], o, "first radius from the joint")
	_check_point(limits[2 * arc + 1], o + zero.rotated(axis, -0.4) * r, "first radius to hinge_min")
	_check_point(limits[2 * arc + 3], o + zero.rotated(axis, 1.2) * r, "second radius to hinge_max")


func test_free_hinge_circle() -> void:
	var rig := _make_rig()
	var j := FakeJoint.new()
	j.bone_name = "j2"
	j.type = Drawer.JOINT_HINGE
	j.hinge_axis = Vector3(0, 0, 1)
	rig["ik"].joints = [j]
	var limits: PackedVector3Array = Drawer.build(rig["ik"])["limits"]
	var fk := _fk_world()
	var axis: Vector3 = (fk[2].basis * Vector3(0, 0, 1)).normalized()
	var o: Vector3 = fk[3].origin
	check_eq(_segments(limits), Drawer.CIRCLE_SEGMENTS, "a full circle")
	for p in limits:
		check_near(p.distance_to(o), Drawer.LIMIT_RADIUS * Arm.lengths(N)[2], EPS, "circle radius")
		check_near((p - o).dot(axis), 0.0, EPS, "circle perpendicular to the hinge axis")
	_check_point(limits[0], limits[limits.size() - 1], "the circle closes")


func test_cone_and_twist() -> void:
	var rig := _make_rig()
	var j := FakeJoint.new()
	j.bone_name = "j0"
	j.cone_limit_enabled = true
	j.cone_angle = 0.5
	j.twist_limit_enabled = true
	j.twist_min = -0.3
	j.twist_max = 0.6
	rig["ik"].joints = [j]
	var limits: PackedVector3Array = Drawer.build(rig["ik"])["limits"]
	var fk := _fk_world()
	var axis: Vector3 = (fk[0].basis * Vector3(0, 1, 0)).normalized()  # j0's rest frame = base's
	var o: Vector3 = fk[1].origin
	var r: float = Drawer.LIMIT_RADIUS * Arm.lengths(N)[0]
	var cone := Drawer.CIRCLE_SEGMENTS + Drawer.CONE_GENERATORS
	var twist := ceili(0.9 / (PI / 16))
	check_eq(_segments(limits), cone + twist + 2, "cone circle + generators + twist arc + 2 radii")
	for p in limits.slice(0, 2 * Drawer.CIRCLE_SEGMENTS):
		check_near(p.distance_to(o), r, EPS, "cone base point at the slant length")
		check_near((p - o).normalized().angle_to(axis), 0.5, EPS, "cone base point at cone_angle from twist_axis")
	for i in Drawer.CONE_GENERATORS:
		_check_point(limits[2 * (Drawer.CIRCLE_SEGMENTS + i)], o, "generator %d starts at the joint" % i)
	var c: Vector3 = o + axis * r * 0.5
	var arc := limits.slice(2 * cone, 2 * (cone + twist))
	for p in arc:
		check_near(p.distance_to(c), r * 0.5, EPS, "twist arc radius")
		check_near((p - c).dot(axis), 0.0, EPS, "twist arc perpendicular to twist_axis")
	var first: Vector3 = (arc[0] - c).normalized()
	var last: Vector3 = (arc[arc.size() - 1] - c).normalized()
	check_near(first.signed_angle_to(last, axis), 0.9, EPS, "twist arc spans twist_max - twist_min, right-handed")


func test_target_pole_and_goal_crosses() -> void:
	var rig := _make_rig()
	var ik: FakeChain = rig["ik"]
	ik.target = ik.get_path_to(rig["markers"]["Target"])
	ik.pole_target = ik.get_path_to(rig["markers"]["Pole"])
	var goal := FakeGoal.new()
	goal.bone_name = "j2"
	goal.target = ik.get_path_to(rig["markers"]["GoalTarget"])
	ik.goals = [goal, null]
	var lines := Drawer.build(ik)
	var chain_length := Arm.chain_length(N)
	var half := Drawer.CROSS_SIZE * chain_length
	var target: Transform3D = rig["markers"]["Target"].global_transform
	var t: PackedVector3Array = lines["target"]
	check_eq(_segments(t), 3, "target cross")
	var axes := [target.basis.x, target.basis.y, target.basis.z]
	for i in 3:
		_check_point((t[2 * i] + t[2 * i + 1]) * 0.5, target.origin, "target cross arm %d centred" % i)
		_check_point(t[2 * i + 1] - t[2 * i], axes[i].normalized() * 2.0 * half, "target cross arm %d along the target's axis" % i)
	var p: PackedVector3Array = lines["pole"]
	var pole: Vector3 = rig["markers"]["Pole"].global_position
	check_eq(_segments(p), 4, "pole cross + line to the middle joint")
	_check_point((p[0] + p[1]) * 0.5, pole, "pole cross centred")
	_check_point(p[6], _fk_world()[2].origin, "pole line from the middle joint (j1)")
	_check_point(p[7], pole, "pole line to the pole")
	var g: PackedVector3Array = lines["goals"]
	check_eq(_segments(g), 3, "one cross per goal with a target (a null entry is skipped)")
	_check_point((g[0] + g[1]) * 0.5, rig["markers"]["GoalTarget"].global_position, "goal cross centred")
	# target_transform stands in when target is empty.
	ik.target = NodePath()
	ik.target_transform = Transform3D(Basis(), Vector3(3, 2, 1))
	t = Drawer.build(ik)["target"]
	check_eq(_segments(t), 3, "cross at target_transform")
	_check_point((t[0] + t[1]) * 0.5, Vector3(3, 2, 1), "cross at target_transform's origin")


func test_extended_tip_and_aim_line() -> void:
	var rig := _make_rig(true)
	var ik: FakeChain = rig["ik"]
	ik.tip_extension_axis = 4  # AXIS_PLUS_Z
	ik.tip_extension_length = 0.2
	ik.goal_mode = Drawer.GOAL_MODE_AIM
	ik.target = ik.get_path_to(rig["markers"]["Target"])
	var lines := Drawer.build(ik)
	var fk := _fk_world()
	var effector: Vector3 = fk[4] * Vector3(0, 0, 0.2)
	var bones: PackedVector3Array = lines["bones"]
	check_eq(_segments(bones), N + 1, "the tip bone is a joint too")
	_check_point(bones[2 * N], fk[4].origin, "last bone starts at the tip bone")
	_check_point(bones[2 * N + 1], effector, "last bone ends at the extension")
	var t: PackedVector3Array = lines["target"]
	check_eq(_segments(t), 4, "target cross + aim line")
	_check_point(t[6], effector, "aim line from the effector")
	_check_point(t[7], rig["markers"]["Target"].global_position, "aim line to the target")


func test_problems_are_named() -> void:
	var rig := _make_rig()
	var ik: FakeChain = rig["ik"]
	ik.chain_bones = PackedInt32Array([99])
	var lines := Drawer.build(ik)
	check(lines["problems"].size() == 1 and lines["problems"][0].contains("bone 99"), "bad bone index named: %s" % [lines["problems"]])
	check_eq(_segments(lines["bones"]), 0, "nothing drawn for a bad chain")
	var orphan := FakeChain.new()
	case_root.add_child(orphan)
	lines = Drawer.build(orphan)
	check(lines["problems"].size() == 1 and lines["problems"][0].contains("Skeleton3D"), "no skeleton named: %s" % [lines["problems"]])
	var no_api := Node3D.new()
	rig["skeleton"].add_child(no_api)
	lines = Drawer.build(no_api)
	check(lines["problems"].size() == 1 and lines["problems"][0].contains("get_chain_bones"), "missing API named: %s" % [lines["problems"]])
	var loose := Arm.make_skeleton(N)  # never added to the tree: no global transforms to read
	var loose_ik := FakeChain.new()
	loose.add_child(loose_ik)
	lines = Drawer.build(loose_ik)
	check(lines["problems"].size() == 1 and lines["problems"][0].contains("scene tree"), "outside the tree named: %s" % [lines["problems"]])
	loose.free()


func test_debug_draw_redraws_on_skeleton_update() -> void:
	var rig := _make_rig()
	var ik: FakeChain = rig["ik"]
	ik.target = ik.get_path_to(rig["markers"]["Target"])
	var view := DebugDraw.new()
	case_root.add_child(view)
	view.ik_chain = view.get_path_to(ik)
	var skel: Skeleton3D = rig["skeleton"]
	skel.set_bone_pose_rotation(skel.find_bone("j1"), Quaternion(Vector3(1, 0, 0), 0.2))
	await skel.skeleton_updated
	await process_frame  # leave the signal's emission before the case's nodes are freed
	var bones: PackedVector3Array = view.last_lines.get("bones", PackedVector3Array())
	check_eq(_segments(bones), N, "bones drawn after the update")
	var mesh: ImmediateMesh = view.get_child(0, true).mesh
	check_eq(mesh.get_surface_count(), 1, "one line surface")
	var vertices: PackedVector3Array = mesh.surface_get_arrays(0)[Mesh.ARRAY_VERTEX]
	check_eq(vertices.size(), bones.size() + 6, "one vertex per segment end (bones + target cross)")
	_check_point(vertices[0], bones[0], "the mesh's first vertex is the first bone's start")
	# The posed j2 moved with j1's new rotation: the drawing follows the skeleton, not a cache.
	var j2 := skel.global_transform * skel.get_bone_global_pose(skel.find_bone("j2"))
	_check_point(bones[3], j2.origin, "j1's segment ends at the re-posed j2")
	view.visible = false
	check_eq(mesh.get_surface_count(), 0, "hidden: nothing drawn")
	check(view.last_lines.is_empty(), "hidden: no lines kept")


## The real node: everything the drawer reads must exist (node_api.md). Until the node has that
## API this fails and names what is missing; then it checks the drawing of a solved chain.
func test_real_ik_chain() -> void:
	var ik: Node = ClassDB.instantiate("IKChain")
	var missing := []
	for p in ["root_bone", "tip_bone", "extend_tip_bone", "tip_extension_axis", "tip_extension_length",
			"target", "target_transform", "goal_mode", "pole_target", "joints", "goals"]:
		if not p in ik:
			missing.append("property " + p)
	if not ik.has_method("get_chain_bones"):
		missing.append("method get_chain_bones()")
	for cls in ["IKChainJoint", "IKChainGoal"]:
		if not ClassDB.class_exists(cls):
			missing.append("class " + cls)
	ik.free()
	if not missing.is_empty():
		fail("IKChain lacks what the gizmo drawer reads (notes/node_api.md): " + ", ".join(missing))
		return
	var skel := Arm.make_skeleton(N)
	ik = ClassDB.instantiate("IKChain")
	ik.set("root_bone", "j0")
	ik.set("tip_bone", "tip")
	var knee: Resource = ClassDB.instantiate("IKChainJoint")
	knee.set("bone_name", "j1")
	knee.set("type", 1)
	knee.set("hinge_axis", Vector3(1, 0, 0))
	knee.set("hinge_limit_enabled", true)
	knee.set("hinge_min", -0.5)
	knee.set("hinge_max", 1.0)
	var joints: Array = ik.get("joints")
	joints.append(knee)
	ik.set("joints", joints)
	var target := Marker3D.new()
	target.position = Arm.fk_tip_world(N, ROTATIONS)
	case_root.add_child(target)
	skel.add_child(ik)
	case_root.add_child(skel)
	ik.set("target", ik.get_path_to(target))
	var seen := {}
	skel.skeleton_updated.connect(func():
		seen["lines"] = Drawer.build(ik)
		seen["globals"] = Arm.compose_globals(skel), CONNECT_ONE_SHOT)
	skel.set_bone_pose_rotation(skel.find_bone("j0"), Quaternion(Vector3(0, 0, 1), 0.1))
	await skel.skeleton_updated
	await process_frame  # leave the signal's emission before the case's nodes are freed
	check(seen.has("lines"), "drawn inside skeleton_updated")
	if not seen.has("lines"):
		return
	var lines: Dictionary = seen["lines"]
	check_eq(lines["problems"], PackedStringArray(), "no problems with a configured IKChain")
	check_eq(Array(ik.call("get_chain_bones")), [skel.find_bone("j0"), skel.find_bone("j1"), skel.find_bone("j2")],
			"get_chain_bones()")
	var bones: PackedVector3Array = lines["bones"]
	check_eq(_segments(bones), N, "one bone segment per joint")
	var globals: Array = seen["globals"]
	for k in N:
		var want := skel.global_transform * (globals[skel.find_bone("j%d" % k)] as Transform3D).origin
		_check_point(bones[2 * k], want, "bone %d starts at the solved j%d" % [k, k])
	_check_point(bones[2 * N - 1], skel.global_transform * (globals[skel.find_bone("tip")] as Transform3D).origin,
			"last bone ends at the solved tip")
	check_eq(_segments(lines["limits"]), ceili(1.5 / (PI / 16)) + 2, "the knee's hinge arc + 2 radii")
	check_eq(_segments(lines["target"]), 3, "target cross")


## Issue 16 item 12: the gizmo with two IKChains of one skeleton selected. Each chain connected
## its own skeleton_updated handler: the second was refused ("Signal 'skeleton_updated' is already
## connected", an ERROR line the runner fails on) and that chain was drawn at the unsolved pose.
## The gizmo's line cache (gizmo/ik_chain_gizmo_lines.gd, what the editor plugin draws) must draw
## both at their solved poses, and drop the connection with the last chain.
func test_gizmo_two_chains_on_one_skeleton() -> void:
	const Lines := preload("res://addons/ikchain/gizmo/ik_chain_gizmo_lines.gd")
	var skel := Arm.make_skeleton(N)
	# A second arm on the same base: k0 -> k1 -> ktip.
	var k0 := skel.add_bone("k0")
	skel.set_bone_parent(k0, skel.find_bone("base"))
	skel.set_bone_rest(k0, Transform3D(Basis(), Vector3(-0.2, 0.1, 0)))
	var k1 := skel.add_bone("k1")
	skel.set_bone_parent(k1, k0)
	skel.set_bone_rest(k1, Transform3D(Basis(), Vector3(0, 0.4, 0)))
	var ktip := skel.add_bone("ktip")
	skel.set_bone_parent(ktip, k1)
	skel.set_bone_rest(ktip, Transform3D(Basis(), Vector3(0, 0.3, 0)))
	skel.reset_bone_poses()
	case_root.add_child(skel)
	var goals := {"A": Arm.fk_tip_world(N, ROTATIONS)}
	var k0_world := skel.global_transform * skel.get_bone_global_pose(k0).origin
	goals["B"] = k0_world + Vector3(-0.3, 0.4, 0.2).normalized() * 0.5
	var chains := {}
	for name in ["A", "B"]:
		var target := Marker3D.new()
		target.name = "Target" + name
		case_root.add_child(target)
		target.global_position = goals[name]
		var ik := IKChain.new()
		ik.name = "IK" + name
		ik.root_bone = "j0" if name == "A" else "k0"
		ik.tip_bone = "tip" if name == "A" else "ktip"
		ik.solver = IKChain.SOLVER_DLS
		skel.add_child(ik)
		ik.target = ik.get_path_to(target)
		chains[name] = ik
	var lines := Lines.new()
	var changed := {}
	lines.lines_changed.connect(func(ik: Node3D): changed[ik.name] = changed.get(ik.name, 0) + 1)
	lines.watch(chains["A"])
	lines.watch(chains["B"])
	lines.watch(chains["B"])  # a redraw watches again: nothing new
	check_eq(skel.skeleton_updated.get_connections().size(), 1, "one connection for the skeleton's two chains")
	await frames(3)
	for name in ["A", "B"]:
		var ik: IKChain = chains[name]
		check(changed.get(StringName("IK" + name), 0) > 0, "chain %s: lines rebuilt in the skeleton's update" % name)
		var bones: PackedVector3Array = lines.lines_of(ik)["bones"]
		if check(bones.size() >= 2, "chain %s: bones drawn" % name):
			_check_point(bones[bones.size() - 1], goals[name], "chain %s: drawn effector at its solved target" % name)
	lines.unwatch(chains["A"].get_instance_id())
	check_eq(skel.skeleton_updated.get_connections().size(), 1, "still connected for chain B")
	lines.unwatch(chains["B"].get_instance_id())
	check_eq(skel.skeleton_updated.get_connections().size(), 0, "disconnected with the last chain")
