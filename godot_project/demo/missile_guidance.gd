extends Node3D
## Missile guidance: a launcher built as a bone chain (yaw, shoulder, elbow, barrel; a `muzzle`
## bone at the barrel's end is the IKChain's tip) tracks a drone. Each frame the lead intercept
## point (guidance.gd: the smallest t > 0 with |d + v·t| = s·t, or the drone itself when there is
## none) moves the AimPoint marker, and the IKChain's aim goal (goal_mode Aim, aim_axis +Y) turns
## the chain so the barrel points at it: no look-at code here. Once the barrel is on the point, a
## missile leaves the muzzle along the barrel and homes with augmented proportional navigation.
## Options: see demo_cli.gd.

const Cli := preload("res://demo/demo_cli.gd")
const Guidance := preload("res://demo/guidance.gd")

## Missile speed (m/s, constant), navigation constant, turn-rate cap (rad/s), life (s).
const MISSILE_SPEED := 55.0
const NAV_CONSTANT := 4.0
const MAX_TURN_RATE := deg_to_rad(90.0)
const MISSILE_LIFE := 5.0
## A missile passing this close to the drone hits it (m).
const HIT_RADIUS := 1.5
## Fire only when the barrel is this close to the aim point (rad), at most this often (s).
const FIRE_ERROR := deg_to_rad(1.0)
const FIRE_INTERVAL := 1.0
## A new drone this long after a hit (s).
const RESPAWN_DELAY := 1.0

## Simulated seconds per frame; 0 = the frame's real delta. Tests set 1/60 for repeatable runs.
@export var fixed_dt := 0.0
## Seeds the drones' flight paths (the command line's --seed=N overrides it).
@export var seed := 1

@onready var skeleton: Skeleton3D = $Launcher
@onready var ik: IKChain = $Launcher/IKChain
@onready var aim_point: Marker3D = $AimPoint
@onready var gizmo: Node3D = $IKGizmo
@onready var solver_menu: OptionButton = $UI/Panel/VBox/SolverRow/Solver
@onready var show_gizmo: CheckBox = $UI/Panel/VBox/ShowGizmo
@onready var stats_label: Label = $UI/Panel/VBox/Stats

var options := {}
var rng := RandomNumberGenerator.new()
var time := 0.0
## Launched missiles, drones hit, missiles that expired (shots = hits + misses + in flight).
var shots := 0
var hits := 0
var misses := 0
## The barrel's angle off the aim point in the last skeleton update (rad), and its per-frame
## samples while tracking (from SETTLE seconds after a drone appears: a new drone is a jump).
var aim_error := INF
var aim_errors := PackedFloat64Array()
const SETTLE := 0.5
var intercept_time := -1.0

var drone: Node3D
var drone_alive := false
var drone_velocity := Vector3.ZERO
var drone_accel := Vector3.ZERO
var _path := {}
var _path_time := 0.0
var _respawn_in := 0.0
var _fire_cooldown := 0.0
## Each missile: {node, position, velocity, age, trail (PackedVector3Array)}.
var missiles: Array[Dictionary] = []
var _explosions: Array[Dictionary] = []
var _muzzle_bone := -1
var _muzzle := Transform3D()
var _lines: ImmediateMesh
var _last_frame := -1
var _second := Cli.Stats.new()
var _run := Cli.Stats.new()
var _next_report := 1.0
var _finished := false
var _shot_taken := false
var _missile_mesh: Mesh
var _explosion_mesh: Mesh


