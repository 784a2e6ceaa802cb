extends SkeletonModifier3D
## A stand-in for IKBody while this build has none (the character demo's fallback): poses the
## humanoid from the same targets with textbook analytic pieces, limb by limb, no coupling:
## the Hips bone on its target, each leg and arm a two-bone solve (law of cosines, knees toward
## the heading, elbows back and down) with the foot taking its target's rotation, and the head
## turned to its look target. It does not crouch by itself and bends the spine only by a crude
## search (_bend_spine); the coupled solve of spine, legs and arms is what IKBody is for.

## Effector targets by bone name (Node3D, world transforms read each update).
var targets := {}
## How long the last update took (µs).
var last_usec := 0.0

var _bones := {}


func _ready() -> void:
	var skeleton := get_skeleton()
	if skeleton != null:
		for bone in ["Root", "Hips", "Spine", "Chest", "UpperChest", "Neck", "Head"]:
			_bones[bone] = skeleton.find_bone(bone)
		for side in ["Left", "Right"]:
			for part in ["UpperLeg", "LowerLeg", "Foot", "UpperArm", "LowerArm", "Hand"]:
				_bones[side + part] = skeleton.find_bone(side + part)


func _process_modification_with_delta(_delta: float) -> void:
	var skeleton := get_skeleton()
	if skeleton == null or _bones.is_empty() or targets.is_empty():
		return
	var start := Time.get_ticks_usec()
	var to_skeleton := skeleton.global_transform.affine_inverse()
	var hips := _target(to_skeleton, "Hips")
	var root_global := skeleton.get_bone_global_pose(_bones["Root"])
	skeleton.set_bone_pose(_bones["Hips"], root_global.affine_inverse() * hips)
	for side in ["Left", "Right"]:
		var foot := _target(to_skeleton, side + "Foot")
		_two_bone(skeleton, side + "UpperLeg", side + "LowerLeg", side + "Foot", foot.origin, hips.basis * Vector3.BACK)
		_set_global_basis(skeleton, side + "Foot", foot.basis)
	_bend_spine(skeleton, to_skeleton, hips.basis.x.normalized())
	for side in ["Left", "Right"]:
		var hand := _target(to_skeleton, side + "Hand")
		_two_bone(skeleton, side + "UpperArm", side + "LowerArm", side + "Hand", hand.origin,
				hips.basis * Vector3(0, -0.6, -0.8))
	var head := _target(to_skeleton, "Head")
	# A third of the turn in the neck, the rest in the head.
	var neck_global := skeleton.get_bone_global_pose(_bones["Neck"]).basis
	var turn := head.basis * skeleton.get_bone_global_pose(_bones["Head"]).basis.inverse()
	_set_global_basis(skeleton, "Neck", Basis(Quaternion().slerp(turn.get_rotation_quaternion(), 0.35)) * neck_global)
	_set_global_basis(skeleton, "Head", head.basis)
	last_usec = float(Time.get_ticks_usec() - start)


## Bends Spine, Chest and UpperChest forward (a third each, about `axis`) by the least angle that
## brings both shoulders within 95 % of the arm's length of their hand targets (bisection, up to
## 80°). Crude, but it keeps the stand-in's pick-up readable; IKBody solves it as part of the body.
func _bend_spine(skeleton: Skeleton3D, to_skeleton: Transform3D, axis: Vector3) -> void:
	var spine := ["Spine", "Chest", "UpperChest"]
	var start: Array[Basis] = []
	for bone in spine:
		start.append(skeleton.get_bone_global_pose(_bones[bone]).basis)
	var reach := 0.95 * _arm_length(skeleton)
	var goals := [_target(to_skeleton, "LeftHand").origin, _target(to_skeleton, "RightHand").origin]
	var short_of := func(angle: float) -> bool:
		for i in spine.size():
			_set_global_basis(skeleton, spine[i], Basis(axis, angle * (i + 1) / 3.0) * start[i])
		for i in 2:
			var shoulder := skeleton.get_bone_global_pose(_bones[["LeftUpperArm", "RightUpperArm"][i]]).origin
			if shoulder.distance_to(goals[i]) > reach:
				return true
		return false
	if not short_of.call(0.0):
		return
	var lo := 0.0
	var hi := deg_to_rad(80.0)
	for _i in 12:
		var mid := 0.5 * (lo + hi)
		if short_of.call(mid):
			lo = mid
		else:
			hi = mid
	short_of.call(hi)


func _arm_length(skeleton: Skeleton3D) -> float:
	var shoulder := skeleton.get_bone_global_rest(_bones["LeftUpperArm"]).origin
	var elbow := skeleton.get_bone_global_rest(_bones["LeftLowerArm"]).origin
	var wrist := skeleton.get_bone_global_rest(_bones["LeftHand"]).origin
	return shoulder.distance_to(elbow) + elbow.distance_to(wrist)


func _target(to_skeleton: Transform3D, bone: String) -> Transform3D:
	var node := targets.get(bone) as Node3D
	return to_skeleton * node.global_transform if node != null else Transform3D()


## Turns `upper` and `lower` (keeping their lengths) so that `end`'s origin lands on `goal`
## (skeleton space), bending toward `pole`; the smallest swing of each bone from its current pose.
func _two_bone(skeleton: Skeleton3D, upper: String, lower: String, end: String, goal: Vector3, pole: Vector3) -> void:
	var a_pose := skeleton.get_bone_global_pose(_bones[upper])
	var b_pose := skeleton.get_bone_global_pose(_bones[lower])
	var c_pose := skeleton.get_bone_global_pose(_bones[end])
	var root := a_pose.origin
	var len_a := root.distance_to(b_pose.origin)
	var len_b := b_pose.origin.distance_to(c_pose.origin)
	var to_goal := goal - root
	var d := clampf(to_goal.length(), absf(len_a - len_b) + 1e-4, len_a + len_b - 1e-4)
	var dir := to_goal.normalized() if to_goal.length() > 1e-6 else Vector3.DOWN
	var bend := (pole - dir * pole.dot(dir)).normalized()
	var cos_a := clampf((len_a * len_a + d * d - len_b * len_b) / (2.0 * len_a * d), -1.0, 1.0)
	var mid := root + len_a * (cos_a * dir + sqrt(1.0 - cos_a * cos_a) * bend)
	var tip := root + dir * d
	_swing(skeleton, upper, a_pose, mid - root)
	var b_now := skeleton.get_bone_global_pose(_bones[lower])
	_swing(skeleton, lower, b_now, tip - mid)


## Turns bone `bone` (global pose `pose`) by the smallest rotation that puts its +Y along `along`.
func _swing(skeleton: Skeleton3D, bone: String, pose: Transform3D, along: Vector3) -> void:
	var y := pose.basis.y.normalized()
	var to := along.normalized()
	var axis := y.cross(to)
	var turn := Basis()
	if axis.length() > 1e-9:
		turn = Basis(axis.normalized(), y.angle_to(to))
	_set_global_basis(skeleton, bone, turn * pose.basis)


func _set_global_basis(skeleton: Skeleton3D, bone: String, basis: Basis) -> void:
	var i: int = _bones[bone]
	var parent := skeleton.get_bone_parent(i)
	var parent_basis := skeleton.get_bone_global_pose(parent).basis if parent >= 0 else Basis()
	skeleton.set_bone_pose_rotation(i, (parent_basis.inverse() * basis).get_rotation_quaternion())
