extends Node3D
## The character demo: a humanoid (its proportions from CMU motion capture, character/
## build_humanoid.gd) walks a lap over a ramp, a landing and two steps, picks a crate up from the
## floor, puts it back, turns and walks home, its head following a drifting orb. The scene only
## moves effector targets (Marker3D under Targets, written by character/body_targets.gd: foot
## placement by ray casts, the hips' height, the hands, the look); one IKBody node under the
## skeleton poses the whole body onto them, starting from a relaxed stance (RELAXED: arms down,
## elbows a little bent), which is the pose its posture task keeps the spare freedom near.
## Options: demo_cli.gd (--demo-seconds, --screenshot, --screenshot-at, --start-at).

const Cli := preload("res://demo/demo_cli.gd")
const BodyTargets := preload("res://demo/character/body_targets.gd")
const Course := preload("res://demo/character/course.gd")
const ToesOnGround := preload("res://demo/character/toes_on_ground.gd")

## The effectors, their priority (1 = highest: the feet stay planted whatever the hands need)
## and weights [position, rotation]. The head only turns (a look), the hands only reach.
const EFFECTORS := {
	"LeftFoot": [1, 1.0, 1.0], "RightFoot": [1, 1.0, 1.0],
	"LeftHand": [2, 1.0, 0.0], "RightHand": [2, 1.0, 0.0],
	"Head": [3, 0.0, 1.0], "Hips": [4, 1.0, 0.5],
}
const TARGET_COLORS := {
	"Hips": Color(1.0, 0.55, 0.1), "LeftFoot": Color(0.3, 0.95, 0.4), "RightFoot": Color(0.3, 0.95, 0.4),
	"LeftHand": Color(0.25, 0.8, 1.0), "RightHand": Color(0.25, 0.8, 1.0), "Head": Color(1.0, 0.9, 0.2),
}

## The relaxed stance the skeleton holds under the IK (the "animation" IKBody corrects): per bone,
## a turn in the skeleton's space (axis, degrees) on top of its parent's. The T-pose's arms hang
## down, the elbows bend a little forward.
const RELAXED := {
	"LeftUpperArm": [Vector3.BACK, -78.0], "RightUpperArm": [Vector3.BACK, 78.0],
	"LeftLowerArm": [Vector3.LEFT, 15.0], "RightLowerArm": [Vector3.LEFT, 15.0],
}

## The lap (m, s, rad): stand, walk out over the course, pick the crate up and put it down, turn,
## walk back, turn.
const WALK_FROM := -3.0
const WALK_TO := 5.0
const WALK_SPEED := 0.8
const ACCEL_TIME := 0.8
const STAND_TIME := 0.6
const TURN_TIME := 2.8
const PICK_TIME := 7.2
## The crate: its size, how far ahead of the hips' stop it stands, where it is carried, how deep
## the hips crouch for it and how far they move back meanwhile.
const CRATE_SIZE := 0.4
const CRATE_AHEAD := 0.5
const CARRY := Vector3(0.0, 1.0, 0.38)
const CROUCH := 0.34
const CROUCH_BACK := 0.05
## How far the pelvis tilts forward at the deepest crouch (rad).
const PELVIS_TILT := deg_to_rad(40.0)
## A planted foot further than this from its target fails the headless run (m).
const PLANTED_TOLERANCE := 0.01
## While the hands grip the crate on the floor (these seconds into the pick-up), IKBody must hold
## them within this of their targets (m), bending and crouching as needed.
const GRIP := [2.0, 2.4]
const GRIP_TOLERANCE := 0.02

@onready var humanoid: Node3D = $Humanoid
@onready var skeleton: Skeleton3D = $Humanoid/Skeleton3D
@onready var targets_root: Node3D = $Targets
@onready var crate: Node3D = $Crate
@onready var orb: Node3D = $Orb
@onready var camera: Camera3D = $Camera3D
@onready var mode_label: Label = $UI/Panel/VBox/Mode
@onready var stats_label: Label = $UI/Panel/VBox/Stats
@onready var show_targets: CheckBox = $UI/Panel/VBox/ShowTargets