func _ready() -> void:
	options = Cli.options()
	rng.seed = options["seed"] if options["seed"] >= 0 else seed
	if options["solver"] >= 0:
		ik.solver = options["solver"]
	_muzzle_bone = skeleton.find_bone(ik.tip_bone)
	_muzzle = skeleton.global_transform * skeleton.get_bone_global_pose(_muzzle_bone)
	Cli.fill_solver_menu(solver_menu, ik.solver)
	solver_menu.item_selected.connect(func(index: int): set_solver(solver_menu.get_item_id(index)))
	show_gizmo.toggled.connect(func(on: bool): gizmo.visible = on)
	$UI/Panel/VBox/Menu.pressed.connect(back_to_menu)
	skeleton.skeleton_updated.connect(_on_skeleton_updated)
	_build_visuals()
	_spawn_drone()
	_update_aim_point()
	if options["demo_seconds"] > 0.0:
		print("missile_guidance: solver %s, missile %.0f m/s, N = %.1f, turn rate <= %.0f°/s, %s s of simulated time" % [
				Cli.solver_label(ik.solver), MISSILE_SPEED, NAV_CONSTANT, rad_to_deg(MAX_TURN_RATE), options["demo_seconds"]])


func set_solver(solver: int) -> void:
	ik.solver = solver
	solver_menu.select(maxi(solver_menu.get_item_index(solver), 0))


func back_to_menu() -> void:
	get_tree().change_scene_to_file("res://demo/menu.tscn")


## The muzzle's pose in the world after the last solve. Skeleton3D shows the solved pose only
## inside its update (outside it get_bone_global_pose() gives the pose before modifiers), so it is
## kept from there.
func muzzle() -> Transform3D:
	return _muzzle


# ------------------------------------------------------------------ the drone

## A new flight: a loop around a point ahead of the launcher, at a random radius, height, speed,
## direction and weave, all from the seeded generator.
func _spawn_drone() -> void:
	var radius := rng.randf_range(22.0, 32.0)
	var speed := rng.randf_range(16.0, 24.0)
	_path = {
		"center": Vector3(rng.randf_range(-12.0, 8.0), rng.randf_range(16.0, 26.0), rng.randf_range(-50.0, -42.0)),
		"radius": radius,
		"omega": speed / radius * (1.0 if rng.randf() < 0.5 else -1.0),
		"phase": rng.randf_range(0.0, TAU),
		"weave": rng.randf_range(2.0, 7.0),
	}
	_path_time = 0.0
	drone_alive = true
	drone.visible = true
	_move_drone(0.0)


## Position, velocity and acceleration of the loop (analytic, so augmented PN gets the true a_T).
func _move_drone(dt: float) -> void:
	_path_time += dt
	var c: Vector3 = _path["center"]
	var r: float = _path["radius"]
	var w: float = _path["omega"]
	var a: float = _path["weave"]
	var th: float = _path["phase"] + w * _path_time
	var p := c + Vector3(r * cos(th), a * sin(3.0 * th), r * sin(th))
	drone_velocity = Vector3(-r * sin(th), 3.0 * a * cos(3.0 * th), r * cos(th)) * w
	drone_accel = Vector3(-r * cos(th), -9.0 * a * sin(3.0 * th), -r * sin(th)) * (w * w)
	drone.global_position = p
	if drone_velocity.length_squared() > 1e-6:
		drone.look_at(p + drone_velocity, Vector3.UP)


func _update_aim_point() -> void:
	if not drone_alive:
		return
	var from := muzzle().origin
	var d := drone.global_position - from
	intercept_time = Guidance.intercept_time(d, drone_velocity, MISSILE_SPEED)
	aim_point.global_position = drone.global_position + drone_velocity * intercept_time if intercept_time > 0.0 \
			else drone.global_position


# ------------------------------------------------------------------ the simulation

func _process(delta: float) -> void:
	if _finished:
		return
	var dt := fixed_dt if fixed_dt > 0.0 else delta
	step(dt)
	_draw_lines()
	stats_label.text = _status_text()
	# The screenshot waits for a missile well on its way (or gives up waiting after 5 s).
	if options["screenshot"] != "" and not _shot_taken and time >= options["screenshot_at"] \
			and ((not missiles.is_empty() and missiles[0]["age"] >= 0.5) or time >= options["screenshot_at"] + 5.0):
		_shot_taken = true
		var err: int = await Cli.save_screenshot(get_viewport(), options["screenshot"])
		get_tree().quit(0 if err == OK else 1)
	elif options["demo_seconds"] > 0.0 and time >= options["demo_seconds"]:
		_finish()


