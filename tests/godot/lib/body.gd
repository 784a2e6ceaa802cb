# Fixtures of the IKBody tests (test_ik_body.gd, test_ik_body_features.gd): a humanoid Skeleton3D
# built from Godot's SkeletonProfileHumanoid (names, parents, reference poses: what a retargeted
# glTF/FBX humanoid has), bare or set up under an IKBody, an effector whose target is a sibling of
# the skeleton, target nodes, the body's configuration warnings as one string and the angle between
# two rotations.

static func humanoid() -> Skeleton3D:
	var profile := SkeletonProfileHumanoid.new()
	var skel := Skeleton3D.new()
	skel.name = "Skeleton"
	for i in profile.bone_size:
		skel.add_bone(profile.get_bone_name(i))
	for i in profile.bone_size:
		var parent: StringName = profile.get_bone_parent(i)
		if parent != &"":
			skel.set_bone_parent(i, skel.find_bone(parent))
		skel.set_bone_rest(i, profile.get_reference_pose(i))
	skel.reset_bone_poses()
	return skel


## humanoid() under `parent` (the case root) with an IKBody under it, set up by setup_humanoid().
static func set_up_humanoid(parent: Node) -> IKBody:
	var skel := humanoid()
	parent.add_child(skel)
	var body := IKBody.new()
	skel.add_child(body)
	body.setup_humanoid()
	return body


## A target node named `name` at `t` under `parent` (the case root: a sibling of the skeleton).
static func target(parent: Node, name: String, t: Transform3D) -> Node3D:
	var n := Node3D.new()
	n.name = name
	n.transform = t
	parent.add_child(n)
	return n


static func warnings(body: IKBody) -> String:
	return "\n".join(body._get_configuration_warnings())


## The angle between two rotations (rad), accurate for small angles (Quaternion.angle_to's acos
## loses float precision near 0: ~7e-4 rad of noise).
static func angle(a: Quaternion, b: Quaternion) -> float:
	var d := minf((a - b).length(), (a + b).length())
	return 4.0 * asin(minf(d * 0.5, 1.0))


static func effector(bone: String, target: Node3D, priority := 1, position_weight := 1.0,
		rotation_weight := 0.0) -> IKBodyEffector:
	var e := IKBodyEffector.new()
	e.bone_name = bone
	e.priority = priority
	e.position_weight = position_weight
	e.rotation_weight = rotation_weight
	if target != null:
		e.target = NodePath("../../" + String(target.name))
	return e


## The skeleton's global and local bone poses (skeleton at the origin: skeleton space = world) at
## the next skeleton_updated, with the body's result (the test's `tree` waits the frames).
## `idle_ok`: a body that writes nothing leaves the skeleton clean, so no skeleton_updated comes;
## the pose is then read after a few frames.
static func capture(tree: SceneTree, skel: Skeleton3D, body: IKBody, idle_ok := false) -> Dictionary:
	var cap := {}
	var grab := func():
		if cap.is_empty():
			var globals := []
			var locals := []
			for i in skel.get_bone_count():
				globals.append(skel.get_bone_global_pose(i))
				locals.append(skel.get_bone_pose(i))
			cap["globals"] = globals
			cap["locals"] = locals
			cap["result"] = body.get_last_result()
	skel.skeleton_updated.connect(grab)
	var waited := 0
	while cap.is_empty() and waited < 4:
		await tree.process_frame
		waited += 1
	skel.skeleton_updated.disconnect(grab)
	if cap.is_empty() and idle_ok:
		grab.call()
	return cap
