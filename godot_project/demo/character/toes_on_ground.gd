extends SkeletonModifier3D
## Runs after the body's IK: keeps each planted foot's toes flat on the surface it was planted on
## while the foot rolls onto them (heel-off, body_targets.gd), instead of turning them into the
## ground with the foot. Only the Toes bones' rotation changes; no effector is involved.

## The foot placement to read (body_targets.gd); its feet are [left, right].
var body: RefCounted = null

var _toes: Array[int] = []
var _rest_in_foot: Array[Basis] = []


func _ready() -> void:
	var skeleton := get_skeleton()
	if skeleton == null:
		return
	for side in ["Left", "Right"]:
		var toes := skeleton.find_bone(side + "Toes")
		_toes.append(toes)
		_rest_in_foot.append(skeleton.get_bone_rest(toes).basis if toes >= 0 else Basis())


func _process_modification_with_delta(_delta: float) -> void:
	var skeleton := get_skeleton()
	if skeleton == null or body == null or _toes.size() != 2:
		return
	var to_skeleton := skeleton.global_transform.basis.inverse()
	for i in 2:
		var foot: Object = body.feet[i]
		var toes := _toes[i]
		if toes < 0 or foot.swinging:
			continue
		# The toes as they would be on the unrolled, planted foot, in the skeleton's space.
		var planted: Transform3D = foot.planted
		var want := (to_skeleton * planted.basis) * _rest_in_foot[i]
		var foot_bone := skeleton.get_bone_parent(toes)
		var foot_basis := _global_basis(skeleton, foot_bone)
		skeleton.set_bone_pose_rotation(toes, (foot_basis.inverse() * want).get_rotation_quaternion())


## A bone's rotation in the skeleton's space from the local poses (composed down from the root, as the modifiers leave them).
func _global_basis(skeleton: Skeleton3D, bone: int) -> Basis:
	var basis := skeleton.get_bone_pose(bone).basis
	var parent := skeleton.get_bone_parent(bone)
	while parent >= 0:
		basis = skeleton.get_bone_pose(parent).basis * basis
		parent = skeleton.get_bone_parent(parent)
	return basis
