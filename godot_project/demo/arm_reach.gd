extends Node3D
## IKChain demo: a 3-joint arm (upper_arm → forearm → hand, effector at "fingertip") follows a
## target moving on a figure-eight. Once a second it prints the solver, the last result's reason,
## final_error and solve time.
##
## User arguments (after `--` on Godot's command line):
##   --demo-seconds=N   run N seconds of simulated time, print a summary and quit with 0 if the tip
##                      tracked the target (median per-frame error <= 10 × tolerance), 1 otherwise
##                      (scripts/demo runs `--headless --fixed-fps 60 ... -- --demo-seconds=5`)
##   --solver=NAME      two_bone is not valid for this 3-joint arm; ccd, jacobian, dls, bfgs, fabrik
## Keys (windowed): 2–6 pick CCD, Jacobian, DLS, BFGS, FABRIK.

const SOLVER_NAMES := ["TWO_BONE", "CCD", "JACOBIAN", "DLS", "BFGS", "FABRIK"]

## Figure-eight half extents (m) and angular speed of its parameter (rad/s).
@export var extent := Vector2(0.45, 0.35)
@export var speed := 1.2

@onready var skeleton: Skeleton3D = $Arm
@onready var ik: IKChain = $Arm/IKChain
@onready var target: Marker3D = $Target

var _time := 0.0
var _center := Vector3.ZERO
var _tip_bone := -1
var _demo_seconds := 0.0
var _next_report := 1.0
var _last_frame := -1
var _errors := PackedFloat64Array()
var _micros := PackedFloat64Array()
var _reasons := {}
var _finished := false


func _ready() -> void:
	for arg in OS.get_cmdline_user_args():
		if arg.begins_with("--demo-seconds="):
			_demo_seconds = arg.trim_prefix("--demo-seconds=").to_float()
		elif arg.begins_with("--solver="):
			var i := SOLVER_NAMES.find(arg.trim_prefix("--solver=").to_upper())
			if i < 0:
				push_error("arm_reach: unknown solver in %s (use one of %s)" % [arg, ", ".join(SOLVER_NAMES)])
			else:
				ik.solver = i
	_tip_bone = skeleton.find_bone(ik.tip_bone)
	# The figure-eight lies in front of the shoulder, well inside the arm's reach.
	var shoulder := skeleton.global_transform * skeleton.get_bone_global_pose(skeleton.find_bone(ik.root_bone)).origin
	_center = shoulder + Vector3(0.0, 0.15, 0.45)
	target.global_position = _figure_eight(0.0)
	skeleton.skeleton_updated.connect(_on_skeleton_updated)
	print("IKChain demo: solver %s, max_iterations %d, tolerance %s m, %s" % [
			SOLVER_NAMES[ik.solver], ik.max_iterations, str(ik.tolerance),
			"%s s of simulated time" % _demo_seconds if _demo_seconds > 0.0 else "until closed"])


func _figure_eight(t: float) -> Vector3:
	var a := t * speed
	return _center + Vector3(extent.x * sin(a), extent.y * sin(2.0 * a), 0.15 * cos(a))


func _process(delta: float) -> void:
	if _finished:
		return
	_time += delta
	target.global_position = _figure_eight(_time)
	if _demo_seconds > 0.0 and _time >= _demo_seconds:
		_finish()


func _unhandled_input(event: InputEvent) -> void:
	var key := event as InputEventKey
	if key and key.pressed and not key.echo and key.keycode >= KEY_2 and key.keycode <= KEY_6:
		ik.solver = key.keycode - KEY_1
		print("solver → %s" % SOLVER_NAMES[ik.solver])


# The modified pose is visible only inside the skeleton's update, so measure here.
func _on_skeleton_updated() -> void:
	var frame := Engine.get_process_frames()
	if _finished or frame == _last_frame:
		return  # one sample per frame (the skeleton may update more than once)
	_last_frame = frame
	var tip := skeleton.global_transform * skeleton.get_bone_global_pose(_tip_bone).origin
	var goal := target.global_position
	var error := tip.distance_to(goal)
	var r := ik.get_last_result()
	_errors.append(error)
	_micros.append(float(r.get("microseconds", 0)))
	var reason := str(r.get("reason", "?"))
	_reasons[reason] = _reasons.get(reason, 0) + 1
	if _time >= _next_report:
		_next_report += 1.0
		print("frame %d (t=%.1f s): solver %s, target %s, tip %s, error %.6f m, final_error %.6f m, reason %s, %d iterations, %d µs" % [
				_errors.size(), _time, SOLVER_NAMES[ik.solver], _v(goal), _v(tip), error,
				float(r.get("final_error", NAN)), reason, int(r.get("iterations", -1)), int(r.get("microseconds", -1))])


func _finish() -> void:
	_finished = true
	var ok := _errors.size() >= 10
	var median_error := _median(_errors)
	var limit := ik.tolerance * 10.0
	ok = ok and median_error <= limit
	print("demo summary: %d frames, solver %s, median error %.7f m (limit %.7f), max error %.7f m, median %d µs, reasons %s" % [
			_errors.size(), SOLVER_NAMES[ik.solver], median_error, limit, _max(_errors), int(_median(_micros)), str(_reasons)])
	print("demo: %s" % ("PASS" if ok else "FAIL (the tip did not track the target)" if _errors.size() >= 10 else "FAIL (too few skeleton updates)"))
	get_tree().quit(0 if ok else 1)


static func _median(values: PackedFloat64Array) -> float:
	if values.is_empty():
		return INF
	var sorted := values.duplicate()
	sorted.sort()
	return sorted[sorted.size() / 2]


static func _max(values: PackedFloat64Array) -> float:
	var m := 0.0
	for v in values:
		m = maxf(m, v)
	return m


static func _v(v: Vector3) -> String:
	return "(%.3f, %.3f, %.3f)" % [v.x, v.y, v.z]