var options := {}
## The IKBody node under the skeleton (the demo ships with the extension).
var ik_body: IKBody = null
## Runs after the IK: keeps a rolling foot's toes on the ground (toes_on_ground.gd).
var toes: SkeletonModifier3D = null
## Effector target markers by bone name.
var targets := {}
var body: BodyTargets
## Simulated time (s) and the lap's state this frame.
var time := 0.0
var lap := {}
## Per-effector errors of the pose the skeleton shows (m and rad), measured in skeleton_updated.
var position_errors := {}
var rotation_errors := {}
## Landings counted (each foot touching down after a swing).
var landings := 0

var _bones := {}
var _start_time := 0.0
var _started := false
var _was_swinging := [false, false]
var _last_frame := -1
var _second := Cli.Stats.new()
var _run := Cli.Stats.new()
var _next_report := 1.0
var _finished := false
var _shot_taken := false
var _camera_focus := Vector3.ZERO
var _max_planted_error := 0.0
var _max_contact_error := 0.0
var _max_grip_error := 0.0
## Frames whose solve used every iteration allowed, and those of them with a goal level unmet.
var _at_max_iterations := 0
var _unmet_levels := 0


func _ready() -> void:
	options = Cli.options()
	time = options["start_at"]
	_start_time = time
	_next_report = time + 1.0
	Course.build($Ground)
	for bone in EFFECTORS:
		targets[bone] = _make_marker(bone)
		_bones[bone] = skeleton.find_bone(bone)
	body = BodyTargets.new(skeleton)
	_relax()
	use_ik_body(IKBody.new())
	toes = ToesOnGround.new()
	toes.name = "ToesOnGround"
	toes.body = body
	skeleton.add_child(toes)
	show_targets.button_pressed = true
	show_targets.toggled.connect(func(on: bool): targets_root.visible = on)
	$UI/Panel/VBox/Menu.pressed.connect(back_to_menu)
	skeleton.skeleton_updated.connect(_on_skeleton_updated)
	lap = lap_state(time)
	_place_character()
	_camera_focus = Vector3(lap["x"], 1.25, 0.0)
	mode_label.text = "IKBody: one solve for the whole body, feet first (priority 1)"
	if options["demo_seconds"] > 0.0:
		print("character: IKBody, %d bones, %s s of simulated time" % [skeleton.get_bone_count(), options["demo_seconds"]])


## Poses the skeleton in the RELAXED stance (its bone poses, not its rests: what an animation
## would set). IKBody starts from it each frame and keeps the freedom the targets leave near it.
func _relax() -> void:
	var globals := {}
	for i in skeleton.get_bone_count():
		var parent := skeleton.get_bone_parent(i)
		var local := skeleton.get_bone_rest(i).basis
		var name := skeleton.get_bone_name(i)
		var turn := Basis()
		if RELAXED.has(name):
			turn = Basis(RELAXED[name][0], deg_to_rad(RELAXED[name][1]))
		var parent_global: Basis = globals[parent] if parent >= 0 else Basis()
		globals[i] = turn * parent_global * local
		if RELAXED.has(name):
			skeleton.set_bone_pose_rotation(i, (parent_global.inverse() * globals[i]).get_rotation_quaternion())


## Puts `node` under the skeleton and wires it: setup_humanoid() (root bone Hips, floating),
## each effector's target, priority and weights by bone name; effectors this scene has no target
## for are disabled.
func use_ik_body(node: IKBody) -> void:
	ik_body = node
	ik_body.name = "IKBody"
	skeleton.add_child(ik_body)
	ik_body.setup_humanoid()
	var found := []
	for effector: IKBodyEffector in ik_body.effectors:
		var bone := str(effector.bone_name)
		if EFFECTORS.has(bone):
			var e: Array = EFFECTORS[bone]
			effector.target = ik_body.get_path_to(targets[bone])
			effector.priority = e[0]
			effector.position_weight = e[1]
			effector.rotation_weight = e[2]
			effector.enabled = true
			found.append(bone)
		else:
			effector.enabled = false  # no target for it in this scene
	ik_body.effectors = ik_body.effectors
	if toes != null:
		skeleton.move_child(toes, -1)  # after the IK
	for bone in EFFECTORS:
		if not found.has(bone):
			push_warning("character: IKBody.setup_humanoid() made no effector for %s" % bone)


