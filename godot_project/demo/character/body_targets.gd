extends RefCounted
## Where a walking humanoid's effectors should be: foot placement on uneven ground, the hips'
## height, swinging or reaching hands, and a head that looks. Pure target logic: it writes the
## world transforms of the effector targets (Node3D markers), never a bone; a full-body IK node
## (IKBody) moves the skeleton onto them.
##
## Each physics frame the caller gives the character's ground frame (`root`: origin on the path at
## floor level, basis = heading; the character faces its local +Z, its left on +X) and its
## velocity; `update()` then
## - casts a ray down under each foot's home (beside the hips, a little ahead when walking): the
##   contact point and the surface normal;
## - keeps each foot planted (rolling onto its toes as it trails: heel-off) until it trails its
##   home by more than STEP_TRIGGER (or is turned more than 25° from the heading), then swings it, one foot at a time, onto a new contact ahead:
##   smoothstep across, an arc that clears the highest ground under the swing (ray cast at three
##   points), the foot's sole turned onto the new surface normal;
## - lowers the hips just enough that both ankles are within LEG_REACH of the hip joints, and
##   smooths the rest of their height (a critically damped spring), so steps down don't pop;
## - moves the hands: swinging beside the thighs opposite to the feet, or onto `reach_points`
##   (a pick-up: the caller drives `reach_weight` from 0 to 1);
## - turns the head target toward `look_at_point`, limited to ±70° of yaw and ±30° of pitch of the
##   heading, eased.

## How far a planted foot may trail its home before it steps (m at walking speed).
const STEP_TRIGGER := 0.2
## How long a swing takes (s); the other foot stays planted meanwhile.
const SWING_TIME := 0.34
## Least time both feet stay planted between two swings (s).
const DOUBLE_SUPPORT := 0.1
## The walking speed STEP_TRIGGER is tuned for (m/s); slower walks take shorter steps.
const WALK_SPEED := 0.8
## Foot lift over the highest ground under the swing (m).
const CLEARANCE := 0.07
## Fraction of the leg's length (hip joint to ankle) the hips keep the feet within.
const LEG_REACH := 0.985
## How much lower than the rest pose the hips walk (m): a little bent knee.
const WALK_CROUCH := 0.008
## Heel-off: a planted foot trailing its home by more than HEEL_OFF_START (m) rolls onto its toes,
## up to HEEL_OFF_MAX when it trails by HEEL_OFF_START + HEEL_OFF_RANGE; so the hips need not drop
## to keep a trailing flat foot in reach.
const HEEL_OFF_START := 0.1
const HEEL_OFF_RANGE := 0.25
const HEEL_OFF_MAX := deg_to_rad(30.0)
## How far the hips (and the body on them) lean forward at walking speed (rad).
const WALK_LEAN := deg_to_rad(4.0)
## Hips height smoothing: the spring's time constant (s).
const HIPS_SMOOTHING := 0.12
## Look-at limits relative to the heading (rad) and easing rate (1/s).
const LOOK_YAW_LIMIT := deg_to_rad(70.0)
const LOOK_PITCH_LIMIT := deg_to_rad(30.0)
const LOOK_RATE := 6.0

## One foot's state.
class Foot:
	var side := 1.0  ## +1 left, -1 right
	var hip_in_hips := Vector3.ZERO  ## the hip joint in the hips' frame (rest)
	var home_in_root := Vector3.ZERO  ## the ankle's place beside the hips, in the ground frame
	var rest_basis := Basis()  ## the foot bone's rest basis in the skeleton's space
	var planted := Transform3D()  ## the ankle's target while planted (world)
	var contact := Vector3.ZERO  ## the ground point under the planted ankle (world)
	var normal := Vector3.UP
	var swinging := false
	var swing_from := Transform3D()
	var swing_to := Transform3D()
	var swing_to_contact := Vector3.ZERO
	var swing_to_normal := Vector3.UP
	var swing_t := 0.0
	var swing_top := 0.0  ## the highest ground under the swing (world y)
	var target := Transform3D()  ## what the foot's effector target gets this frame (world)

	## Progress through the swing in [0, 1]; 0 when planted.
	func swing_phase() -> float:
		return clampf(swing_t / SWING_TIME, 0.0, 1.0) if swinging else 0.0