## One step of `dt` seconds: the drone, the aim point (the IKChain aims at it in this frame's
## skeleton update), the missiles, firing.
func step(dt: float) -> void:
	time += dt
	_fire_cooldown -= dt
	if drone_alive:
		_move_drone(dt)
	else:
		_respawn_in -= dt
		if _respawn_in <= 0.0:
			_spawn_drone()
	_update_aim_point()
	for i in range(missiles.size() - 1, -1, -1):
		if _step_missile(missiles[i], dt):
			missiles.remove_at(i)
	for i in range(_explosions.size() - 1, -1, -1):
		var e := _explosions[i]
		e["age"] += dt
		var node: MeshInstance3D = e["node"]
		node.scale = Vector3.ONE * (1.0 + 10.0 * e["age"])
		node.transparency = clampf(e["age"] / 0.7, 0.0, 1.0)
		if e["age"] >= 0.7:
			node.queue_free()
			_explosions.remove_at(i)
	# aim_error is from the last skeleton update: wait until it is about this drone.
	if drone_alive and _path_time >= SETTLE and missiles.is_empty() and _fire_cooldown <= 0.0 \
			and intercept_time > 0.0 and aim_error <= FIRE_ERROR:
		_fire()


func _fire() -> void:
	var m := muzzle()
	var dir := m.basis.y.normalized()
	var node := MeshInstance3D.new()
	node.mesh = _missile_mesh
	add_child(node)
	node.global_position = m.origin
	var missile := {"node": node, "position": m.origin, "velocity": dir * MISSILE_SPEED, "age": 0.0,
			"trail": PackedVector3Array([m.origin])}
	_orient_missile(missile)
	missiles.append(missile)
	shots += 1
	_fire_cooldown = FIRE_INTERVAL


## Moves one missile; returns true when it is done (hit, or expired).
func _step_missile(missile: Dictionary, dt: float) -> bool:
	missile["age"] += dt
	var pos: Vector3 = missile["position"]
	var vel: Vector3 = missile["velocity"]
	var accel := Vector3.ZERO
	if drone_alive:
		accel = Guidance.pn_acceleration(drone.global_position - pos, drone_velocity - vel, vel, drone_accel,
				NAV_CONSTANT, MAX_TURN_RATE * MISSILE_SPEED)
	var next: Array = Guidance.step_missile(pos, vel, accel, dt)
	var offset_before := drone.global_position - drone_velocity * dt - pos  # the drone has already moved
	missile["position"] = next[0]
	missile["velocity"] = next[1]
	var trail: PackedVector3Array = missile["trail"]
	trail.append(next[0])
	if trail.size() > 90:
		trail.remove_at(0)
	missile["trail"] = trail
	_orient_missile(missile)
	if drone_alive and Guidance.closest_approach(offset_before, drone.global_position - next[0]) <= HIT_RADIUS:
		hits += 1
		_explode(drone.global_position)
		drone_alive = false
		drone.visible = false
		_respawn_in = RESPAWN_DELAY
		(missile["node"] as Node).queue_free()
		return true
	if missile["age"] >= MISSILE_LIFE or next[0].y < 0.0:
		misses += 1
		(missile["node"] as Node).queue_free()
		return true
	return false


func _orient_missile(missile: Dictionary) -> void:
	var node: MeshInstance3D = missile["node"]
	var vel: Vector3 = missile["velocity"]
	node.global_position = missile["position"]
	# The capsule's long axis is +Y: a basis whose y is the velocity.
	var y := vel.normalized()
	var x := y.cross(Vector3.UP if absf(y.y) < 0.99 else Vector3.RIGHT).normalized()
	node.global_basis = Basis(x, y, x.cross(y))