## A small visible marker for an effector's target under Targets.
func _make_marker(bone: String) -> Marker3D:
	var marker := Marker3D.new()
	marker.name = bone
	marker.gizmo_extents = 0.06
	var material := StandardMaterial3D.new()
	material.albedo_color = TARGET_COLORS[bone]
	material.shading_mode = BaseMaterial3D.SHADING_MODE_UNSHADED
	material.no_depth_test = true
	material.render_priority = 1
	var view := MeshInstance3D.new()
	if bone.ends_with("Foot"):
		var ring := TorusMesh.new()  # lies in the sole's plane
		ring.inner_radius = 0.05
		ring.outer_radius = 0.065
		view.mesh = ring
		view.rotation = Vector3(PI / 2.0, 0.0, 0.0)  # the foot's +Z is the sole's normal
		view.position = Vector3(0.0, 0.02, -0.065)
	else:
		var dot := SphereMesh.new()
		dot.radius = 0.025
		dot.height = 0.05
		view.mesh = dot
	view.material_override = material
	view.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	marker.add_child(view)
	targets_root.add_child(marker)
	return marker


## Jumps to `t` s into the lap: both feet are put down afresh at the next physics frame.
func restart_at(t: float) -> void:
	time = t
	_start_time = t
	_next_report = t + 1.0
	_started = false
	landings = 0
	lap = lap_state(t)
	_camera_focus = Vector3(lap["x"], 1.25, 0.0)


func back_to_menu() -> void:
	get_tree().change_scene_to_file("res://demo/menu.tscn")


# ------------------------------------------------------------------ the lap

## The lap at time `t`: phase name, time into it (tau), the hips' ground point x, heading yaw
## (rad, +π/2 = facing +X), speed (m/s along the heading) and yaw rate (rad/s).
static func lap_state(t: float) -> Dictionary:
	var walk_time := (WALK_TO - WALK_FROM) / WALK_SPEED + ACCEL_TIME
	var phases := [["stand", STAND_TIME], ["walk_out", walk_time], ["pick", PICK_TIME], ["turn_back", TURN_TIME],
			["walk_back", walk_time], ["turn_out", TURN_TIME]]
	var total := 0.0
	for p in phases:
		total += p[1]
	var tau := fmod(maxf(t, 0.0), total)
	var s := {"x": WALK_FROM, "yaw": PI / 2.0, "speed": 0.0, "yaw_rate": 0.0}
	for p in phases:
		if tau < p[1] or p == phases.back():
			s["phase"] = p[0]
			s["tau"] = tau
			break
		tau -= p[1]
	match s["phase"]:
		"walk_out", "walk_back":
			var w := _trapezoid(tau, WALK_TO - WALK_FROM, WALK_SPEED, ACCEL_TIME)
			var out: bool = s["phase"] == "walk_out"
			s["x"] = WALK_FROM + w[0] if out else WALK_TO - w[0]
			s["yaw"] = PI / 2.0 if out else -PI / 2.0
			s["speed"] = w[1]
		"pick":
			s["x"] = WALK_TO
		"turn_back", "turn_out":
			var u := clampf(tau / TURN_TIME, 0.0, 1.0)
			var back: bool = s["phase"] == "turn_back"
			s["x"] = WALK_TO if back else WALK_FROM
			s["yaw"] = (PI / 2.0 if back else -PI / 2.0) + PI * smoothstep(0.0, 1.0, u)
			s["yaw_rate"] = PI * 6.0 * u * (1.0 - u) / TURN_TIME
	return s


## When phase `name` first starts in the lap (s).
static func phase_start(name: String) -> float:
	var t := 0.0
	while t < 120.0 and lap_state(t)["phase"] != name:
		t += 0.05
	while t > 0.0 and lap_state(t - 0.001)["phase"] == name:
		t -= 0.001
	return t


## Distance and speed after `tau` s of a walk of `length` m: accelerate for `ramp` s, cruise at
## `speed`, slow down for `ramp` s.
static func _trapezoid(tau: float, length: float, speed: float, ramp: float) -> Array:
	var total := length / speed + ramp
	tau = clampf(tau, 0.0, total)
	if tau < ramp:
		return [0.5 * speed * tau * tau / ramp, speed * tau / ramp]
	if tau > total - ramp:
		var left := total - tau
		return [length - 0.5 * speed * left * left / ramp, speed * left / ramp]
	return [speed * (tau - 0.5 * ramp), speed]


