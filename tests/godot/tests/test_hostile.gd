# Hostile inputs at run time: nodes freed or moved while the chain solves, skeletons edited under
# it, degenerate skeletons, wrongly typed property values, non-finite targets. Each case: no crash
# (the runner fails the file on one), no leak, no NaN in any bone pose, the problem named where
# there is one, and a chain that works again once the problem is gone. A configuration problem (a
# missing target or skeleton, unknown bones, a degenerate chain) is a configuration warning and
# prints nothing, like Godot's own modifiers; a problem at run time (a zero-scale skeleton, a
# wrong-typed set()) prints one error (declared with expect_error, so a missing one fails).
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")


# ------------------------------------------------------------------ helpers

## The node's configuration warnings mention `regex` (case-insensitive).
func _check_warning(ik: IKChain, regex: String, what: String) -> void:
	var w := " | ".join(ik._get_configuration_warnings())
	check(RegEx.create_from_string("(?i)" + regex).search(w) != null,
			"%s: a configuration warning mentions /%s/, got: %s" % [what, regex, w])

func _rig(seed_value: int, solver := IKChain.SOLVER_DLS) -> Dictionary:
	var rng := RandomNumberGenerator.new()
	rng.seed = seed_value
	var rig := Rig.make(3, solver, Arm.fk_tip_world(3, Arm.random_rotations(rng, 3)))
	return rig


## Every bone's global pose finite.
func _check_finite(skel: Skeleton3D, what: String) -> void:
	for i in skel.get_bone_count():
		if not check(transform_is_finite(skel.get_bone_global_pose(i)),
				"%s: bone %s global pose is finite" % [what, skel.get_bone_name(i)]):
			return
	check(true, what)


## The tip (bone "tip") reaches `goal` (world) in the pose seen inside the next skeleton updates.
func _check_reaches(skel: Skeleton3D, ik: IKChain, goal: Vector3, what: String) -> void:
	var cap := {}
	var grab := func():
		cap["tip"] = Arm.tip_world(skel)
		cap["reason"] = ik.get_last_result().get("reason")
	skel.skeleton_updated.connect(grab)
	await frames(3)
	skel.skeleton_updated.disconnect(grab)
	if check(not cap.is_empty(), "%s: skeleton_updated ran" % what):
		check_le((cap["tip"] as Vector3).distance_to(goal), ik.tolerance + 2e-6, "%s: tip to target (m)" % what)
		check_eq(cap["reason"], "converged", "%s: reason" % what)


## A skeleton of `n` bones in a line along +Y (bone i named "b<i>", length `length`).
func _line_skeleton(n: int, length := 0.1) -> Skeleton3D:
	var skel := Skeleton3D.new()
	skel.name = "Skeleton"
	for i in n:
		var b := skel.add_bone("b%d" % i)
		skel.set_bone_parent(b, b - 1)
		skel.set_bone_rest(b, Transform3D(Basis(), Vector3(0, 0.0 if i == 0 else length, 0)))
	skel.reset_bone_poses()
	return skel


# ------------------------------------------------------------------ nodes freed or moved

func test_target_freed_while_solving() -> void:
	var rig := _rig(1)
	var skel: Skeleton3D = rig["skeleton"]
	Rig.add_to(case_root, rig)
	await frames(2)
	(rig["target"] as Node).free()
	await frames(4)
	_check_finite(skel, "after the target was freed")
	_check_warning(rig["ik"], "target", "target freed")
	check_eq(rig["ik"].get_last_result().get("usable"), false, "usable without a target")
	# A new node at the same path is picked up again.
	var again := Marker3D.new()
	again.name = "Target"
	var goal := Arm.fk_tip_world(3, Arm.random_rotations(RandomNumberGenerator.new(), 3))
	again.position = goal
	rig["container"].add_child(again)
	await _check_reaches(skel, rig["ik"], goal, "a new target at the same path")


func test_target_queue_freed_inside_skeleton_update() -> void:
	var rig := _rig(2)
	var skel: Skeleton3D = rig["skeleton"]
	var held := [rig["target"]]  # not captured directly: a lambda's captured object may not be freed
	skel.skeleton_updated.connect(func():
		if held[0] != null:
			(held[0] as Node).queue_free()
			held[0] = null)
	Rig.add_to(case_root, rig)
	await frames(5)
	_check_finite(skel, "after the target was queue_freed during an update")
	_check_warning(rig["ik"], "target", "target queue_freed")


