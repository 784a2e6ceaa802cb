# Reachable targets: a 2-joint and a 3-joint chain must put the tip on the target in ONE frame,
# for every solver (TWO_BONE only on the 2-joint chain), with default settings
# (max_iterations 64, tolerance 1e-4 m).
#
# Each target is the forward kinematics (lib/arm.gd, checked against Skeleton3D in
# test_fixtures) of random ball-joint rotations, so it is reachable and the chain must bend. Every
# target gets a fresh scene; the pose is read at the first skeleton_updated after the scene enters
# the tree (Skeleton3D's modifier pass of that frame). Measured: world distance tip → target.
# Asserted per target:
#   - skeleton_updated came in the first frame; the tip is within tolerance + 2e-6 m (the slack is
#     float32 rounding of Godot's transforms, 2% of the tolerance; the solver computes in double);
#   - get_last_result(): reason "converged", usable, final_error <= tolerance, 0 <= iterations <=
#     max_iterations, initial_error == the rest pose's tip distance (± 1e-3 m);
#   - every bone's global pose is finite; bone lengths are kept (only rotations change); bones
#     outside the chain (base, side) and the tip bone's own local pose are untouched.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")

## Float32 slack on top of the tolerance for distances measured from Godot's transforms.
const FLOAT_SLACK := 2e-6
const TARGETS_PER_CASE := 4


func test_two_joint_two_bone() -> void:
	await _reach(2, IKChain.SOLVER_TWO_BONE, 101)


# CCD converges linearly, slowly near full extension (see docs/how-it-works.md): it gets a larger
# per-frame budget here; every other solver uses the default 64.
const CCD_ITERATIONS := 1000


func test_two_joint_ccd() -> void:
	await _reach(2, IKChain.SOLVER_CCD, 102, CCD_ITERATIONS)


func test_two_joint_jacobian() -> void:
	await _reach(2, IKChain.SOLVER_JACOBIAN, 103)


func test_two_joint_dls() -> void:
	await _reach(2, IKChain.SOLVER_DLS, 104)


func test_two_joint_bfgs() -> void:
	await _reach(2, IKChain.SOLVER_BFGS, 105)


func test_two_joint_fabrik() -> void:
	await _reach(2, IKChain.SOLVER_FABRIK, 106)


func test_three_joint_ccd() -> void:
	await _reach(3, IKChain.SOLVER_CCD, 201, CCD_ITERATIONS)


func test_three_joint_jacobian() -> void:
	await _reach(3, IKChain.SOLVER_JACOBIAN, 202)


func test_three_joint_dls() -> void:
	await _reach(3, IKChain.SOLVER_DLS, 203)


func test_three_joint_bfgs() -> void:
	await _reach(3, IKChain.SOLVER_BFGS, 204)


func test_three_joint_fabrik() -> void:
	await _reach(3, IKChain.SOLVER_FABRIK, 205)


func _reach(n: int, solver: int, seed_value: int, max_iterations := 0) -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = seed_value
	var rest_rotations := []
	for i in n:
		rest_rotations.append(Quaternion.IDENTITY)
	var rest_tip := Arm.fk_tip_world(n, rest_rotations)
	for k in TARGETS_PER_CASE:
		var goal := Arm.fk_tip_world(n, Arm.random_rotations(rng, n))
		var label := "%d joints %s target #%d %s" % [n, Rig.SOLVER_NAMES[solver], k, fmt_v(goal)]
		var rig := Rig.make(n, solver, goal)
		var skel: Skeleton3D = rig["skeleton"]
		var ik: IKChain = rig["ik"]
		if max_iterations > 0:
			ik.max_iterations = max_iterations
		var locals_before := []
		for i in skel.get_bone_count():
			locals_before.append(skel.get_bone_pose(i))
		var cap := {}
		skel.skeleton_updated.connect(func():
			if cap.is_empty():
				cap.merge(Rig.capture(skel, ik)))
		Rig.add_to(case_root, rig)
		var waited := 0
		while cap.is_empty() and waited < 3:
			await process_frame
			waited += 1
		if check(not cap.is_empty(), label + ": skeleton_updated within 3 frames"):
			check(waited <= 1, label + ": solved in the first frame (waited %d)" % waited)
			_check_solution(label, n, skel, ik, cap, goal, locals_before, rest_tip)
		(rig["container"] as Node).free()