## The ground frame under the hips this frame.
func ground_frame() -> Transform3D:
	return Transform3D(Basis(Vector3.UP, lap["yaw"]), Vector3(lap["x"], 0.0, 0.0))


func _place_character() -> void:
	humanoid.global_transform = ground_frame()


# ------------------------------------------------------------------ each frame

func _physics_process(delta: float) -> void:
	if _finished:
		return
	var space := get_world_3d().direct_space_state
	if not _started:
		# The bodies are in the physics space from the first physics frame on.
		_started = true
		lap = lap_state(time)
		_place_character()
		body.reset(space, ground_frame())
		_write_targets()
		return
	time += delta
	lap = lap_state(time)
	_place_character()
	var root := ground_frame()
	var velocity: Vector3 = root.basis * Vector3.BACK * float(lap["speed"])
	_pick_up(float(lap["tau"]) if lap["phase"] == "pick" else -1.0)
	var t := time
	# The orb drifts on the far side of the character from the camera.
	orb.global_position = Vector3(lap["x"], body.hips.origin.y, 0.0) \
			+ Vector3(1.8 * cos(0.5 * t), 0.45 + 0.25 * sin(1.3 * t), -1.3 + 0.8 * sin(0.5 * t))
	body.update(space, root, velocity, delta, float(lap["yaw_rate"]))
	for i in 2:
		var swinging := body.feet[i].swinging
		if _was_swinging[i] and not swinging:
			landings += 1
		_was_swinging[i] = swinging
	_write_targets()
	_follow_camera(delta)


## The pick-up, `tau` s into it (< 0: not picking): reach for the crate's sides while the hips
## crouch, grip, lift it to the chest, hold, put it back, let go.
func _pick_up(tau: float) -> void:
	var heading := ground_frame().basis
	var rest := Vector3(WALK_TO, 0.0, 0.0) + heading * Vector3(0, CRATE_SIZE * 0.5, CRATE_AHEAD)
	if tau < 0.0:
		crate.global_transform = Transform3D(Basis(), rest)
		body.reach_weight = 0.0
		body.crouch = 0.0
		body.lean_back = 0.0
		body.pelvis_tilt = 0.0
		body.look_at_point = orb.global_position
		return
	var reach := smoothstep(0.3, 2.0, tau)
	var lift := smoothstep(2.4, 3.8, tau)
	var lower := smoothstep(4.6, 6.0, tau)
	var release := smoothstep(6.0, 6.9, tau)
	var carried := lift * (1.0 - lower)
	var carry := Vector3(WALK_TO, 0.0, 0.0) + heading * CARRY
	crate.global_transform = Transform3D(Basis(), rest.lerp(carry, smoothstep(0.0, 1.0, carried)))
	var c := crate.global_position
	var side := heading * Vector3.RIGHT * (CRATE_SIZE * 0.5 + 0.015)
	# The grips: on the sides, 6 cm below the top.
	var grip := Vector3(0.0, CRATE_SIZE * 0.5 - 0.06, 0.0)
	body.reach_points[0] = c + side + grip
	body.reach_points[1] = c - side + grip
	body.reach_weight = reach * (1.0 - release)
	var down := clampf(reach - lift + lower - release, 0.0, 1.0)
	body.crouch = CROUCH * down
	body.lean_back = CROUCH_BACK * down
	body.pelvis_tilt = PELVIS_TILT * down
	body.look_at_point = c if tau < 3.9 or tau > 4.5 else orb.global_position


func _write_targets() -> void:
	targets["Hips"].global_transform = body.hips
	targets["LeftFoot"].global_transform = body.feet[0].target
	targets["RightFoot"].global_transform = body.feet[1].target
	targets["LeftHand"].global_transform = body.hands[0]
	targets["RightHand"].global_transform = body.hands[1]
	targets["Head"].global_transform = body.head