func test_reparented_out_of_skeleton_and_back() -> void:
	var rig := _rig(3)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(2)
	var holder := Node3D.new()
	holder.name = "Holder"
	rig["container"].add_child(holder)
	ik.reparent(holder, false)
	await frames(3)
	_check_finite(skel, "IKChain outside its skeleton")
	_check_warning(ik, "skeleton3d", "IKChain outside its skeleton")
	ik.reparent(skel, false)
	await _check_reaches(skel, ik, goal, "IKChain back in its skeleton")


func test_moved_between_skeletons() -> void:
	var a := _rig(4)
	var b := _rig(5)
	a["container"].name = "RigA"
	b["container"].name = "RigB"
	Rig.add_to(case_root, a)
	Rig.add_to(case_root, b)
	b["ik"].free()  # B's skeleton gets A's chain instead
	await frames(2)
	var ik: IKChain = a["ik"]
	ik.reparent(b["skeleton"], false)  # target "../../Target" now resolves to B's target
	await _check_reaches(b["skeleton"], ik, (b["target"] as Node3D).position, "chain moved to another skeleton")
	_check_finite(a["skeleton"], "the skeleton it left")


func test_skeleton_freed_with_chain() -> void:
	var rig := _rig(6)
	Rig.add_to(case_root, rig)
	await frames(2)
	(rig["skeleton"] as Node).queue_free()
	await frames(3)
	check(not is_instance_valid(rig["ik"]), "the chain went with its skeleton")


# ------------------------------------------------------------------ the skeleton edited under it

func test_tip_bone_renamed_at_run_time() -> void:
	var rig := _rig(7)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(2)
	var tip := skel.find_bone("tip")
	skel.set_bone_name(tip, "renamed")
	await frames(3)
	_check_finite(skel, "tip bone renamed")
	_check_warning(ik, "tip_bone", "tip bone renamed")
	check_eq(ik.get_last_result().get("usable"), false, "usable with the tip bone gone")
	skel.set_bone_name(tip, "tip")
	await _check_reaches(skel, ik, goal, "tip bone named back")


func test_bones_added_at_run_time() -> void:
	var rig := _rig(8)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(2)
	var extra := skel.add_bone("extra")
	skel.set_bone_parent(extra, skel.find_bone("j1"))
	skel.set_bone_rest(extra, Transform3D(Basis(), Vector3(0.1, 0, 0)))
	skel.reset_bone_pose(extra)
	await _check_reaches(skel, ik, goal, "after a bone was added")


## Issue 16 item 1: set_bone_parent() reshapes the chain without changing the bone count. The
## chain must follow the new hierarchy (j0 -> j2 -> tip), not keep solving the old one and report
## converged with the tip off the target.
func test_bone_parent_changed_same_bone_count() -> void:
	var rig := _rig(12)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	Rig.add_to(case_root, rig)
	await frames(2)
	var j0 := skel.find_bone("j0")
	var j2 := skel.find_bone("j2")
	var count := skel.get_bone_count()
	skel.set_bone_parent(j2, j0)  # j1 leaves the chain; j2 (0.45) and tip (0.3) stay
	check_eq(skel.get_bone_count(), count, "bone count unchanged")
	# A point 0.6 from j0's origin (fixed by the solve): reachable by 0.45 + 0.3 ball joints.
	var j0_world := skel.global_transform * skel.get_bone_global_pose(j0).origin
	var goal := j0_world + Vector3(0.3, 0.4, -0.2).normalized() * 0.6
	(rig["target"] as Node3D).global_position = goal
	await _check_reaches(skel, ik, goal, "after set_bone_parent(j2, j0)")
	check_eq(Array(ik.get_chain_bones()), [j0, j2], "the chain follows the new hierarchy")


func test_bones_cleared_at_run_time() -> void:
	var rig := _rig(9)
	var skel: Skeleton3D = rig["skeleton"]
	Rig.add_to(case_root, rig)
	await frames(2)
	skel.clear_bones()
	await frames(3)
	check_eq(skel.get_bone_count(), 0, "bone count")
	_check_warning(rig["ik"], "root_bone|tip_bone", "bones cleared")
	check_eq(rig["ik"].get_last_result().get("usable"), false, "usable without bones")


