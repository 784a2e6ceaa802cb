extends "res://lib/ik_test.gd"
## The demo scenes (godot_project/demo/) load and run headless without an error, and the arm-reach
## scene does what its panel claims: six limited hinges, the hand on the target's position and
## rotation, the solver switched live, the run-time gizmo drawn on demand.

const ARM := "res://demo/arm_reach.tscn"
const MISSILE := "res://demo/missile_guidance.tscn"
const MENU := "res://demo/menu.tscn"


func _frames(n: int) -> void:
	for i in n:
		await process_frame


func test_menu_loads() -> void:
	var menu: Control = (load(MENU) as PackedScene).instantiate()
	case_root.add_child(menu)
	await _frames(2)
	check(menu.get_node_or_null("Center/VBox/ArmReach/VBox/Open") is Button, "the arm reach button")
	check(menu.get_node_or_null("Center/VBox/MissileGuidance/VBox/Open") is Button, "the missile guidance button")
	for path in menu.SCENES.values():
		check(ResourceLoader.exists(path), "the menu's scene %s exists" % path)


func test_arm_reach_tracks_position_and_rotation() -> void:
	var scene: Node3D = (load(ARM) as PackedScene).instantiate()
	case_root.add_child(scene)
	var ik: IKChain = scene.ik
	check_eq(ik.get_chain_bones().size(), 6, "joints in the chain")
	var hinges := 0
	for joint in ik.joints:
		var j := joint as IKChainJoint
		if j.type == IKChainJoint.JOINT_HINGE and j.hinge_limit_enabled and j.hinge_min < j.hinge_max:
			hinges += 1
	check_eq(hinges, 6, "hinges with limits")
	check(ik.use_target_rotation, "the hand takes the target's rotation")
	# Two seconds of the wander path: the pose the skeleton shows (measured by the scene in
	# skeleton_updated, not the solver's report) stays on the moving target.
	var worst_position := 0.0
	var worst_orientation := 0.0
	for i in 120:
		await process_frame
		if i >= 5:
			worst_position = maxf(worst_position, scene.last_position_error)
			worst_orientation = maxf(worst_orientation, scene.last_orientation_error)
	check_le(worst_position, 1e-3, "worst hand position error over 115 frames (m)")
	check_le(worst_orientation, deg_to_rad(0.5), "worst hand orientation error over 115 frames (rad)")
	var r: Dictionary = ik.get_last_result()
	check(r.get("reached", false), "the last solve reached: %s" % r)
	check(scene.stats_label.text.begins_with("REACHED"), "the panel shows it: %s" % scene.stats_label.text)