func _follow_camera(delta: float) -> void:
	var ahead: Vector3 = ground_frame().basis * Vector3.BACK * 0.4 * float(lap["speed"])
	var focus := Vector3(body.hips.origin.x + ahead.x, 0.75 + 0.5 * body.hips.origin.y, 0.0)
	_camera_focus = _camera_focus.lerp(focus, 1.0 - exp(-3.0 * delta))
	camera.global_position = _camera_focus + Vector3(0.9, 0.55, 2.7)
	camera.look_at(_camera_focus)


func _process(_delta: float) -> void:
	if _finished:
		return
	stats_label.text = _hud_text()
	var elapsed := time - _start_time
	if options["screenshot"] != "" and not _shot_taken and elapsed >= options["screenshot_at"]:
		_shot_taken = true
		var err: int = await Cli.save_screenshot(get_viewport(), options["screenshot"])
		get_tree().quit(0 if err == OK else 1)
	elif options["demo_seconds"] > 0.0 and elapsed >= options["demo_seconds"]:
		_finish()


func _unhandled_input(event: InputEvent) -> void:
	var key := event as InputEventKey
	if key != null and key.pressed and not key.echo:
		if key.keycode == KEY_T:
			show_targets.button_pressed = not show_targets.button_pressed
		elif key.keycode == KEY_ESCAPE:
			back_to_menu()


# ------------------------------------------------------------------ measuring

## Microseconds the last body solve took (IKBody's typed getter: no Dictionary per frame).
func last_usec() -> float:
	return ik_body.get_last_usec()


func _hud_text() -> String:
	if position_errors.is_empty():
		return "no pose yet"
	var lines := PackedStringArray()
	lines.append("%s   (lap: %s)" % [_phase_text(), "%.1f s" % time])
	lines.append("effector     prio   error")
	for bone in EFFECTORS:
		var what := ""
		if bone.ends_with("Foot"):
			what = "  swing" if body.feet[0 if bone.begins_with("Left") else 1].swinging else "  planted"
		var err := "%5.1f°" % rad_to_deg(rotation_errors.get(bone, NAN)) if bone == "Head" \
				else "%5.1f mm" % (1000.0 * float(position_errors.get(bone, NAN)))
		lines.append("%-11s  %d   %s%s" % [bone, EFFECTORS[bone][0], err, what])
	lines.append("%.0f µs per character, %d iterations" % [last_usec(), ik_body.get_last_iterations()])
	return "\n".join(lines)


func _phase_text() -> String:
	match lap.get("phase", ""):
		"walk_out", "walk_back":
			return "walking"
		"pick":
			return "picking the crate up"
		"turn_back", "turn_out":
			return "turning"
	return "standing"


# The modified pose is visible only inside the skeleton's update, so measure here.
func _on_skeleton_updated() -> void:
	var frame := Engine.get_process_frames()
	if _finished or not _started or frame == _last_frame:
		return
	_last_frame = frame
	var to_world := skeleton.global_transform
	for bone in EFFECTORS:
		var pose := to_world * skeleton.get_bone_global_pose(_bones[bone])
		if bone == "Head":
			body.head_origin = pose.origin  # where the look's marker is drawn next frame
		var goal: Transform3D = (targets[bone] as Node3D).global_transform
		position_errors[bone] = pose.origin.distance_to(goal.origin)
		rotation_errors[bone] = (pose.basis.orthonormalized().inverse() * goal.basis.orthonormalized()).get_rotation_quaternion().get_angle()
	for stats in [_second, _run]:
		for i in 2:
			var foot := body.feet[i]
			if not foot.swinging:
				var bone := "LeftFoot" if i == 0 else "RightFoot"
				stats.add("planted", position_errors[bone])
		stats.add("hands", 0.5 * (position_errors["LeftHand"] + position_errors["RightHand"]))
		if gripping():
			stats.add("grip", maxf(position_errors["LeftHand"], position_errors["RightHand"]))
		stats.add("head", rotation_errors["Head"])
		stats.add("hips", position_errors["Hips"])
		stats.add("micros", last_usec())
		stats.add("iterations", ik_body.get_last_iterations())
	if ik_body.get_last_iterations() >= ik_body.max_iterations:
		_at_max_iterations += 1
		for level in range(1, 5):
			if not ik_body.is_last_level_met(level):
				_unmet_levels += 1
				break
	if gripping():
		_max_grip_error = maxf(_max_grip_error, maxf(position_errors["LeftHand"], position_errors["RightHand"]))
	for i in 2:
		var foot := body.feet[i]
		if not foot.swinging:
			_max_planted_error = maxf(_max_planted_error, position_errors["LeftFoot" if i == 0 else "RightFoot"])
			# The ray casts against the course's own shape: a contact away from an edge must sit
			# on the surface the course says is there.
			var x := foot.contact.x
			if absf(foot.contact.z) < Course.LANE - 0.02 and _far_from_edges(x):
				_max_contact_error = maxf(_max_contact_error, absf(foot.contact.y - Course.height_at(x)))
	if options["demo_seconds"] > 0.0 and time >= _next_report:
		_next_report += 1.0
		print("character t=%2.0f s, frame %d: %s | planted feet %.2f mm mean | hands %.1f mm | head %.2f° | hips %.1f mm | %d landings | %.0f µs, %.1f iterations per character" % [
				time - _start_time, _run.count("hips"), _phase_text(), 1000.0 * _second.mean("planted"),
				1000.0 * _second.mean("hands"), rad_to_deg(_second.mean("head")), 1000.0 * _second.mean("hips"),
				landings, _second.mean("micros"), _second.mean("iterations")])
		_second.clear()