func test_bones_changed_every_frame() -> void:
	var rig := _rig(10)
	var skel: Skeleton3D = rig["skeleton"]
	var rng := RandomNumberGenerator.new()
	rng.seed = 11
	Rig.add_to(case_root, rig)
	for f in 30:
		var rots := Arm.random_rotations(rng, 3, 0.0, 3.1)
		Arm.pose_joints(skel, rots)
		var j1 := skel.find_bone("j1")
		skel.set_bone_rest(j1, Transform3D(Basis(rots[0]), Vector3(0, rng.randf_range(0.0, 1.0), 0)))
		await process_frame
	_check_finite(skel, "after 30 frames of edits")
	var r: Dictionary = rig["ik"].get_last_result()
	check_eq(r.get("usable"), true, "usable")
	check(is_finite(float(r.get("final_error", NAN))), "final_error finite")


# ------------------------------------------------------------------ degenerate skeletons

func test_skeleton_with_zero_bones() -> void:
	var skel := _line_skeleton(0)
	var ik := IKChain.new()
	ik.root_bone = "b0"
	ik.tip_bone = "b1"
	skel.add_child(ik)
	case_root.add_child(skel)
	await frames(3)
	check_eq(ik.get_last_result().get("usable"), false, "usable")
	_check_warning(ik, "root_bone|tip_bone", "zero bones")


func test_skeleton_with_one_bone() -> void:
	var skel := _line_skeleton(1)
	var target := Marker3D.new()
	target.name = "Target"
	case_root.add_child(target)
	var ik := IKChain.new()
	ik.root_bone = "b0"
	ik.tip_bone = "b0"
	ik.target = NodePath("../../Target")
	skel.add_child(ik)
	case_root.add_child(skel)
	await frames(3)
	_check_finite(skel, "one bone")
	_check_warning(ik, "tip_bone|root_bone", "one bone")
	check_eq(ik.get_last_result().get("usable"), false, "usable")


func test_skeleton_with_200_bones() -> void:
	var skel := _line_skeleton(201, 0.05)  # 200 joints b0..b199, tip b200
	var target := Marker3D.new()
	target.name = "Target"
	var goal := Vector3(3.0, 6.0, 1.0)  # within the 10 m reach
	target.position = goal
	case_root.add_child(target)
	var ik := IKChain.new()
	ik.root_bone = "b0"
	ik.tip_bone = "b200"
	ik.target = NodePath("../../Target")
	skel.add_child(ik)
	var cap := {}
	skel.skeleton_updated.connect(func():
		cap["tip"] = skel.global_transform * skel.get_bone_global_pose(200).origin
		cap["reason"] = ik.get_last_result().get("reason"))
	case_root.add_child(skel)
	await frames(3)
	_check_finite(skel, "200 bones")
	if check(not cap.is_empty(), "skeleton_updated ran"):
		check_le((cap["tip"] as Vector3).distance_to(goal), ik.tolerance + 2e-6, "tip to target (m)")
		check_eq(cap["reason"], "converged", "reason")


## No NaN, the pose is left alone, and the error names the skeleton's scale, the real problem.
func test_zero_scale_skeleton() -> void:
	await _zero_scale("scale")


func _zero_scale(error_regex: String) -> void:
	var rig := _rig(12)
	var skel: Skeleton3D = rig["skeleton"]
	skel.scale = Vector3.ZERO
	expect_error(error_regex, 1)
	Rig.add_to(case_root, rig)
	await frames(3)
	for i in skel.get_bone_count():
		if not check(transform_is_finite(skel.get_bone_pose(i)), "bone %s local pose finite" % skel.get_bone_name(i)):
			break
	check(is_finite(float(rig["ik"].get_last_result().get("final_error", NAN))), "final_error finite")


func test_zero_length_bones() -> void:
	var skel := _line_skeleton(4, 0.0)
	var target := Marker3D.new()
	target.name = "Target"
	target.position = Vector3(0, 1, 0)
	case_root.add_child(target)
	var ik := IKChain.new()
	ik.root_bone = "b0"
	ik.tip_bone = "b3"
	ik.target = NodePath("../../Target")
	skel.add_child(ik)
	case_root.add_child(skel)
	await frames(3)
	_check_finite(skel, "zero-length bones")
	_check_warning(ik, "length|zero", "zero-length bones")
	check_eq(ik.get_last_result().get("usable"), false, "usable")