func _check_solution(label: String, n: int, skel: Skeleton3D, ik: IKChain, cap: Dictionary,
		goal: Vector3, locals_before: Array, rest_tip: Vector3) -> void:
	var tol := ik.tolerance
	var err := (cap["tip"] as Vector3).distance_to(goal)
	check_le(err, tol + FLOAT_SLACK, label + ": tip %s to target distance (m)" % fmt_v(cap["tip"]))
	var r: Dictionary = cap["result"]
	check_eq(r.get("reason"), "converged", label + ": reason")
	check_eq(r.get("usable"), true, label + ": usable")
	check_le(float(r.get("final_error", INF)), tol, label + ": final_error")
	var iters := int(r.get("iterations", -1))
	check(iters >= 0 and iters <= ik.max_iterations, label + ": iterations %d in [0, max_iterations]" % iters)
	check_near(float(r.get("initial_error", NAN)), rest_tip.distance_to(goal), 1e-3, label + ": initial_error")
	var globals: Array = cap["globals"]
	var all_finite := true
	for t in globals:
		all_finite = all_finite and transform_is_finite(t)
	check(all_finite, label + ": all bone global poses finite")
	var ls := Arm.lengths(n)
	var chain := ["j0"]
	for i in range(1, n):
		chain.append("j%d" % i)
	chain.append("tip")
	for i in n:
		var a: Transform3D = globals[skel.find_bone(chain[i])]
		var b: Transform3D = globals[skel.find_bone(chain[i + 1])]
		check_near(a.origin.distance_to(b.origin), ls[i], 1e-5, label + ": length %s→%s kept" % [chain[i], chain[i + 1]])
	for bone in ["base", "side", "tip"]:
		var i := skel.find_bone(bone)
		check(transforms_near(cap["locals"][i], locals_before[i], 1e-6), label + ": bone %s's local pose untouched" % bone)


# Once solved, the chain must keep up with a target that moves every frame (warm start).
func test_three_joint_tracks_moving_target_all_solvers() -> void:
	for solver in [IKChain.SOLVER_CCD, IKChain.SOLVER_JACOBIAN, IKChain.SOLVER_DLS,
			IKChain.SOLVER_BFGS, IKChain.SOLVER_FABRIK]:
		var label := "3 joints %s moving" % Rig.SOLVER_NAMES[solver]
		var rng := RandomNumberGenerator.new()
		rng.seed = 300 + solver
		var rotations := Arm.random_rotations(rng, 3, 0.4, 0.8)
		var rig := Rig.make(3, solver, Arm.fk_tip_world(3, rotations))
		var skel: Skeleton3D = rig["skeleton"]
		var ik: IKChain = rig["ik"]
		var target: Marker3D = rig["target"]
		var errors := []
		skel.skeleton_updated.connect(func():
			errors.append([Arm.tip_world(skel).distance_to(target.global_position), ik.get_last_result().get("reason")]))
		Rig.add_to(case_root, rig)
		for f in 12:
			await process_frame
			# a reachable path: rotate the joints a little further each frame and follow their FK
			for i in rotations.size():
				rotations[i] = rotations[i] * Quaternion(Vector3(0.3, 0.2, 1).normalized(), 0.05)
			target.global_position = Arm.fk_tip_world(3, rotations)
		await process_frame
		check(errors.size() >= 10, label + ": skeleton_updated every frame (%d)" % errors.size())
		var worst := 0.0
		var reasons := {}
		for e in errors:
			worst = maxf(worst, e[0])
			reasons[e[1]] = true
		check_le(worst, ik.tolerance + FLOAT_SLACK, label + ": worst per-frame error (m)")
		check_eq(reasons.keys(), ["converged"], label + ": reasons seen")
		(rig["container"] as Node).free()


# A target that enters the tree after the chain. Godot 4.6's Skeleton3D runs a first modifier pass
# synchronously inside add_child (checked: modification_processed fires before add_child returns),
# so at that moment the target really is missing: a configuration warning, no error. The chain must then
# pick the target up on the next frame (resolved per solve, not cached) with no further errors.
func test_target_added_after_chain() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 606
	var goal := Arm.fk_tip_world(3, Arm.random_rotations(rng, 3))
	var rig := Rig.make(3, IKChain.SOLVER_DLS, goal)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var container: Node3D = rig["container"]
	var target: Node3D = rig["target"]
	container.remove_child(target)
	var cap := {}
	skel.skeleton_updated.connect(func(): cap.merge(Rig.capture(skel, ik), true))
	Rig.add_to(case_root, rig)
	container.add_child(target)
	await frames(3)
	if check(not cap.is_empty(), "skeleton_updated"):
		check_le((cap["tip"] as Vector3).distance_to(goal), ik.tolerance + FLOAT_SLACK, "tip to target (m), 3 frames later")
		check_eq(cap["result"].get("reason"), "converged", "reason, 3 frames later")