var feet: Array[Foot] = []
## The hips' target (world) and its bone's rest in the skeleton's space.
var hips := Transform3D()
var hips_rest := Transform3D()
var hands: Array[Transform3D] = [Transform3D(), Transform3D()]  ## left, right (world)
var head := Transform3D()  ## the head's target: its origin near the head, its basis the look
var head_rest := Transform3D()
var look_at_point := Vector3.ZERO
## Where the head was last posed (world; NAN until known): the head's target takes it as its
## origin, which only places the marker and the look's start (the head effector is rotation only).
var head_origin := Vector3(NAN, NAN, NAN)
## Where the hands should be when reaching (world), and how far they have gone there (0..1).
var reach_points: Array[Vector3] = [Vector3.ZERO, Vector3.ZERO]
var reach_weight := 0.0
## How much the hips crouch on top of what the feet need, and move back meanwhile (m); the
## caller drives both.
var crouch := 0.0
var lean_back := 0.0
## How far the pelvis tilts forward on top of the walk's lean (rad; the caller drives it: a
## pick-up bends at the hips first, the spine does the rest).
var pelvis_tilt := 0.0
## Measured once from the skeleton's rest.
var ankle_height := 0.07
var toe_ahead := 0.13  ## how far the toes' joint is ahead of the ankle (m)
var leg_length := 0.8
var arm_length := 0.5
var shoulders_in_hips: Array[Vector3] = [Vector3.ZERO, Vector3.ZERO]

var _hips_y := NAN
var _hips_y_rate := 0.0
var _since_landing := 1.0
var _look_dir_local := Vector3.FORWARD
var _space: PhysicsDirectSpaceState3D
var _ray := PhysicsRayQueryParameters3D.new()


## Reads the proportions the targets need from the skeleton's rest (bones by humanoid name).
func _init(skeleton: Skeleton3D) -> void:
	var rest := func(bone: String) -> Transform3D:
		return skeleton.get_bone_global_rest(skeleton.find_bone(bone))
	hips_rest = rest.call("Hips")
	head_rest = rest.call("Head")
	for side in [1.0, -1.0]:
		var n := "Left" if side > 0.0 else "Right"
		var foot := Foot.new()
		foot.side = side
		var hip: Transform3D = rest.call(n + "UpperLeg")
		var ankle: Transform3D = rest.call(n + "Foot")
		foot.hip_in_hips = hips_rest.affine_inverse() * hip.origin
		foot.home_in_root = Vector3(ankle.origin.x, 0.0, ankle.origin.z)
		foot.rest_basis = ankle.basis
		ankle_height = ankle.origin.y
		var toes: Transform3D = rest.call(n + "Toes")
		toe_ahead = Vector2(toes.origin.x - ankle.origin.x, toes.origin.z - ankle.origin.z).length()
		leg_length = hip.origin.distance_to(rest.call(n + "LowerLeg").origin) \
				+ (rest.call(n + "LowerLeg") as Transform3D).origin.distance_to(ankle.origin)
		feet.append(foot)
		var shoulder: Transform3D = rest.call(n + "UpperArm")
		var elbow: Transform3D = rest.call(n + "LowerArm")
		var wrist: Transform3D = rest.call(n + "Hand")
		arm_length = shoulder.origin.distance_to(elbow.origin) + elbow.origin.distance_to(wrist.origin)
		shoulders_in_hips[0 if side > 0.0 else 1] = hips_rest.affine_inverse() * shoulder.origin
	_ray.collide_with_areas = false