# ------------------------------------------------------------------ property values of the wrong kind

func test_max_iterations_set_to_a_string() -> void:
	var rig := _rig(13)
	var ik: IKChain = rig["ik"]
	Rig.add_to(case_root, rig)
	await frames(1)
	var before: int = ik.max_iterations
	expect_error("set_max_iterations: argument 'iterations' must be int, got String", 1)
	ik.set("max_iterations", "abc")
	await frames(2)
	check_eq(ik.max_iterations, before, "max_iterations unchanged")
	_check_finite(rig["skeleton"], "after set(max_iterations, \"abc\")")


func test_solver_set_to_99() -> void:
	var rig := _rig(14)
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(1)
	expect_error("solver", 1)
	ik.set("solver", 99)
	check(ik.solver >= IKChain.SOLVER_TWO_BONE and ik.solver <= IKChain.SOLVER_AUTO,
			"solver within the enum, got %d" % ik.solver)
	if ik.solver != IKChain.SOLVER_TWO_BONE:
		ik.max_iterations = 1000  # CCD / FABRIK near full extension need hundreds
		await _check_reaches(rig["skeleton"], ik, goal, "after set(solver, 99)")


func test_tolerance_set_to_nan_and_string() -> void:
	var rig := _rig(15)
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(1)
	var before: float = ik.tolerance
	expect_error("tolerance", -1)
	ik.set("tolerance", NAN)
	ik.set("tolerance", "abc")
	check(is_finite(ik.tolerance) and ik.tolerance > 0.0, "tolerance finite and > 0, got %s" % str(ik.tolerance))
	check_eq(ik.tolerance, before, "tolerance unchanged")
	await _check_reaches(rig["skeleton"], ik, goal, "after bad tolerances")


func test_two_chains_on_the_same_bones() -> void:
	var rig := _rig(16)
	var skel: Skeleton3D = rig["skeleton"]
	var second := IKChain.new()
	second.name = "IKChain2"
	second.root_bone = "j0"
	second.tip_bone = "tip"
	second.target = NodePath("../../Target2")
	second.solver = IKChain.SOLVER_CCD
	skel.add_child(second)
	var t2 := Marker3D.new()
	t2.name = "Target2"
	t2.position = Arm.root_joint_world() + Vector3(0.5, 0.5, 0.0)
	rig["container"].add_child(t2)
	var cap := {}
	skel.skeleton_updated.connect(func(): cap["tip"] = Arm.tip_world(skel))
	Rig.add_to(case_root, rig)
	await frames(4)
	_check_finite(skel, "two chains")
	# Modifiers run in child order: the second one has the last word.
	if check(not cap.is_empty(), "skeleton_updated ran"):
		check_le((cap["tip"] as Vector3).distance_to(t2.position), 1e-3, "the last chain's target is reached (m)")
	check_eq(rig["ik"].get_last_result().get("usable"), true, "first chain usable")
	check_eq(second.get_last_result().get("usable"), true, "second chain usable")


# ------------------------------------------------------------------ non-finite and huge targets

func _non_finite_target(position: Vector3) -> void:
	var rig := _rig(17)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	Rig.add_to(case_root, rig)
	await frames(2)
	var locals := []
	for i in skel.get_bone_count():
		locals.append(skel.get_bone_pose(i))
	expect_error("target", 1)
	(rig["target"] as Node3D).position = position
	await frames(3)
	_check_finite(skel, "non-finite target")
	for i in skel.get_bone_count():
		check(transforms_near(skel.get_bone_pose(i), locals[i], 1e-6),
				"bone %s left as it was" % skel.get_bone_name(i))
	check_eq(ik.get_last_result().get("usable"), false, "usable")
	(rig["target"] as Node3D).position = goal
	await _check_reaches(skel, ik, goal, "target finite again")


func test_nan_target() -> void:
	await _non_finite_target(Vector3(NAN, 0.5, 0.0))


func test_inf_target() -> void:
	await _non_finite_target(Vector3(0.0, INF, 0.0))


