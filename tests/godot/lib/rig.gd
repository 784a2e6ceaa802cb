extends RefCounted
## IKChain set-ups on the test arms of lib/arm.gd. The scene is
##   case_root ─ Rig ─ Skeleton (arm) ─ IKChain    root_bone "j0", tip_bone "tip", target "../../Target"
##                   └ Target (Marker3D)
## Nothing is in the tree yet: add_to() adds the whole Rig at once, as instancing a scene would
## (the Target comes after the Skeleton, as in a typical scene where a character precedes its
## targets). Extra nodes a test needs go under `container` before that.

const Arm := preload("res://lib/arm.gd")


static func make(n_joints: int, solver: int, target_world: Vector3, rotations := []) -> Dictionary:
	var skel := Arm.make_skeleton(n_joints)
	if not rotations.is_empty():
		Arm.pose_joints(skel, rotations)
	var target := Marker3D.new()
	target.name = "Target"
	target.position = target_world
	var ik := IKChain.new()
	ik.name = "IKChain"
	ik.root_bone = "j0"
	ik.tip_bone = "tip"
	ik.target = NodePath("../../Target")
	ik.solver = solver
	skel.add_child(ik)
	var container := Node3D.new()
	container.name = "Rig"
	container.add_child(skel)
	container.add_child(target)
	return {"container": container, "skeleton": skel, "ik": ik, "target": target}


static func add_to(case_root: Node, rig: Dictionary) -> void:
	case_root.add_child(rig["container"])


## A snapshot of what the skeleton shows right now; call it inside skeleton_updated (or the
## modifier's modification_processed), where the modified pose is visible.
static func capture(skel: Skeleton3D, ik: IKChain) -> Dictionary:
	var globals := []
	var locals := []
	for i in skel.get_bone_count():
		globals.append(skel.get_bone_global_pose(i))
		locals.append(skel.get_bone_pose(i))
	return {"tip": Arm.tip_world(skel), "globals": globals, "locals": locals,
			"result": ik.get_last_result()}


const SOLVER_NAMES := {0: "TWO_BONE", 1: "CCD", 2: "JACOBIAN", 3: "DLS", 4: "BFGS", 5: "FABRIK"}
