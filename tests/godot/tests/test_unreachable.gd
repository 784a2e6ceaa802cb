# Out-of-reach targets: the chain must straighten toward the target.
#
# The target is placed 0.5 m beyond full reach, in a direction the rest pose does not point to.
# Asserted (first frame, read in skeleton_updated):
#   - |tip - target| == |target - root joint| - chain length, within 1e-3 m (the chain is straight
#     and points at the target: the only pose at that distance);
#   - reason is NOT "converged" (the target was not reached) and is one of the non-success reasons
#     "unreachable" / "max_iterations" / "stalled"; we do not require "unreachable" specifically;
#   - final_error equals the measured tip distance (± 1e-3 m); every bone pose is finite.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")

const BEYOND := 0.5
const DIRECTIONS := [Vector3(0.6, -0.2, 0.77), Vector3(-0.3, -0.9, 0.2)]


func test_two_joint_two_bone() -> void:
	await _unreachable(2, IKChain.SOLVER_TWO_BONE)


func test_two_joint_dls() -> void:
	await _unreachable(2, IKChain.SOLVER_DLS)


func test_three_joint_ccd() -> void:
	await _unreachable(3, IKChain.SOLVER_CCD)


func test_three_joint_jacobian() -> void:
	await _unreachable(3, IKChain.SOLVER_JACOBIAN)


func test_three_joint_dls() -> void:
	await _unreachable(3, IKChain.SOLVER_DLS)


func test_three_joint_bfgs() -> void:
	await _unreachable(3, IKChain.SOLVER_BFGS)


func test_three_joint_fabrik() -> void:
	await _unreachable(3, IKChain.SOLVER_FABRIK)


func _unreachable(n: int, solver: int) -> void:
	var root := Arm.root_joint_world()
	var reach := Arm.chain_length(n)
	for d in DIRECTIONS:
		var goal: Vector3 = root + (d as Vector3).normalized() * (reach + BEYOND)
		var label := "%d joints %s target %s" % [n, Rig.SOLVER_NAMES[solver], fmt_v(goal)]
		var rig := Rig.make(n, solver, goal)
		var skel: Skeleton3D = rig["skeleton"]
		var ik: IKChain = rig["ik"]
		var cap := {}
		skel.skeleton_updated.connect(func():
			if cap.is_empty():
				cap.merge(Rig.capture(skel, ik)))
		Rig.add_to(case_root, rig)
		await frames(2)
		if check(not cap.is_empty(), label + ": skeleton_updated was emitted"):
			var tip: Vector3 = cap["tip"]
			var dist := tip.distance_to(goal)
			check_near(dist, root.distance_to(goal) - reach, 1e-3,
					label + ": tip %s to target distance (m)" % fmt_v(tip))
			var r: Dictionary = cap["result"]
			var reason = r.get("reason")
			check(reason != "converged", label + ": reason must not be converged")
			check(reason in ["unreachable", "max_iterations", "stalled"],
					label + ": reason %s is a non-success reason" % var_to_str(reason))
			check_near(float(r.get("final_error", NAN)), dist, 1e-3, label + ": final_error matches the measured distance")
			var all_finite := true
			for t in cap["globals"]:
				all_finite = all_finite and transform_is_finite(t)
			check(all_finite, label + ": all bone global poses finite")
		(rig["container"] as Node).free()