func test_huge_target() -> void:
	var rig := _rig(18)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var far := Vector3(1e30, 1e30, 0.0)
	(rig["target"] as Node3D).position = far
	var cap := {}
	skel.skeleton_updated.connect(func():
		cap["tip"] = Arm.tip_world(skel)
		cap["result"] = ik.get_last_result())
	Rig.add_to(case_root, rig)
	await frames(3)
	_check_finite(skel, "1e30 target")
	if check(not cap.is_empty(), "skeleton_updated ran"):
		var r: Dictionary = cap["result"]
		check_eq(r.get("usable"), true, "usable")
		check(r.get("reason") != "converged", "not converged on a 1e30 target, got %s" % r.get("reason"))
		# The best reach: the chain points at the target, fully extended.
		var root := Arm.root_joint_world()
		var dir := (cap["tip"] as Vector3 - root).normalized()
		check_le(dir.angle_to(far.normalized()), 1e-3, "chain points at the target (rad)")
		check_near((cap["tip"] as Vector3 - root).length(), Arm.chain_length(3), 1e-3, "fully extended (m)")


# ------------------------------------------------------------------ bad inputs that do not stop the frame
# (issue 16 item 10): each one message per spell naming the property and the fix, and a defined
# result: the solve goes on without the part the input spoils.

## A pole at NaN, inf or 1e30: ignored (the target is still reached), one error per spell.
func test_pole_target_not_finite_or_far() -> void:
	var rig := _rig(20)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	var pole := Marker3D.new()
	pole.name = "Pole"
	pole.position = Vector3(2.0, 1.0, -1.0)
	rig["container"].add_child(pole)
	ik.pole_target = NodePath("../../Pole")
	Rig.add_to(case_root, rig)
	await frames(2)
	# One error per bad spell: three spells, three errors (awk ERE: no apostrophe escapes needed).
	expect_error("pole_target.s global position is not finite or absurdly far.*Move pole_target", 3)
	for bad in [Vector3(NAN, 0.0, 0.0), Vector3(0.0, INF, 0.0), Vector3(1e30, 1e30, 0.0)]:
		pole.position = bad
		await _check_reaches(skel, ik, goal, "pole at %s: the target still reached" % bad)
		_check_finite(skel, "pole at %s" % bad)
		pole.position = Vector3(2.0, 1.0, -1.0)  # the spell ends: the next bad pole is reported again
		await frames(2)


## use_target_rotation with a zero target basis: the rotation is skipped (not taken as identity),
## the position still reached, one error per spell.
func test_target_zero_basis_skips_rotation() -> void:
	var rig := _rig(21)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	ik.use_target_transform = true
	ik.use_target_rotation = true
	ik.target_transform = Transform3D(Basis(Vector3.ZERO, Vector3.ZERO, Vector3.ZERO), goal)
	# Two spells: the second starts after frames that did not ask for the rotation.
	expect_error("target.s basis is degenerate.*use_target_rotation", 2)
	Rig.add_to(case_root, rig)
	await _check_reaches(skel, ik, goal, "zero target basis: the position")
	await frames(3)
	_check_finite(skel, "zero target basis")
	check_eq(ik.get_last_orientation_error(), 0.0, "no orientation goal was pursued")
	ik.use_target_rotation = false
	await frames(2)
	ik.use_target_rotation = true
	await frames(2)


## An orientation goal whose target has a zero basis: that goal is skipped, one error per spell.
func test_orientation_goal_zero_basis_is_skipped() -> void:
	var rig := _rig(22)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var goal: Vector3 = (rig["target"] as Node3D).position
	var flat := Node3D.new()
	flat.name = "Flat"
	flat.transform = Transform3D(Basis(Vector3.ZERO, Vector3.ZERO, Vector3.ZERO), Vector3(0.5, 1.0, -1.5))
	rig["container"].add_child(flat)
	var g := IKChainGoal.new()
	g.bone_name = "j1"
	g.kind = IKChainGoal.KIND_ORIENTATION
	g.target = NodePath("../../Flat")
	ik.goals = [g]
	expect_error("orientation goal.*degenerate basis", 1)
	Rig.add_to(case_root, rig)
	await _check_reaches(skel, ik, goal, "the main goal with a skipped orientation goal")
	await frames(3)
	_check_finite(skel, "orientation goal with a zero basis")