func test_arm_reach_switches_solver_live() -> void:
	var scene: Node3D = (load(ARM) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _frames(3)
	for pair in [[IKChain.SOLVER_BFGS, "BFGS"], [IKChain.SOLVER_JACOBIAN, "Jacobian"], [IKChain.SOLVER_DLS, "Damped"]]:
		scene.set_solver(pair[0])
		await _frames(3)
		var r: Dictionary = scene.ik.get_last_result()
		check(str(r.get("solver", "")).begins_with(pair[1]), "solver after switching: %s, want %s" % [r.get("solver"), pair[1]])
		check_eq(scene.solver_menu.get_selected_id(), pair[0], "the menu follows")
		check_le(scene.last_position_error, 1e-3, "%s keeps the hand on the target (m)" % pair[1])


func test_arm_reach_gizmo_toggle() -> void:
	var scene: Node3D = (load(ARM) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _frames(2)
	check(not scene.gizmo.visible, "the gizmo starts hidden")
	scene.show_gizmo.button_pressed = true
	await _frames(2)
	check(scene.gizmo.visible, "the check box shows it")
	var limits: PackedVector3Array = scene.gizmo.last_lines.get("limits", PackedVector3Array())
	var bones: PackedVector3Array = scene.gizmo.last_lines.get("bones", PackedVector3Array())
	check(limits.size() > 0 and bones.size() > 0,
			"it draws the chain and the limits: %d limit and %d bone vertices" % [limits.size(), bones.size()])
	scene.show_gizmo.button_pressed = false
	await _frames(1)
	check(scene.gizmo.last_lines.is_empty(), "hidden again, it draws nothing")


func test_arm_reach_mouse_drag() -> void:
	var scene: Node3D = (load(ARM) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _frames(2)
	var camera: Camera3D = scene.camera
	var start: Vector3 = scene.target.global_position
	var press := InputEventMouseButton.new()
	press.button_index = MOUSE_BUTTON_LEFT
	press.pressed = true
	press.position = camera.unproject_position(start)
	scene._unhandled_input(press)
	var motion := InputEventMouseMotion.new()
	# A few centimetres whatever the (headless) viewport's size.
	motion.position = press.position - 0.04 * Vector2(scene.get_viewport().get_visible_rect().size.y, scene.get_viewport().get_visible_rect().size.y)
	scene._unhandled_input(motion)
	var moved: Vector3 = scene.target.global_position
	check(moved.distance_to(start) > 0.01 and moved.distance_to(start) < 0.3,
			"dragging moved the target a little: %s → %s" % [start, moved])
	check_near(camera.unproject_position(moved).distance_to(motion.position), 0.0, 0.5,
			"the target stays under the mouse (px)")
	check_near((moved - start).dot(camera.global_basis.z), 0.0, 1e-4, "in the plane facing the camera")
	await _frames(30)
	check_le(scene.last_position_error, 1e-3, "the hand followed the dragged target (m)")
	var release := InputEventMouseButton.new()
	release.button_index = MOUSE_BUTTON_LEFT
	release.pressed = false
	scene._unhandled_input(release)
	check(not scene._dragging, "released")


func test_missile_guidance_loads_and_aims() -> void:
	var scene: Node3D = (load(MISSILE) as PackedScene).instantiate()
	scene.fixed_dt = 1.0 / 60.0
	case_root.add_child(scene)
	await _frames(60)
	var ik: IKChain = scene.ik
	check_eq(ik.goal_mode, IKChain.GOAL_MODE_AIM, "goal mode")
	check_eq(ik.get_chain_bones().size(), 4, "yaw, shoulder, elbow, barrel")
	check_le(scene.aim_error, deg_to_rad(0.2), "the barrel's aim error after one second (rad)")
	check(scene.stats_label.text.begins_with("aim error"), "the panel shows the figures: %s" % scene.stats_label.text)


# ------------------------------------------------------------------ the character

const CHARACTER := "res://demo/character.tscn"
const HUMANOID_BONES := ["Root", "Hips", "Spine", "Chest", "UpperChest", "Neck", "Head",
		"LeftShoulder", "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightShoulder", "RightUpperArm",
		"RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToes",
		"RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"]


func _physics_frames(n: int) -> void:
	for i in n:
		await physics_frame


## The largest distance of a planted foot from its target over `n` physics frames (m).
func _worst_planted(scene: Node3D, n: int) -> float:
	var worst := 0.0
	for i in n:
		await physics_frame
		for j in 2:
			var bone: String = ["LeftFoot", "RightFoot"][j]
			if not scene.body.feet[j].swinging and scene.position_errors.has(bone):
				worst = maxf(worst, scene.position_errors[bone])
	return worst


## The planted-foot bound: IKBody's tolerance, or the stand-in's analytic legs (exact when the
## hips leave both feet in reach).
func _planted_bound(scene: Node3D) -> float:
	return scene.PLANTED_TOLERANCE if scene.ik_body != null else 1e-4


func test_character_skeleton_is_humanoid() -> void:
	var scene: Node3D = (load(CHARACTER) as PackedScene).instantiate()
	case_root.add_child(scene)
	var skeleton: Skeleton3D = scene.skeleton
	var profile := SkeletonProfileHumanoid.new()
	check_eq(skeleton.get_bone_count(), HUMANOID_BONES.size(), "bones")
	for bone in HUMANOID_BONES:
		var i := skeleton.find_bone(bone)
		var p := profile.find_bone(bone)
		if check(i >= 0 and p >= 0, "bone %s in the skeleton and the profile" % bone) and bone != "Root":
			check_eq(skeleton.get_bone_name(skeleton.get_bone_parent(i)), str(profile.get_bone_parent(p)), "%s's parent" % bone)
	# The CMU proportions (subject 01): about 1.6 m tall, legs about 0.83 m hip to ankle.
	var head := skeleton.get_bone_global_rest(skeleton.find_bone("Head")).origin
	check(head.y > 1.35 and head.y < 1.5, "the head joint's height %.3f m" % head.y)
	var hip := skeleton.get_bone_global_rest(skeleton.find_bone("LeftUpperLeg")).origin
	var ankle := skeleton.get_bone_global_rest(skeleton.find_bone("LeftFoot")).origin
	check_near(hip.distance_to(ankle), 0.835, 0.01, "hip to ankle (m)")
	# Knees bend about their own +X as on the profile: a positive turn moves the ankle backward.
	var knee := skeleton.find_bone("LeftLowerLeg")
	var foot := skeleton.find_bone("LeftFoot")
	skeleton.set_bone_pose_rotation(knee, skeleton.get_bone_rest(knee).basis.get_rotation_quaternion() * Quaternion(Vector3.RIGHT, 0.5))
	var bent := skeleton.get_bone_global_pose(foot).origin
	check(bent.z < ankle.z - 0.1, "a knee turned about +X moves the ankle back: z %.3f -> %.3f" % [ankle.z, bent.z])
	skeleton.reset_bone_poses()
	var menu: Control = (load(MENU) as PackedScene).instantiate()
	case_root.add_child(menu)
	check(menu.get_node_or_null("Center/VBox/Character/VBox/Open") is Button, "the menu's character button")
	check_eq(menu.SCENES.get("character"), CHARACTER, "the menu opens it")


func test_character_walks_with_planted_feet() -> void:
	var scene: Node3D = (load(CHARACTER) as PackedScene).instantiate()
	case_root.add_child(scene)
	check(scene.ik_body != null or scene.standin != null, "IKBody or the stand-in poses the body")
	for bone in scene.EFFECTORS:
		check(scene.targets.get(bone) is Marker3D, "a target for %s" % bone)
	# Three seconds of the walk on flat ground: steps, feet planted on their targets.
	var worst: float = await _worst_planted(scene, 180)
	check(scene.landings >= 3, "landings in 3 s of walking: %d" % scene.landings)
	check_le(worst, _planted_bound(scene), "worst planted foot error (m)")
	check(scene.stats_label.text.contains("µs per character"), "the HUD shows the figures: %s" % scene.stats_label.text)
	var hips_y: float = scene.targets["Hips"].global_position.y
	check(hips_y > 0.85 and hips_y < 1.01, "the hips walk a little below their rest height: %.3f m" % hips_y)


func test_character_feet_follow_the_ramp_and_steps() -> void:
	var scene: Node3D = (load(CHARACTER) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _physics_frames(2)
	scene.restart_at(3.8)  # just before the ramp
	var ramp_normal := Vector3(-0.3, 2.0, 0.0).normalized()
	var tilted := 0
	var on_steps := 0
	var worst := 0.0
	for i in 330:  # up the ramp, over the landing, down both steps
		await physics_frame
		for j in 2:
			var foot = scene.body.feet[j]
			if foot.swinging:
				continue
			var up: Vector3 = foot.planted.basis * foot.rest_basis.inverse() * Vector3.UP
			var x: float = foot.contact.x
			if x > 0.1 and x < 1.9:
				check_le(up.angle_to(ramp_normal), deg_to_rad(0.5), "a sole on the ramp along its normal (rad)")
				tilted += 1
			elif x > 3.25 and x < 3.85:
				check_le(up.angle_to(Vector3.UP), deg_to_rad(0.5), "a sole on a step is level (rad)")
				check_near(foot.contact.y, 0.2 if x < 3.55 else 0.1, 1e-3, "the step's height (m)")
				on_steps += 1
			var bone: String = ["LeftFoot", "RightFoot"][j]
			if scene.position_errors.has(bone):
				worst = maxf(worst, scene.position_errors[bone])
	check(tilted > 0, "a foot planted on the ramp")
	check(on_steps > 0, "a foot planted on a step")
	check_le(worst, _planted_bound(scene), "worst planted foot error over the ramp and steps (m)")


func test_character_picks_the_crate_up() -> void:
	var scene: Node3D = (load(CHARACTER) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _physics_frames(2)
	scene.restart_at(scene.phase_start("pick") + 0.7)
	await _physics_frames(80)  # reaching done, gripping
	check_eq(scene.lap["phase"], "pick", "phase")
	check_near(scene.body.reach_weight, 1.0, 1e-3, "the hands are on their reach points")
	var crate_y: float = scene.crate.global_position.y
	check_near(crate_y, scene.CRATE_SIZE * 0.5, 1e-3, "the crate still on the floor (m)")
	var hips_y: float = scene.targets["Hips"].global_position.y
	check(hips_y < 0.75, "the hips crouch for it: %.3f m" % hips_y)
	var worst: float = await _worst_planted(scene, 90)  # the lift
	check(scene.crate.global_position.y > 0.6, "the crate lifted: %.3f m" % scene.crate.global_position.y)
	check_le(worst, _planted_bound(scene), "the feet stay planted while the hands reach and lift (m)")
	if scene.ik_body != null:
		var hands: float = maxf(scene.position_errors["LeftHand"], scene.position_errors["RightHand"])
		check_le(hands, 0.02, "IKBody's hands on the crate (m)")


## Stands in for IKBody's script API (the class is not in every build): what the scene wires.
class MockEffector extends Resource:
	var bone_name := ""
	var target := NodePath()
	var priority := 1
	var position_weight := 1.0
	var rotation_weight := 0.0
	var enabled := true


class MockIKBody extends Node:
	var effectors: Array = []
	var floating_root := false

	func setup_humanoid() -> void:
		for bone in ["Hips", "LeftHand", "RightHand", "LeftFoot", "RightFoot", "Head", "LeftToes"]:
			var e := MockEffector.new()
			e.bone_name = bone
			effectors.append(e)

	func get_last_usec() -> int:
		return 7


func test_character_wires_ik_body_by_bone_name() -> void:
	var scene: Node3D = (load(CHARACTER) as PackedScene).instantiate()
	case_root.add_child(scene)
	await _frames(2)
	var body := MockIKBody.new()
	scene.use_ik_body(body)
	check_eq(body.get_parent(), scene.skeleton, "the IKBody under the skeleton")
	check(body.floating_root, "a floating root")
	for e: MockEffector in body.effectors:
		if e.bone_name == "LeftToes":
			check(not e.enabled, "an effector without a target in the scene is disabled")
			continue
		var want: Array = scene.EFFECTORS[e.bone_name]
		check_eq(body.get_node_or_null(e.target), scene.targets[e.bone_name], "%s's target path" % e.bone_name)
		check_eq(e.priority, want[0], "%s's priority" % e.bone_name)
		check_eq(e.position_weight, want[1], "%s's position weight" % e.bone_name)
		check_eq(e.rotation_weight, want[2], "%s's rotation weight" % e.bone_name)
		check(e.enabled, "%s enabled" % e.bone_name)
	check_eq(scene.last_usec(), 7.0, "µs from get_last_usec()")
	await _frames(2)
	check(scene.stats_label.text.contains("7 µs per character"), "the HUD shows IKBody's µs: %s" % scene.stats_label.text)
