@tool
@icon("res://addons/ikchain/icons/IKBodyEffector.svg")
class_name IKFootPlacement
extends Node
## Foot placement on uneven ground for an [IKBody]: add it as a child of the IKBody and name the
## foot effectors.
##
## Every physics frame it casts a ray down under each foot (from above the animated foot to below
## it, [method PhysicsDirectSpaceState3D.intersect_ray]), puts the foot's effector target on the
## hit point at the height the animation holds the foot above the skeleton's ground plane (a
## lifted foot stays lifted by as much over the ground below it), turns the foot so that its up
## axis follows the surface normal, and lowers the hips' effector target so that the lower foot
## still reaches (the hips never rise above the animation). Heights and normals move toward their
## goals smoothly: an exponential approach ([member smoothing]) with a bounded speed
## ([member max_height_speed], [member max_turn_speed]), so a step down does not pop.
##
## It writes the effectors' [member IKBodyEffector.target_transform] (and turns on
## [member IKBodyEffector.use_target_transform]); the feet need a [member IKBodyEffector.rotation_weight]
## above 0 to follow the normal, the hips need [member IKBody.floating_root] and a hips effector to
## lower. A foot whose ray hits nothing follows the animation.

## Bone names of the IKBody's foot effectors.
@export var feet := PackedStringArray(["LeftFoot", "RightFoot"]):
	set(value):
		feet = value
		_resolved_size = -1
		update_configuration_warnings()
## Bone name of the IKBody's hips effector (lowered so both feet reach); empty: the hips stay.
@export var hips := "Hips":
	set(value):
		hips = value
		_resolved_size = -1
		update_configuration_warnings()
## How far above the animated foot the ray starts (m): the highest step a foot climbs.
@export_range(0.0, 5.0, 0.01, "suffix:m") var ray_above := 0.6
## How far below the skeleton's ground plane the ray reaches (m): the deepest step a foot goes down.
@export_range(0.0, 5.0, 0.01, "suffix:m") var ray_below := 0.6
## The physics layers the rays hit.
@export_flags_3d_physics var collision_mask := 1
## How fast heights and normals approach their goals (1/s; the share left after t seconds is
## exp(-smoothing * t)). 0: at once (up to the speed limits).
@export_range(0.0, 100.0, 0.1, "suffix:1/s") var smoothing := 15.0
## The fastest a foot's or the hips' height changes (m/s).
@export_range(0.01, 100.0, 0.01, "suffix:m/s") var max_height_speed := 1.5
## The fastest a foot's normal turns (rad/s).
@export_range(0.1, 100.0, 0.1, "radians_as_degrees") var max_turn_speed := 6.0
## Off: the effectors are left as they are (the feet follow their targets or the animation).
@export var enabled := true

var _body: IKBody
var _resolved_size := -1
var _foot_effectors: Array[IKBodyEffector] = []
var _hips_effector: IKBodyEffector
# Skeleton bone indices of the feet and the hips (-1: not a bone), resolved with the effectors.
var _foot_bones := PackedInt32Array()
var _hips_bone := -1
var _resolved_skeleton: Skeleton3D
var _resolved_bone_count := -1
var _resolved_ok := false
var _resolved_floating := false
var _query := PhysicsRayQueryParameters3D.new()
# Per foot: the smoothed height offset from the animation along up (m) and surface normal.
var _offset := PackedFloat64Array()
var _normal: Array[Vector3] = []
var _hips_offset := 0.0
var _started := false


func _ready() -> void:
	_body = get_parent() as IKBody


func _notification(what: int) -> void:
	if what == NOTIFICATION_PARENTED:
		_body = get_parent() as IKBody
		_resolved_size = -1
		update_configuration_warnings()


func _get_configuration_warnings() -> PackedStringArray:
	var out := PackedStringArray()
	var body := get_parent() as IKBody
	if body == null:
		out.append("IKFootPlacement: the parent is not an IKBody; make it a child of the IKBody whose feet it places.")
		return out
	var by_bone := {}
	for e in body.effectors:
		if e != null:
			by_bone[e.bone_name] = e
	if feet.is_empty():
		out.append("IKFootPlacement: feet is empty; name the IKBody's foot effectors (their bone names).")
	for f in feet:
		if not by_bone.has(f):
			out.append("IKFootPlacement: no effector of the IKBody has bone '%s'; add one (or call setup_humanoid()) "
					% f + "or fix the name in feet.")
		elif not (by_bone[f].rotation_weight > 0.0):
			out.append("IKFootPlacement: effector '%s' has rotation_weight 0, so the foot cannot follow the " % f
					+ "ground's normal; set it above 0.")
	if hips != "":
		if not by_bone.has(hips):
			out.append("IKFootPlacement: no effector of the IKBody has bone '%s'; add a hips effector or clear hips."
					% hips)
		elif not body.floating_root:
			out.append("IKFootPlacement: the IKBody's floating_root is off, so the hips cannot lower; turn it on.")
	return out


func _physics_process(delta: float) -> void:
	if not Engine.is_editor_hint() and enabled:
		place(delta)


