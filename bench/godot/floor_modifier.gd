extends SkeletonModifier3D
## The floor: writes n fixed bone rotations every frame without solving anything, i.e. the
## engine's work for any script modifier that moves n bones (the scripted virtual call and
## n set_bone_pose_rotation calls, plus the skeleton update they trigger).

var bones := PackedInt32Array()
var rotations: Array[Quaternion] = []


func _process_modification_with_delta(_delta: float) -> void:
	var skel := get_skeleton()
	for i in bones.size():
		skel.set_bone_pose_rotation(bones[i], rotations[i])
