extends SkeletonModifier3D
## A stand-in for IKBody while this build has none (the character demo's fallback): poses the
## humanoid from the same targets with textbook analytic pieces, limb by limb, no coupling:
## the Hips bone on its target, each leg and arm a two-bone solve (law of cosines, knees toward
## the heading, elbows back and down) with the foot taking its target's rotation, and the head
## turned to its look target. It does not crouch by itself and bends forward only by a crude
## search (_bend_forward); the coupled solve of pelvis, spine, legs and arms is what IKBody is for.

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
	var root_global := _global(skeleton, _bones["Root"])
	skeleton.set_bone_pose(_bones["Hips"], root_global.affine_inverse() * hips)
	_bend_forward(skeleton, to_skeleton, hips.basis.x.normalized())
	for side in ["Left", "Right"]:
		var foot := _target(to_skeleton, side + "Foot")
		_two_bone(skeleton, side + "UpperLeg", side + "LowerLeg", side + "Foot", foot.origin, hips.basis * Vector3.BACK)
		_set_global_basis(skeleton, side + "Foot", foot.basis)
	for side in ["Left", "Right"]:
		var hand := _target(to_skeleton, side + "Hand")
		_two_bone(skeleton, side + "UpperArm", side + "LowerArm", side + "Hand", hand.origin,
				hips.basis * Vector3(0, -0.6, -0.8))
	var head := _target(to_skeleton, "Head")
	# A third of the turn in the neck, the rest in the head.
	var neck_global := _global(skeleton, _bones["Neck"]).basis
	var turn := head.basis * _global(skeleton, _bones["Head"]).basis.inverse()
	_set_global_basis(skeleton, "Neck", Basis(Quaternion().slerp(turn.get_rotation_quaternion(), 0.35)) * neck_global)
	_set_global_basis(skeleton, "Head", head.basis)
	last_usec = float(Time.get_ticks_usec() - start)


## Bends the body forward at the pelvis and the spine (the Hips bone half of the angle, Spine,
## Chest and UpperChest a sixth each, about `axis`) by the least angle that brings both shoulders
## within 98.5 % of the arm's length of their hand targets (bisection, up to 110°); the legs are
## solved afterwards from the tilted pelvis. Crude, but it keeps the stand-in's pick-up readable;
## IKBody solves it as part of the body.
func _bend_forward(skeleton: Skeleton3D, to_skeleton: Transform3D, axis: Vector3) -> void:
	var bones := ["Hips", "Spine", "Chest", "UpperChest"]
	var shares := [0.5, 0.1667, 0.1667, 0.1667]
	var start: Array[Basis] = []
	for bone in bones:
		start.append(_global(skeleton, _bones[bone]).basis)
	var reach := 0.985 * _arm_length(skeleton)
	var goals := [_target(to_skeleton, "LeftHand").origin, _target(to_skeleton, "RightHand").origin]
	var short_of := func(angle: float) -> bool:
		var turned := 0.0
		for i in bones.size():
			turned += shares[i] * angle
			_set_global_basis(skeleton, bones[i], Basis(axis, turned) * start[i])
		for i in 2:
			var shoulder := _global(skeleton, _bones[["LeftUpperArm", "RightUpperArm"][i]]).origin
			if shoulder.distance_to(goals[i]) > reach:
				return true
		return false
	if not short_of.call(0.0):
		return
	var lo := 0.0
	var hi := deg_to_rad(110.0)
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


## A bone's pose in the skeleton's space, composed from the local poses set so far: the
## skeleton's own get_bone_global_pose() can lag behind poses set within one modification.
func _global(skeleton: Skeleton3D, bone: int) -> Transform3D:
	var pose := skeleton.get_bone_pose(bone)
	var parent := skeleton.get_bone_parent(bone)
	while parent >= 0:
		pose = skeleton.get_bone_pose(parent) * pose
		parent = skeleton.get_bone_parent(parent)
	return pose


func _target(to_skeleton: Transform3D, bone: String) -> Transform3D:
	var node := targets.get(bone) as Node3D
	return to_skeleton * node.global_transform if node != null else Transform3D()


## Turns `upper` and `lower` (keeping their lengths) so that `end`'s origin lands on `goal`
## (skeleton space), bending toward `pole`; the smallest swing of each bone from its current pose.
func _two_bone(skeleton: Skeleton3D, upper: String, lower: String, end: String, goal: Vector3, pole: Vector3) -> void:
	var a_pose := _global(skeleton, _bones[upper])
	var b_pose := _global(skeleton, _bones[lower])
	var c_pose := _global(skeleton, _bones[end])
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
	var b_now := _global(skeleton, _bones[lower])
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
	var parent_basis := _global(skeleton, parent).basis if parent >= 0 else Basis()
	skeleton.set_bone_pose_rotation(i, (parent_basis.inverse() * basis).get_rotation_quaternion())