## The hands hold the crate on the floor (GRIP s into the pick-up).
func gripping() -> bool:
	return lap.get("phase", "") == "pick" and lap["tau"] >= GRIP[0] and lap["tau"] <= GRIP[1]


static func _far_from_edges(x: float) -> bool:
	var edges := [Course.RAMP_START, Course.RAMP_END, Course.LANDING_END]
	for step in Course.STEPS:
		edges.append(step[0])
	for e in edges:
		if absf(x - e) < 0.02:
			return false
	return true


## PASS: the feet touched down at least once a second of walking, every planted foot stayed within
## PLANTED_TOLERANCE of its ground contact, every contact sat on the course's surface within 1 mm
## (the ray casts' job), and, if the run got there, both hands held the crate's grips within
## GRIP_TOLERANCE while it stood on the floor (the worst frame).
func _finish() -> void:
	_finished = true
	var frames := _run.count("hips")
	var walked := time - _start_time - STAND_TIME
	var why := ""
	if frames < 10:
		why = "too few skeleton updates (%d)" % frames
	elif walked > 2.0 and landings < int(walked):
		why = "only %d landings in %.0f s" % [landings, walked]
	elif not (_max_planted_error <= PLANTED_TOLERANCE):
		why = "a planted foot was %.1f mm off its ground contact (> %.0f mm)" % [1000.0 * _max_planted_error, 1000.0 * PLANTED_TOLERANCE]
	elif not (_max_contact_error <= 1e-3):
		why = "a ground contact was %.2f mm off the course's surface" % (1000.0 * _max_contact_error)
	elif _run.count("grip") > 0 and not (_max_grip_error <= GRIP_TOLERANCE):
		why = "a hand was %.1f mm off the crate's grip (> %.0f mm)" % [1000.0 * _max_grip_error, 1000.0 * GRIP_TOLERANCE]
	print("character summary: %d frames, %d landings, planted feet %.3f mm mean / %.3f mm max, hands %.1f mm (at the grips %s), head %.2f°, hips %.1f mm, %.0f µs and %.1f iterations per character, %d frames at max_iterations (%d of them with a level unmet)" % [
			frames, landings, 1000.0 * _run.mean("planted"), 1000.0 * _max_planted_error, 1000.0 * _run.mean("hands"),
			"%.2f mm max" % (1000.0 * _max_grip_error) if _run.count("grip") > 0 else "not reached",
			rad_to_deg(_run.mean("head")), 1000.0 * _run.mean("hips"), _run.mean("micros"), _run.mean("iterations"),
			_at_max_iterations, _unmet_levels])
	print("demo: PASS character: %d landings, planted feet within %.2f mm of their targets%s" % [landings, 1000.0 * _max_planted_error,
			", hands within %.2f mm of the grips" % (1000.0 * _max_grip_error) if _run.count("grip") > 0 else ""]
			if why == "" else "demo: FAIL character: %s" % why)
	get_tree().quit(0 if why == "" else 1)
