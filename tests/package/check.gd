extends SceneTree
## Run by tests/package/run inside a fresh project that holds only the unzipped release package:
## the extension's classes are registered, and one IKChain on a two-bone skeleton reaches a
## reachable target (tip checked by the skeleton's own global pose, not the solver's claim).
## Prints PACKAGE_CHECK_OK on success, PACKAGE_CHECK_FAIL: <why> otherwise.

const LINK := 0.5


var _done := false


# The scene tree takes nodes only once the main loop runs: check on the first frame.
func _process(_delta: float) -> bool:
	if _done:
		return true
	_done = true
	var why := _check()
	if why.is_empty():
		print("PACKAGE_CHECK_OK")
		quit(0)
	else:
		print("PACKAGE_CHECK_FAIL: " + why)
		quit(1)
	return true


func _check() -> String:
	for c in ["IKChain", "IKChainJoint", "IKChainGoal"]:
		if not ClassDB.class_exists(c):
			return "class %s is not registered (the library did not load)" % c
	var skel := Skeleton3D.new()
	for bone in ["upper", "lower", "hand"]:
		skel.add_bone(bone)
	skel.set_bone_parent(1, 0)
	skel.set_bone_parent(2, 1)
	for i in [1, 2]:
		skel.set_bone_rest(i, Transform3D(Basis(), Vector3(0, LINK, 0)))
	skel.reset_bone_poses()
	var target := Marker3D.new()
	target.position = Vector3(0.35, 0.55, 0.2)  # 0.68 from the root, within reach 2 * LINK
	root.add_child(skel)
	root.add_child(target)
	var ik: Node = ClassDB.instantiate("IKChain")
	ik.set("root_bone", "upper")
	ik.set("tip_bone", "hand")
	skel.add_child(ik)
	ik.set("target", ik.get_path_to(target))
	ik.call("solve_now")
	var r: Dictionary = ik.call("get_last_result")
	var tip := skel.global_transform * skel.get_bone_global_pose(2).origin
	var miss := tip.distance_to(target.global_position)
	skel.free()
	target.free()
	if not r.get("reached", false):
		return "the solve did not reach the target: %s" % r
	if miss > 1e-3:
		return "the hand is %.6f from the target (result says %s)" % [miss, r]
	print("solver %s, %d iterations, tip within %s of the target" % [r.get("solver"), r.get("iterations"), String.num_scientific(miss)])
	return ""