## Casts the rays and moves the targets by one step of [param delta] seconds (called every physics
## frame; call it yourself with [member enabled] off to drive it by hand). Returns false (and
## leaves the targets) when the body is not usable.
func place(delta: float) -> bool:
	if _body == null or not is_instance_valid(_body) or not _body.is_inside_tree():
		return false
	var skel := _body.get_skeleton()
	if skel == null or not _resolve(skel):
		return false
	var space := _body.get_world_3d().direct_space_state
	var skel_xform := skel.global_transform
	var up := skel_xform.basis.y.normalized()
	var ground := skel_xform.origin  # the skeleton's ground plane passes through its origin
	var step := clampf(1.0 - exp(-smoothing * maxf(delta, 0.0)), 0.0, 1.0) if smoothing > 0.0 else 1.0
	var max_rise := max_height_speed * maxf(delta, 0.0)
	var max_turn := max_turn_speed * maxf(delta, 0.0)
	if not _started:
		step = 1.0
		max_rise = INF
		max_turn = INF
	var lowest := 0.0
	for k in _foot_effectors.size():
		var e := _foot_effectors[k]
		if _foot_bones[k] < 0:
			continue
		var animated := skel_xform * skel.get_bone_global_pose(_foot_bones[k])
		var height := (animated.origin - ground).dot(up)  # how high the animation holds the foot
		var foot_on_plane := animated.origin - up * height
		_query.from = foot_on_plane + up * (height + ray_above)
		_query.to = foot_on_plane - up * ray_below
		_query.collision_mask = collision_mask
		var hit := space.intersect_ray(_query)
		var offset_goal := 0.0
		var normal_goal := up
		if not hit.is_empty():
			normal_goal = (hit["normal"] as Vector3).normalized()
			offset_goal = (hit["position"] - foot_on_plane).dot(up)
		_offset[k] = _offset[k] + clampf((offset_goal - _offset[k]) * step, -max_rise, max_rise)
		_normal[k] = _turn_toward(_normal[k], normal_goal, step, max_turn)
		# The foot turned from the animation's up onto the surface normal, its origin the animated
		# height above the (smoothed) ground point along the normal: a foot on a slope sits on it.
		var tilt := Quaternion(up, _normal[k]) if up.dot(_normal[k]) > -0.999 else Quaternion()
		var target := Transform3D(Basis(tilt) * animated.basis,
				foot_on_plane + up * _offset[k] + _normal[k] * height)
		lowest = minf(lowest, (target.origin - animated.origin).dot(up))
		e.target_transform = target
	if _hips_effector != null and _hips_bone >= 0:
		var hips_goal := minf(lowest, 0.0)
		_hips_offset = _hips_offset + clampf((hips_goal - _hips_offset) * step, -max_rise, max_rise)
		var animated_hips := skel_xform * skel.get_bone_global_pose(_hips_bone)
		_hips_effector.target_transform = Transform3D(animated_hips.basis, animated_hips.origin + up * _hips_offset)
	_started = true
	return true


## The current smoothed height offset of foot [param index] (in [member feet]) from the animation
## along the skeleton's up axis (m), and of the hips.
func get_foot_offset(index: int) -> float:
	return _offset[index] if index >= 0 and index < _offset.size() else NAN


func get_hips_offset() -> float:
	return _hips_offset


## Forgets the smoothed state, so the next frame jumps to the ground (after a teleport), and looks
## the effectors up again (after the body's effectors were replaced by others).
func reset() -> void:
	_started = false
	_resolved_size = -1


func _resolve(skel: Skeleton3D) -> bool:
	if _resolved_size == _body.effectors.size() and _resolved_skeleton == skel \
			and _resolved_bone_count == skel.get_bone_count() and _resolved_floating == _body.floating_root:
		return _resolved_ok  # (a failure was reported once, when it was found)
	_resolved_skeleton = skel
	_resolved_bone_count = skel.get_bone_count()
	_resolved_floating = _body.floating_root
	_foot_effectors.clear()
	_hips_effector = null
	var by_bone := {}
	for e in _body.effectors:
		if e != null:
			by_bone[e.bone_name] = e
	for f in feet:
		if not by_bone.has(f):
			push_error("IKFootPlacement: no effector of the IKBody has bone '%s'; add one or fix feet. " % f
					+ "Foot placement is off until then.")
			_foot_effectors.clear()
			_resolved_size = _body.effectors.size()
			_resolved_ok = false
			return false
		_foot_effectors.append(by_bone[f])
	if hips != "" and by_bone.has(hips) and _body.floating_root:
		_hips_effector = by_bone[hips]
	for e in _foot_effectors + ([_hips_effector] if _hips_effector != null else []):
		if not e.use_target_transform:
			e.use_target_transform = true
	_foot_bones.clear()
	for e in _foot_effectors:
		_foot_bones.append(skel.find_bone(e.bone_name))
	_hips_bone = skel.find_bone(_hips_effector.bone_name) if _hips_effector != null else -1
	_offset.resize(_foot_effectors.size())
	_offset.fill(0.0)
	_normal.clear()
	for e in _foot_effectors:
		_normal.append(Vector3.UP)
	_started = false
	_resolved_size = _body.effectors.size()
	_resolved_ok = true
	return true


static func _turn_toward(from: Vector3, to: Vector3, share: float, max_angle: float) -> Vector3:
	var angle := from.angle_to(to)
	if angle < 1e-9:
		return to
	var turn := minf(angle * share, max_angle)
	var axis := from.cross(to)
	if axis.length() < 1e-9:
		axis = from.cross(Vector3.RIGHT if absf(from.x) < 0.9 else Vector3.UP)
	return from.rotated(axis.normalized(), turn).normalized()
