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