func _explode(at: Vector3) -> void:
	var node := MeshInstance3D.new()
	node.mesh = _explosion_mesh
	node.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	add_child(node)
	node.global_position = at
	_explosions.append({"node": node, "age": 0.0})


# ------------------------------------------------------------------ measuring

# The solved pose is visible only inside the skeleton's update, so measure here.
func _on_skeleton_updated() -> void:
	var frame := Engine.get_process_frames()
	if _finished or frame == _last_frame:
		return
	_last_frame = frame
	_muzzle = skeleton.global_transform * skeleton.get_bone_global_pose(_muzzle_bone)
	var m := _muzzle
	var to_aim := aim_point.global_position - m.origin
	aim_error = m.basis.y.normalized().angle_to(to_aim.normalized())
	var r := ik.get_last_result()
	if drone_alive and _path_time >= SETTLE:
		aim_errors.append(aim_error)
		_second.add("aim", aim_error)
	_second.add("micros", float(r.get("microseconds", 0.0)))
	if drone_alive:
		_run.add("micros", float(r.get("microseconds", 0.0)))
		_run.add("iterations", float(r.get("iterations", 0)))
	if options["demo_seconds"] > 0.0 and time >= _next_report:
		_next_report += 1.0
		# No aim samples in a second the drone was down (respawning): say so instead of 0/0.
		var aim := rad_to_deg(_second.mean("aim"))
		var aim_text := "%.4f°" % aim if is_finite(aim) else "- (no drone)"
		print("missile_guidance t=%2.0f s: solver %s | mean aim error %s | shots %d, hits %d | %.1f µs per solve" % [
				time, str(r.get("solver", "?")), aim_text, shots, hits, _second.mean("micros")])
		_second.clear()


func max_aim_error() -> float:
	var m := 0.0
	for e in aim_errors:
		m = maxf(m, e)
	return m if aim_errors.size() > 0 else INF


func mean_aim_error() -> float:
	var sum := 0.0
	for e in aim_errors:
		sum += e
	return sum / aim_errors.size() if aim_errors.size() > 0 else INF


func _status_text() -> String:
	var r := ik.get_last_result()
	var lines := PackedStringArray()
	lines.append("aim error: %.3f° (mean %.3f°)" % [rad_to_deg(aim_error), rad_to_deg(mean_aim_error())])
	lines.append("shots %d   hits %d   misses %d" % [shots, hits, misses])
	if not drone_alive:
		lines.append("drone down; next one in %.1f s" % maxf(_respawn_in, 0.0))
	elif intercept_time > 0.0:
		lines.append("lead intercept in %.2f s" % intercept_time)
	else:
		lines.append("no intercept: aiming at the drone")
	lines.append("IK %s: %s, %d iterations, %.1f µs" % [r.get("solver", "?"), r.get("reason", "?"),
			int(r.get("iterations", 0)), float(r.get("microseconds", 0.0))])
	return "\n".join(lines)


## PASS needs hits and a barrel on the aim point: mean aim error within 0.5° while tracking.
func _finish() -> void:
	_finished = true
	var mean_deg := rad_to_deg(mean_aim_error())
	var why := ""
	if aim_errors.size() < 10:
		why = "too few skeleton updates (%d)" % aim_errors.size()
	elif not (mean_deg <= 0.5):
		why = "mean aim error %.3f° > 0.5°" % mean_deg
	elif hits == 0:
		why = "no hits in %d shots" % shots
	print("missile_guidance summary: %.0f s, shots %d, hits %d, misses %d, aim error mean %.4f°, max %.4f°, %.1f iterations, %.1f µs per solve" % [
			time, shots, hits, misses, mean_deg, rad_to_deg(max_aim_error()), _run.mean("iterations"), _run.mean("micros")])
	print("demo: PASS missile_guidance: %d hits of %d missiles (%d in flight at the end), mean aim error %.4f°" % [
			hits, hits + misses, missiles.size(), mean_deg] if why == "" else "demo: FAIL missile_guidance: %s" % why)
	get_tree().quit(0 if why == "" else 1)


