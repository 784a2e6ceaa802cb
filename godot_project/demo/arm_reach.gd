extends Node3D
## Arm reach: a robot arm of six hinges with limits (waist, shoulder, elbow, forearm roll, wrist,
## wrist roll) whose hand takes the target's position and rotation through one IKChain
## (use_target_rotation). Drag the target with the mouse (it moves in the plane facing the
## camera; the wheel turns it while dragging); left alone it wanders. The panel switches the
## solver live, shows the last solve's result and toggles the run-time gizmo
## (addons/ikchain/ik_chain_debug_draw.gd). Options: see demo_cli.gd.

const Cli := preload("res://demo/demo_cli.gd")

## Seconds without dragging before the target wanders again.
const IDLE_BEFORE_WANDER := 2.0
## How near the mouse ray must pass to the target's handle to pick it (m).
const PICK_RADIUS := 0.09

@onready var skeleton: Skeleton3D = $Arm
@onready var ik: IKChain = $Arm/IKChain
@onready var target: Marker3D = $Target
@onready var camera: Camera3D = $Camera3D
@onready var gizmo: Node3D = $IKGizmo
@onready var solver_menu: OptionButton = $UI/Panel/VBox/SolverRow/Solver
@onready var show_gizmo: CheckBox = $UI/Panel/VBox/ShowGizmo
@onready var match_rotation: CheckBox = $UI/Panel/VBox/MatchRotation
@onready var stats_label: Label = $UI/Panel/VBox/Stats

var options := {}
## Simulated time (s), the wander path's own clock, seconds since the last drag.
var time := 0.0
var wander_time := 0.0
var idle := IDLE_BEFORE_WANDER

var _hand_bone := -1
var _dragging := false
var _drag_plane := Plane()
var _orbiting := false
var _orbit_pivot := Vector3(0.05, 0.72, 0.15)
var _orbit_yaw := 0.0
var _orbit_pitch := 0.0
var _orbit_distance := 1.0
var _last_frame := -1
## Per-frame measures of the pose the skeleton shows (not the solver's own report).
var last_position_error := INF
var last_orientation_error := INF
var _second := Cli.Stats.new()
var _run := Cli.Stats.new()
var _next_report := 1.0
var _finished := false
var _shot_taken := false


func _ready() -> void:
	options = Cli.options()
	if options["solver"] >= 0:
		ik.solver = options["solver"]
	_hand_bone = skeleton.find_bone(ik.tip_bone)
	Cli.fill_solver_menu(solver_menu, ik.solver)
	solver_menu.item_selected.connect(func(index: int): set_solver(solver_menu.get_item_id(index)))
	show_gizmo.toggled.connect(func(on: bool): gizmo.visible = on)
	match_rotation.button_pressed = ik.use_target_rotation
	match_rotation.toggled.connect(func(on: bool): ik.use_target_rotation = on)
	$UI/Panel/VBox/Menu.pressed.connect(back_to_menu)
	skeleton.skeleton_updated.connect(_on_skeleton_updated)
	var offset := camera.global_position - _orbit_pivot
	_orbit_distance = offset.length()
	_orbit_yaw = atan2(offset.x, offset.z)
	_orbit_pitch = asin(offset.y / _orbit_distance)
	if options["screenshot"] != "":
		show_gizmo.button_pressed = true  # the screenshot shows the limits too
	target.global_transform = wander_pose(0.0)
	if options["demo_seconds"] > 0.0:
		print("arm_reach: %d hinges, solver %s, max_iterations %d, %s s of simulated time" % [
				ik.get_chain_bones().size(), Cli.solver_label(ik.solver), ik.max_iterations, options["demo_seconds"]])