## Puts both feet down beside `root` (no swing) and the hips over them.
func reset(space: PhysicsDirectSpaceState3D, root: Transform3D) -> void:
	_space = space
	for foot in feet:
		var contact := _ground(root * foot.home_in_root, root.origin.y)
		foot.contact = contact[0]
		foot.normal = contact[1]
		foot.planted = _foot_on_ground(foot, root.basis, foot.contact, foot.normal)
		foot.target = foot.planted
		foot.swinging = false
	_hips_y = NAN
	_look_dir_local = Vector3.BACK  # +Z: ahead
	update(space, root, Vector3.ZERO, 0.0)


## One frame: `root` is the ground frame under the hips, `velocity` its speed (m/s, world),
## `yaw_rate` its turning speed (rad/s, about +Y).
func update(space: PhysicsDirectSpaceState3D, root: Transform3D, velocity: Vector3, delta: float, yaw_rate := 0.0) -> void:
	_space = space
	var heading := root.basis.orthonormalized()
	var speed := Vector3(velocity.x, 0.0, velocity.z).length()
	var gait := clampf(speed / WALK_SPEED, 0.0, 1.0)
	var trigger := lerpf(0.05, STEP_TRIGGER, gait)
	var lead := velocity * (SWING_TIME + STEP_TRIGGER / WALK_SPEED * gait)
	_since_landing += delta
	# Swings in flight.
	for foot in feet:
		if foot.swinging:
			foot.swing_t += delta
			if foot.swing_t >= SWING_TIME:
				foot.swinging = false
				foot.planted = foot.swing_to
				foot.contact = foot.swing_to_contact
				foot.normal = foot.swing_to_normal
				_since_landing = 0.0
	# Start a swing: the foot that trails its home most, once the other one is down.
	var anyone_swinging := feet[0].swinging or feet[1].swinging
	if not anyone_swinging and _since_landing >= DOUBLE_SUPPORT:
		var worst: Foot = null
		var worst_error := 0.0
		for foot in feet:
			# Against where the home will be when a swing started now would land.
			var home := root * foot.home_in_root + velocity * SWING_TIME
			var off := foot.planted.origin - home
			var lag := Vector2(off.x, off.z).length()
			var turn := _yaw_between(foot.planted.basis * foot.rest_basis.inverse(), heading)
			var error := maxf(lag / trigger, turn / deg_to_rad(25.0))
			if error > 1.0 and error > worst_error:
				worst = foot
				worst_error = error
		if worst != null:
			# Land where the home will be: turned and moved on by the swing's time, plus a lead.
			var turned := Transform3D(Basis(Vector3.UP, yaw_rate * SWING_TIME * 1.5) * heading, root.origin)
			_start_swing(worst, turned, lead)
	for foot in feet:
		foot.target = _swing_pose(foot) if foot.swinging else _heel_off(foot, root)
	_update_hips(root, heading, delta, gait)
	_update_hands(heading)
	_update_head(heading, delta)


func _start_swing(foot: Foot, root: Transform3D, lead: Vector3) -> void:
	var home := root * foot.home_in_root + Vector3(lead.x, 0.0, lead.z)
	var contact := _ground(home, root.origin.y)
	foot.swing_from = foot.target
	foot.swing_to_contact = contact[0]
	foot.swing_to_normal = contact[1]
	foot.swing_to = _foot_on_ground(foot, root.basis.orthonormalized(), contact[0], contact[1])
	foot.swing_t = 0.0
	foot.swinging = true
	var top := maxf(foot.contact.y, foot.swing_to_contact.y)
	for s in [0.25, 0.5, 0.75]:
		var p := foot.contact.lerp(foot.swing_to_contact, s)
		top = maxf(top, (_ground(p, p.y)[0] as Vector3).y)
	foot.swing_top = top