# ------------------------------------------------------------------ visuals

func _build_visuals() -> void:
	var body := StandardMaterial3D.new()
	body.albedo_color = Color(0.85, 0.86, 0.9)
	body.metallic = 0.5
	var capsule := CapsuleMesh.new()
	capsule.radius = 0.2
	capsule.height = 1.6
	capsule.material = body
	_missile_mesh = capsule
	var fire := StandardMaterial3D.new()
	fire.shading_mode = BaseMaterial3D.SHADING_MODE_UNSHADED
	fire.albedo_color = Color(1.0, 0.55, 0.15)
	var ball := SphereMesh.new()
	ball.radius = 0.5
	ball.height = 1.0
	ball.material = fire
	_explosion_mesh = ball
	# The drone: a fuselage, wings and a tail, nose along -Z (look_at's forward).
	drone = Node3D.new()
	drone.name = "Drone"
	add_child(drone)
	var paint := StandardMaterial3D.new()
	paint.albedo_color = Color(0.75, 0.2, 0.15)
	for part in [[Vector3(0.5, 0.45, 2.6), Vector3.ZERO], [Vector3(4.4, 0.08, 0.8), Vector3(0, 0, -0.15)],
			[Vector3(1.6, 0.07, 0.5), Vector3(0, 0, 1.1)], [Vector3(0.07, 0.65, 0.5), Vector3(0, 0.3, 1.1)]]:
		var mesh := BoxMesh.new()
		mesh.size = part[0]
		mesh.material = paint
		var mi := MeshInstance3D.new()
		mi.mesh = mesh
		mi.position = part[1]
		drone.add_child(mi)
	# Trails and the lead line, rebuilt every frame.
	_lines = ImmediateMesh.new()
	var line_material := StandardMaterial3D.new()
	line_material.shading_mode = BaseMaterial3D.SHADING_MODE_UNSHADED
	line_material.vertex_color_use_as_albedo = true
	var lines := MeshInstance3D.new()
	lines.name = "Lines"
	lines.mesh = _lines
	lines.material_override = line_material
	lines.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	add_child(lines)


func _draw_lines() -> void:
	_lines.clear_surfaces()
	var any := drone_alive
	for missile in missiles:
		any = any or (missile["trail"] as PackedVector3Array).size() >= 2
	if not any:
		return
	_lines.surface_begin(Mesh.PRIMITIVE_LINES)
	if drone_alive:
		# Drone → lead point (where it will be), muzzle → lead point (where the barrel points).
		_lines.surface_set_color(Color(1.0, 0.85, 0.2))
		_lines.surface_add_vertex(drone.global_position)
		_lines.surface_add_vertex(aim_point.global_position)
		_lines.surface_set_color(Color(1.0, 0.85, 0.2, 0.5))
		_lines.surface_add_vertex(muzzle().origin)
		_lines.surface_add_vertex(aim_point.global_position)
	_lines.surface_set_color(Color(0.95, 0.95, 0.95))
	for missile in missiles:
		var trail: PackedVector3Array = missile["trail"]
		for i in range(1, trail.size()):
			_lines.surface_add_vertex(trail[i - 1])
			_lines.surface_add_vertex(trail[i])
	_lines.surface_end()


# ------------------------------------------------------------------ keys

func _unhandled_input(event: InputEvent) -> void:
	var key := event as InputEventKey
	if key == null or not key.pressed or key.echo:
		return
	if key.keycode >= KEY_1 and key.keycode < KEY_1 + Cli.SOLVERS.size():
		set_solver(Cli.SOLVERS[key.keycode - KEY_1][1])
	elif key.keycode == KEY_G:
		show_gizmo.button_pressed = not show_gizmo.button_pressed
	elif key.keycode == KEY_ESCAPE:
		back_to_menu()