## The path the target follows when left alone: loops in front of the arm, a top-down grasp
## that turns and tilts, in reach of the hand and inside the joints' limits. A hand pointing
## along the forearm would put the wrist in its singular pose (forearm and wrist rolls on one
## axis, free to wind up against their limits), so the path keeps the wrist bent.
func wander_pose(t: float) -> Transform3D:
	var origin := Vector3(0.3 * sin(0.7 * t), 0.6 + 0.15 * sin(1.1 * t + 0.5), 0.7 + 0.12 * sin(0.9 * t))
	var basis := Basis(Vector3.UP, 0.6 * sin(0.5 * t)) * Basis(Vector3.RIGHT, deg_to_rad(155.0) + 0.3 * sin(0.8 * t))
	return Transform3D(basis, origin)


func set_solver(solver: int) -> void:
	ik.solver = solver
	solver_menu.select(maxi(solver_menu.get_item_index(solver), 0))
	if options.get("demo_seconds", 0.0) > 0.0:
		print("arm_reach: solver -> %s" % Cli.solver_label(solver))


func back_to_menu() -> void:
	get_tree().change_scene_to_file("res://demo/menu.tscn")


func _process(delta: float) -> void:
	if _finished:
		return
	time += delta
	if not _dragging:
		idle += delta
	if idle >= IDLE_BEFORE_WANDER:
		# Ease from wherever the user left the target back onto the path.
		wander_time += delta
		var goal := wander_pose(wander_time)
		var k := 1.0 - exp(-3.0 * delta)
		var current := target.global_transform
		target.global_transform = Transform3D(
				current.basis.orthonormalized().slerp(goal.basis, k), current.origin.lerp(goal.origin, k))
	var r := ik.get_last_result()
	stats_label.text = _result_text(r)
	if options["screenshot"] != "" and not _shot_taken and time >= options["screenshot_at"]:
		_shot_taken = true
		var err: int = await Cli.save_screenshot(get_viewport(), options["screenshot"])
		get_tree().quit(0 if err == OK else 1)
	elif options["demo_seconds"] > 0.0 and time >= options["demo_seconds"]:
		_finish()


func _result_text(r: Dictionary) -> String:
	if str(r.get("reason", "not_run")) == "not_run":
		return "no solve yet"
	var lines := PackedStringArray()
	lines.append("%s: %s" % ["REACHED" if r.get("reached", false) else "not reached", r.get("reason", "?")])
	lines.append("solver ran: %s" % r.get("solver", "?"))
	lines.append("iterations: %d" % int(r.get("iterations", 0)))
	lines.append("error: %.3f mm, %.3f°" % [1000.0 * float(r.get("position_error", NAN)),
			rad_to_deg(float(r.get("orientation_error", NAN)))])
	lines.append("time: %.1f µs per solve" % float(r.get("microseconds", NAN)))
	if str(r.get("message", "")) != "":
		lines.append(str(r["message"]))
	return "\n".join(lines)


# ------------------------------------------------------------------ mouse and keys

func _unhandled_input(event: InputEvent) -> void:
	var button := event as InputEventMouseButton
	if button != null:
		if button.button_index == MOUSE_BUTTON_LEFT:
			if button.pressed:
				_dragging = _pick(button.position)
				if _dragging:
					_drag_plane = Plane(-camera.global_basis.z, target.global_position)
					idle = 0.0
			else:
				_dragging = false
		elif button.button_index == MOUSE_BUTTON_RIGHT:
			_orbiting = button.pressed
		elif _dragging and button.pressed and button.button_index in [MOUSE_BUTTON_WHEEL_UP, MOUSE_BUTTON_WHEEL_DOWN]:
			var angle := deg_to_rad(10.0) * (1.0 if button.button_index == MOUSE_BUTTON_WHEEL_UP else -1.0)
			var axis := -camera.global_basis.z
			target.global_basis = Basis(axis, angle) * target.global_basis
		return
	var motion := event as InputEventMouseMotion
	if motion != null:
		if _dragging:
			var hit: Variant = _drag_plane.intersects_ray(camera.project_ray_origin(motion.position),
					camera.project_ray_normal(motion.position))
			if hit != null:
				target.global_position = hit
			idle = 0.0
		elif _orbiting:
			_orbit_yaw -= motion.relative.x * 0.008
			_orbit_pitch = clampf(_orbit_pitch + motion.relative.y * 0.008, -0.2, 1.3)
			var offset := Vector3(sin(_orbit_yaw) * cos(_orbit_pitch), sin(_orbit_pitch), cos(_orbit_yaw) * cos(_orbit_pitch))
			camera.global_position = _orbit_pivot + offset * _orbit_distance
			camera.look_at(_orbit_pivot)
		return
	var key := event as InputEventKey
	if key != null and key.pressed and not key.echo:
		if key.keycode >= KEY_1 and key.keycode < KEY_1 + Cli.SOLVERS.size():
			set_solver(Cli.SOLVERS[key.keycode - KEY_1][1])
		elif key.keycode == KEY_G:
			show_gizmo.button_pressed = not show_gizmo.button_pressed
		elif key.keycode == KEY_R:
			match_rotation.button_pressed = not match_rotation.button_pressed
		elif key.keycode == KEY_ESCAPE:
			back_to_menu()