## A planted foot's target, rolled onto its toes as it trails its home (HEEL_OFF_*): turned about
## the line across the sole under the toes' joint, so the toes stay where they were planted.
func _heel_off(foot: Foot, root: Transform3D) -> Transform3D:
	var forward := root.basis.orthonormalized() * Vector3.BACK
	var trail := (root * foot.home_in_root - foot.planted.origin).dot(forward)
	var angle := clampf((trail - HEEL_OFF_START) / HEEL_OFF_RANGE, 0.0, 1.0) * HEEL_OFF_MAX
	if angle <= 0.0:
		return foot.planted
	var along := (forward - foot.normal * forward.dot(foot.normal)).normalized()  # on the surface
	var pivot := foot.contact + along * toe_ahead
	var roll := Basis(foot.normal.cross(along).normalized(), angle)
	return Transform3D(roll * foot.planted.basis, pivot + roll * (foot.planted.origin - pivot))


## The ankle's transform during a swing: across on a smoothstep, up on an arc over swing_top.
func _swing_pose(foot: Foot) -> Transform3D:
	var s := foot.swing_phase()
	var across := smoothstep(0.0, 1.0, s)
	var origin := foot.swing_from.origin.lerp(foot.swing_to.origin, across)
	var floor_y := lerpf(foot.swing_from.origin.y, foot.swing_to.origin.y, across)
	var lift := maxf(0.0, foot.swing_top + ankle_height - floor_y) + CLEARANCE
	origin.y = floor_y + lift * 4.0 * s * (1.0 - s)
	var from := foot.swing_from.basis.get_rotation_quaternion()
	var to := foot.swing_to.basis.get_rotation_quaternion()
	return Transform3D(Basis(from.slerp(to, across)), origin)


## The ankle's transform for a foot standing on `contact` with the sole on the surface `normal`,
## toes along the heading.
func _foot_on_ground(foot: Foot, heading: Basis, contact: Vector3, normal: Vector3) -> Transform3D:
	var tilt := _turn_onto(Vector3.UP, normal)
	return Transform3D(tilt * heading * foot.rest_basis, contact + normal * ankle_height)


## The hips: the ground frame's heading (leaning forward by WALK_LEAN at walking speed, `gait` = 1,
## and by pelvis_tilt)
## and the rest height less a little over the feet's ground, smoothed, then lowered at once so
## that both ankle targets stay within LEG_REACH of their hip joints.
func _update_hips(root: Transform3D, heading: Basis, delta: float, gait: float) -> void:
	var basis := heading * Basis(Vector3.RIGHT, WALK_LEAN * gait + pelvis_tilt) * hips_rest.basis
	var xz := root * Vector3(hips_rest.origin.x, 0.0, hips_rest.origin.z - lean_back)
	# On the ground under the feet (their mean; a swinging foot's landing), not under the hips:
	# hips over a step's edge stay level; the reach limit below lowers them when a foot needs it.
	var ground := -ankle_height
	for foot in feet:
		ground += 0.5 * (foot.swing_to.origin.y if foot.swinging else foot.planted.origin.y)
	var want := ground + hips_rest.origin.y - WALK_CROUCH - crouch
	if is_nan(_hips_y):
		_hips_y = want
		_hips_y_rate = 0.0
	# Critically damped spring toward `want`.
	var w := 2.0 / HIPS_SMOOTHING
	var accel := w * w * (want - _hips_y) - 2.0 * w * _hips_y_rate
	_hips_y_rate += accel * delta
	_hips_y += _hips_y_rate * delta
	var y := _hips_y
	# Hard limit: each ankle target within reach of its hip joint.
	for foot in feet:
		var hip_offset := basis * foot.hip_in_hips
		var hip_xz := Vector3(xz.x + hip_offset.x, 0.0, xz.z + hip_offset.z)
		var ankle := foot.target.origin
		var across := Vector2(ankle.x - hip_xz.x, ankle.z - hip_xz.z).length()
		var reach := LEG_REACH * leg_length
		var up := sqrt(maxf(reach * reach - across * across, 0.0))
		y = minf(y, ankle.y + up - hip_offset.y)
	if y < _hips_y:
		_hips_y = y
		_hips_y_rate = minf(_hips_y_rate, 0.0)
	hips = Transform3D(basis, Vector3(xz.x, y, xz.z))


