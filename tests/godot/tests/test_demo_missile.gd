extends "res://lib/ik_test.gd"
## A scripted run of the missile-guidance scene (godot_project/demo/missile_guidance.tscn):
## fixed 1/60 s steps and seeded drone flights, so every run is the same. The launcher's IKChain
## (aim goal) keeps the barrel on the lead intercept point, measured here from the skeleton's
## solved pose, and the missiles it fires hit.
##
## Measured (this code, 2026-11-23): seeds 1..8 over 30 s each: 12 hits every time, no miss; the
## barrel's aim error while tracking (from 0.5 s after a drone appears) at most 0.057° (the
## solver's orientation tolerance, 0.001 rad), mean ≤ 0.0011°. Over 20 s, seeds 1 and 2 score 8
## hits each with 8 missiles resolved.
# timeout: 120

const MISSILE := "res://demo/missile_guidance.tscn"
const SECONDS := 20.0
## Bounds with margin over the measurements above.
const MIN_HITS := 6
const MAX_AIM_ERROR := deg_to_rad(0.2)
const MAX_MEAN_AIM_ERROR := deg_to_rad(0.01)

var _scene: Node3D
var _worst_aim := 0.0
var _sum_aim := 0.0
var _samples := 0
var _lead_checks := 0
var _worst_lead := 0.0


func test_seed_1() -> void:
	await _run(1)


func test_seed_2() -> void:
	await _run(2)


func _run(seed: int) -> void:
	_scene = (load(MISSILE) as PackedScene).instantiate()
	_scene.fixed_dt = 1.0 / 60.0
	_scene.seed = seed
	_worst_aim = 0.0
	_sum_aim = 0.0
	_samples = 0
	_lead_checks = 0
	_worst_lead = 0.0
	case_root.add_child(_scene)
	var skeleton: Skeleton3D = _scene.skeleton
	skeleton.skeleton_updated.connect(_on_updated)
	var frames := int(SECONDS * 60.0)
	# Headless Godot sleeps this long after every frame (it cannot draw); the simulation steps a
	# fixed 1/60 s per frame whatever the wall clock says, so there is no need to wait.
	var sleep_usec := OS.low_processor_usage_mode_sleep_usec
	OS.low_processor_usage_mode_sleep_usec = 0
	for i in frames:
		await process_frame
	OS.low_processor_usage_mode_sleep_usec = sleep_usec
	skeleton.skeleton_updated.disconnect(_on_updated)
	var hits: int = _scene.hits
	var shots: int = _scene.shots
	var misses: int = _scene.misses
	print("seed %d: %d hits, %d misses, %d in flight of %d shots; aim error max %.4f°, mean %.5f° over %d frames" % [
			seed, hits, misses, shots - hits - misses, shots, rad_to_deg(_worst_aim), rad_to_deg(_sum_aim / maxi(_samples, 1)), _samples])
	check_near(_scene.time, SECONDS, 1.0 / 60.0 + 1e-6, "simulated time (s)")
	check(hits >= MIN_HITS, "seed %d: %d hits of %d shots (want at least %d)" % [seed, hits, shots, MIN_HITS])
	check_le(misses, 1, "seed %d: misses" % seed)
	check_eq(hits + misses + _scene.missiles.size(), shots, "every shot is a hit, a miss or still in flight")
	# Each hit costs 1 s without a drone and 0.5 s of settling on the next one.
	check(_samples > frames / 4, "frames with a drone tracked: %d of %d" % [_samples, frames])
	check_le(_worst_aim, MAX_AIM_ERROR, "seed %d: largest barrel aim error while tracking (rad)" % seed)
	check_le(_sum_aim / maxi(_samples, 1), MAX_MEAN_AIM_ERROR, "seed %d: mean barrel aim error (rad)" % seed)
	check(_lead_checks > 100, "lead points checked: %d" % _lead_checks)
	# The aim point is the intercept from where the muzzle was a frame before (it moves a little).
	check_le(_worst_lead, 2e-3, "seed %d: | |aim point − muzzle| − s·t | / (s·t)" % seed)


## The solved pose is visible here: the barrel's +Y (the muzzle bone's, the IKChain's aim_axis)
## against the direction to the AimPoint marker the IKChain aims at.
func _on_updated() -> void:
	var skeleton: Skeleton3D = _scene.skeleton
	var muzzle := skeleton.global_transform * skeleton.get_bone_global_pose(skeleton.find_bone("muzzle"))
	var aim: Vector3 = _scene.aim_point.global_position
	if not _scene.drone_alive or _scene._path_time < _scene.SETTLE:
		return  # no drone, or a new one: the aim point has just jumped
	var t: float = _scene.intercept_time
	if t > 0.0:
		var drone: Vector3 = _scene.drone.global_position
		var lead: Vector3 = drone + _scene.drone_velocity * t
		if lead.distance_to(aim) < 1e-3:
			var s_t: float = _scene.MISSILE_SPEED * t
			_worst_lead = maxf(_worst_lead, absf((aim - muzzle.origin).length() - s_t) / s_t)
			_lead_checks += 1
		else:
			_worst_lead = INF  # the marker is not on the lead point
	var error := muzzle.basis.y.normalized().angle_to((aim - muzzle.origin).normalized())
	_worst_aim = maxf(_worst_aim, error)
	_sum_aim += error
	_samples += 1