## Does the ray under `screen_point` pass within PICK_RADIUS of the target?
func _pick(screen_point: Vector2) -> bool:
	var from := camera.project_ray_origin(screen_point)
	var dir := camera.project_ray_normal(screen_point)
	var to_target := target.global_position - from
	var along := to_target.dot(dir)
	return along > 0.0 and (to_target - dir * along).length() <= PICK_RADIUS


# ------------------------------------------------------------------ measuring

# The modified pose is visible only inside the skeleton's update, so measure here.
func _on_skeleton_updated() -> void:
	var frame := Engine.get_process_frames()
	if _finished or frame == _last_frame:
		return  # one sample per frame (the skeleton may update more than once)
	_last_frame = frame
	var hand := skeleton.global_transform * skeleton.get_bone_global_pose(_hand_bone)
	var goal := target.global_transform
	last_position_error = hand.origin.distance_to(goal.origin)
	last_orientation_error = (hand.basis.orthonormalized().inverse() * goal.basis.orthonormalized()).get_rotation_quaternion().get_angle()
	var r := ik.get_last_result()
	for stats in [_second, _run]:
		stats.add("position", last_position_error)
		stats.add("orientation", last_orientation_error)
		stats.add("reached", 1.0 if r.get("reached", false) else 0.0)
		stats.add("iterations", float(r.get("iterations", 0)))
		stats.add("micros", float(r.get("microseconds", 0.0)))
	if options["demo_seconds"] > 0.0 and time >= _next_report:
		_next_report += 1.0
		print("arm_reach t=%2.0f s: solver %s | mean error %.3f mm, %.3f° | reached %3.0f %% | %.1f iterations | %.1f µs per solve" % [
				time, str(r.get("solver", "?")), 1000.0 * _second.mean("position"), rad_to_deg(_second.mean("orientation")),
				100.0 * _second.mean("reached"), _second.mean("iterations"), _second.mean("micros")])
		_second.clear()


## Mean tracking error over the run must stay within 1 mm and 0.5° (the arm's six joints can
## match position and rotation everywhere on the wander path).
func _finish() -> void:
	_finished = true
	var frames := _run.count("position")
	var position_mm := 1000.0 * _run.mean("position")
	var orientation_deg := rad_to_deg(_run.mean("orientation"))
	var why := ""
	if frames < 10:
		why = "too few skeleton updates (%d)" % frames
	elif not (position_mm <= 1.0):
		why = "mean position error %.3f mm > 1 mm" % position_mm
	elif ik.use_target_rotation and not (orientation_deg <= 0.5):
		why = "mean orientation error %.3f° > 0.5°" % orientation_deg
	print("arm_reach summary: %d frames, mean error %.4f mm, %.4f°, reached %.0f %%, %.1f iterations, %.1f µs per solve" % [
			frames, position_mm, orientation_deg, 100.0 * _run.mean("reached"), _run.mean("iterations"), _run.mean("micros")])
	print("demo: PASS arm_reach: the hand tracked the target within %.3f mm, %.3f° (mean)" % [position_mm, orientation_deg] if why == ""
			else "demo: FAIL arm_reach: %s" % why)
	get_tree().quit(0 if why == "" else 1)