## Hands: hanging beside the thighs, swinging opposite to the feet; blended onto reach_points.
func _update_hands(heading: Basis) -> void:
	var forward := heading * Vector3.BACK
	for i in 2:
		var shoulder := hips * shoulders_in_hips[i]
		# The opposite foot's place ahead of or behind the hips drives this arm's swing.
		var other := feet[1 - i].target.origin - hips.origin
		var swing := clampf(other.dot(forward) / 0.35, -1.0, 1.0) * deg_to_rad(18.0)
		var side := heading * Vector3(1.0 if i == 0 else -1.0, 0.0, 0.0)
		var hang := Basis(side, -swing) * (Vector3.DOWN * 0.93 * arm_length) + side * 0.06 + forward * 0.03
		var hanging := shoulder + hang
		var point := hanging.lerp(reach_points[i], smoothstep(0.0, 1.0, reach_weight))
		hands[i] = Transform3D(heading, point)


## The head: look toward look_at_point, limited and eased; the origin at the posed head (or, before
## the first pose, where the rest pose puts it over the hips).
func _update_head(heading: Basis, delta: float) -> void:
	var origin := hips * (hips_rest.affine_inverse() * head_rest.origin)
	if not is_nan(head_origin.x):
		origin = head_origin
	var to_point := heading.inverse() * (look_at_point - origin)
	if to_point.length() < 1e-3:
		to_point = Vector3.BACK
	var yaw := clampf(atan2(to_point.x, to_point.z), -LOOK_YAW_LIMIT, LOOK_YAW_LIMIT)
	var pitch := clampf(atan2(to_point.y, Vector2(to_point.x, to_point.z).length()), -LOOK_PITCH_LIMIT, LOOK_PITCH_LIMIT)
	var want := Vector3(sin(yaw) * cos(pitch), sin(pitch), cos(yaw) * cos(pitch))
	_look_dir_local = _look_dir_local.slerp(want, 1.0 - exp(-LOOK_RATE * delta)).normalized() if delta > 0.0 else want
	# +Z (the face) toward the look, no roll.
	var look := Basis.looking_at(_look_dir_local, Vector3.UP, true)
	head = Transform3D(heading * look * head_rest.basis, origin)


## Where the look is pointing now (world, unit).
func look_direction() -> Vector3:
	return hips.basis * hips_rest.basis.inverse() * _look_dir_local


## [contact point, normal] of the ground under `p` (a ray from 1.5 m above `from_y` down 4 m);
## the floor plane y = 0 if nothing is hit.
func _ground(p: Vector3, from_y: float) -> Array:
	if _space != null:
		_ray.from = Vector3(p.x, from_y + 1.5, p.z)
		_ray.to = Vector3(p.x, from_y - 2.5, p.z)
		var hit := _space.intersect_ray(_ray)
		if not hit.is_empty():
			return [hit["position"], (hit["normal"] as Vector3).normalized()]
	return [Vector3(p.x, 0.0, p.z), Vector3.UP]


## The smallest rotation taking unit vector `from` onto unit vector `to`.
static func _turn_onto(from: Vector3, to: Vector3) -> Basis:
	var axis := from.cross(to)
	if axis.length() < 1e-9:
		return Basis() if from.dot(to) > 0.0 else Basis(Vector3.RIGHT, PI)
	return Basis(axis.normalized(), from.angle_to(to))


## The angle between two frames' forward (+Z) directions seen from above (rad, ≥ 0).
static func _yaw_between(a: Basis, b: Basis) -> float:
	var fa := a * Vector3.BACK
	var fb := b * Vector3.BACK
	return absf(angle_difference(atan2(fa.x, fa.z), atan2(fb.x, fb.z)))
