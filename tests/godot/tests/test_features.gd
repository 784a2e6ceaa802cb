# The node's goals and joint settings on skeletons like a character's: bones that do not point
# along +Y in the world and have rotated rests (a leg from a T-pose, hanging down), a hinge knee
# with limits, a pole, the target's rotation, an aim, extra goals, influence, joints saved in a scene.
# Every check measures the pose the skeleton shows (inside skeleton_updated), not what the node says.
# timeout: 120
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")

const SOLVERS := [IKChain.SOLVER_CCD, IKChain.SOLVER_JACOBIAN, IKChain.SOLVER_DLS, IKChain.SOLVER_BFGS,
		IKChain.SOLVER_FABRIK, IKChain.SOLVER_AUTO]
const KNEE_MIN := -2.6  # rad: the knee folds the shin backwards only
const THIGH := 0.45
const SHIN := 0.42


## A leg as an importer makes it from a T-pose: pelvis at the origin, the thigh's rest turned 180°
## about Z so the bone's +Y points down, the shin and foot along their parent's +Y. The character
## faces +Z, so a knee bends forward (+Z) and the foot goes back.
static func make_leg() -> Skeleton3D:
	var skel := Skeleton3D.new()
	skel.name = "Skeleton"
	skel.add_bone("pelvis")
	skel.set_bone_rest(0, Transform3D(Basis(), Vector3(0, 1.0, 0)))
	skel.add_bone("thigh")
	skel.set_bone_parent(1, 0)
	skel.set_bone_rest(1, Transform3D(Basis(Vector3(0, 0, 1), PI), Vector3(0.1, 0, 0)))
	skel.add_bone("shin")
	skel.set_bone_parent(2, 1)
	skel.set_bone_rest(2, Transform3D(Basis(), Vector3(0, THIGH, 0)))
	skel.add_bone("foot")
	skel.set_bone_parent(3, 2)
	skel.set_bone_rest(3, Transform3D(Basis(), Vector3(0, SHIN, 0)))
	skel.reset_bone_poses()
	return skel


static func knee_joint() -> IKChainJoint:
	var knee := IKChainJoint.new()
	knee.bone_name = "shin"
	knee.type = IKChainJoint.JOINT_HINGE
	knee.hinge_axis = Vector3(1, 0, 0)
	knee.hinge_limit_enabled = true
	knee.hinge_min = KNEE_MIN
	knee.hinge_max = 0.0
	return knee


func leg_rig(solver: int, target_position: Vector3) -> Dictionary:
	var skel := make_leg()
	var ik := IKChain.new()
	ik.name = "IKChain"
	ik.root_bone = "thigh"
	ik.tip_bone = "foot"
	ik.solver = solver
	ik.max_iterations = 500
	ik.target = NodePath("../../Target")
	ik.joints = [knee_joint()]
	ik.max_restarts = 0  # the default, spelled out: the knee case needs no restarts
	skel.add_child(ik)
	var target := Marker3D.new()
	target.name = "Target"
	target.position = target_position
	var rig := Node3D.new()
	rig.name = "Rig"
	rig.add_child(skel)
	rig.add_child(target)
	return {"container": rig, "skeleton": skel, "ik": ik, "target": target}


static func foot_world(skel: Skeleton3D) -> Vector3:
	return skel.global_transform * skel.get_bone_global_pose(3).origin


## How far the knee is in front of (+) or behind (-) the hip-ankle line, along +Z (m).
static func knee_forward(skel: Skeleton3D) -> float:
	var hip := skel.get_bone_global_pose(1).origin
	var knee := skel.get_bone_global_pose(2).origin
	var ankle := skel.get_bone_global_pose(3).origin
	var axis := (ankle - hip).normalized()
	var off := (knee - hip) - axis * (knee - hip).dot(axis)
	return off.z


## The knee hinge's angle about the shin's own +X, from its local pose (rest is identity).
static func knee_angle(skel: Skeleton3D) -> float:
	var q := skel.get_bone_pose_rotation(2)
	return 2.0 * atan2(q.x, q.w)


# A raised foot (in front, 0.6 m under the hip): every solver bends the knee forward and never
# past its limits, over a moving target for 60 frames, and reaches it (hinge knee and a pole in
# front, as a character is set up). The straight start puts the
# knee exactly on its limit (0), where the gradient along the knee is zero: a stationary point,
# which every solver leaves by the core's shared escape (solvers/stuck.hpp; the core test
# Stuck.StraightLegWithKneeOnItsLimitReachesWithoutRestarts), with max_restarts 0 (leg_rig), the
# node's default.
func test_knee_never_bends_backwards_any_solver() -> void:
	for solver in SOLVERS:
		var rig := leg_rig(solver, Vector3(0.1, 0.45, 0.25))
		var skel: Skeleton3D = rig["skeleton"]
		var ik: IKChain = rig["ik"]
		# The hinge decides how the knee bends; the pole decides which way the hip turns it (a ball
		# hip could otherwise twist the whole leg, a restart included, and face the knee backwards).
		var pole := Marker3D.new()
		pole.name = "Pole"
		pole.position = Vector3(0.1, 0.6, 2.0)
		rig["container"].add_child(pole)
		ik.pole_target = NodePath("../../Pole")
		var target: Marker3D = rig["target"]
		var samples := []
		skel.skeleton_updated.connect(func():
			samples.append([knee_forward(skel), knee_angle(skel), foot_world(skel).distance_to(target.global_position),
					skel.get_bone_global_pose(2).origin]))
		Rig.add_to(case_root, rig)
		for f in 60:
			target.position = Vector3(0.1, 0.45 + 0.15 * sin(f * 0.1), 0.25 + 0.1 * cos(f * 0.07))
			await process_frame
		var label: String = "solver %d" % solver
		check(samples.size() >= 30, label + ": skeleton_updated every frame (%d)" % samples.size())
		var worst_forward := INF
		var worst_angle_excess := 0.0
		var worst_error := 0.0
		var worst_jump := 0.0
		for i in samples.size():
			worst_forward = minf(worst_forward, samples[i][0])
			var a: float = samples[i][1]
			worst_angle_excess = maxf(worst_angle_excess, maxf(a - 0.0, KNEE_MIN - a))
			if i >= 2:
				worst_error = maxf(worst_error, samples[i][2])
				worst_jump = maxf(worst_jump, (samples[i][3] as Vector3).distance_to(samples[i - 1][3]))
		check(worst_forward >= -1e-4, label + ": knee in front of the hip-ankle line (worst %.4f m)" % worst_forward)
		check_le(worst_angle_excess, 1e-3, label + ": knee hinge within [%.2f, 0] rad" % KNEE_MIN)
		check_le(worst_error, 0.01, label + ": foot reaches the moving target (worst error, m)")
		check_le(worst_jump, 0.1, label + ": no knee jump between frames (m)")
		(rig["container"] as Node).free()


# Two Bone with a pole in front: the knee bends toward the pole, exactly on target.
func test_two_bone_pole_bends_the_knee_forward() -> void:
	var rig := leg_rig(IKChain.SOLVER_TWO_BONE, Vector3(0.1, 0.5, 0.2))
	var ik: IKChain = rig["ik"]
	ik.joints = []  # two free ball joints: the pole decides the bend
	var pole := Marker3D.new()
	pole.name = "Pole"
	pole.position = Vector3(0.1, 0.6, 2.0)
	rig["container"].add_child(pole)
	ik.pole_target = NodePath("../../Pole")
	var skel: Skeleton3D = rig["skeleton"]
	var cap := {}
	skel.skeleton_updated.connect(func(): cap["forward"] = knee_forward(skel); cap["tip"] = foot_world(skel))
	Rig.add_to(case_root, rig)
	await frames(2)
	if check(not cap.is_empty(), "skeleton_updated"):
		check(cap["forward"] > 0.05, "knee bends toward the pole (%.3f m forward)" % cap["forward"])
		check_le((cap["tip"] as Vector3).distance_to(Vector3(0.1, 0.5, 0.2)), 1e-3, "foot on target (m)")


# use_target_rotation: the tip bone takes the target's rotation, for the solvers that pursue it.
func test_tip_takes_target_rotation() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 77
	for solver in [IKChain.SOLVER_JACOBIAN, IKChain.SOLVER_DLS, IKChain.SOLVER_BFGS, IKChain.SOLVER_AUTO]:
		# A pose the arm can take: position and rotation of its tip bone there.
		var want: Transform3D = Arm.SKELETON_TRANSFORM * (Arm.fk_chain(3, Arm.random_rotations(rng, 3)).back() as Transform3D)
		var rig := Rig.make(3, solver, want.origin)
		var ik: IKChain = rig["ik"]
		ik.use_target_rotation = true
		ik.max_iterations = 200
		(rig["target"] as Marker3D).basis = want.basis
		var skel: Skeleton3D = rig["skeleton"]
		var cap := {}
		skel.skeleton_updated.connect(func():
			cap["tip"] = skel.global_transform * skel.get_bone_global_pose(skel.find_bone("tip"))
			cap["result"] = ik.get_last_result())
		Rig.add_to(case_root, rig)
		await frames(2)
		var label := "solver %d" % solver
		if check(not cap.is_empty(), label + ": skeleton_updated"):
			var got: Transform3D = cap["tip"]
			var angle := got.basis.get_rotation_quaternion().angle_to(want.basis.get_rotation_quaternion())
			check_le(angle, 2e-3, label + ": tip bone rotation to target rotation (rad)")
			check_le(got.origin.distance_to(want.origin), 1e-3, label + ": tip to target (m)")
			check_eq(cap["result"].get("reached"), true, label + ": result says reached")
		(rig["container"] as Node).free()


# goal_mode Aim: the tip bone's aim_axis points at the target (a turret, a look-at).
func test_aim_points_the_tip_axis_at_the_target() -> void:
	for solver in [IKChain.SOLVER_DLS, IKChain.SOLVER_BFGS, IKChain.SOLVER_AUTO]:
		var target_pos := Vector3(1.5, 1.2, -0.8)
		var rig := Rig.make(3, solver, target_pos)
		var ik: IKChain = rig["ik"]
		ik.goal_mode = IKChain.GOAL_MODE_AIM
		ik.aim_axis = Vector3(0, 1, 0)
		var skel: Skeleton3D = rig["skeleton"]
		var cap := {}
		skel.skeleton_updated.connect(func(): cap["tip"] = skel.global_transform * skel.get_bone_global_pose(skel.find_bone("tip")))
		Rig.add_to(case_root, rig)
		await frames(3)
		if check(not cap.is_empty(), "solver %d: skeleton_updated" % solver):
			var t: Transform3D = cap["tip"]
			var axis := (t.basis * Vector3(0, 1, 0)).normalized()
			var to_target := (target_pos - t.origin).normalized()
			check_le(axis.angle_to(to_target), 2e-3, "solver %d: tip +Y points at the target (rad)" % solver)
		(rig["container"] as Node).free()


# influence 0.5: the result's final_error is the error of the pose the skeleton shows.
func test_influence_result_is_the_written_pose() -> void:
	for influence in [0.0, 0.5, 1.0]:
		var goal := Arm.fk_tip_world(3, [Quaternion(Vector3(0, 0, 1), 0.8), Quaternion(Vector3(1, 0, 0), 0.6),
				Quaternion(Vector3(0, 0, 1), 0.5)])
		var rig := Rig.make(3, IKChain.SOLVER_DLS, goal)
		var ik: IKChain = rig["ik"]
		ik.influence = influence
		ik.deterministic = true
		var skel: Skeleton3D = rig["skeleton"]
		var cap := {}
		skel.skeleton_updated.connect(func(): cap["tip"] = Arm.tip_world(skel); cap["result"] = ik.get_last_result())
		Rig.add_to(case_root, rig)
		await frames(2)
		if check(not cap.is_empty(), "influence %.1f: skeleton_updated" % influence):
			var shown: float = (cap["tip"] as Vector3).distance_to(goal)
			check_near(cap["result"]["final_error"], shown, 1e-4, "influence %.1f: final_error = shown tip error" % influence)
			check_eq(cap["result"]["reached"], influence == 1.0, "influence %.1f: reached" % influence)
		(rig["container"] as Node).free()


# An extra position goal on an inner bone (an elbow) and the tip's goal, both met.
func test_extra_goal_on_inner_bone() -> void:
	var rotations := [Quaternion(Vector3(0, 0, 1), 0.7), Quaternion(Vector3(1, 0, 0), -0.5),
			Quaternion(Vector3(0, 0, 1), 0.9)]
	var chain := []  # world positions of base, j0, j1, j2, tip
	for t in Arm.fk_chain(3, rotations):
		chain.append(Arm.SKELETON_TRANSFORM * (t as Transform3D).origin)
	var rig := Rig.make(3, IKChain.SOLVER_DLS, chain[4])
	var ik: IKChain = rig["ik"]
	var elbow := Marker3D.new()
	elbow.name = "Elbow"
	elbow.position = chain[3]
	rig["container"].add_child(elbow)
	var g := IKChainGoal.new()
	g.bone_name = "j2"
	g.kind = IKChainGoal.KIND_POSITION
	g.target = NodePath("../../Elbow")
	ik.goals = [g]
	ik.max_iterations = 200
	var skel: Skeleton3D = rig["skeleton"]
	var cap := {}
	skel.skeleton_updated.connect(func():
		cap["j2"] = skel.global_transform * skel.get_bone_global_pose(skel.find_bone("j2")).origin
		cap["tip"] = Arm.tip_world(skel))
	Rig.add_to(case_root, rig)
	await frames(2)
	if check(not cap.is_empty(), "skeleton_updated"):
		check_le((cap["j2"] as Vector3).distance_to(chain[3]), 1e-3, "inner bone j2 on its goal (m)")
		check_le((cap["tip"] as Vector3).distance_to(chain[4]), 1e-3, "tip on its goal (m)")


# use_target_transform: a script drives the goal without a node.
func test_target_transform_from_code() -> void:
	var goal := Arm.fk_tip_world(3, [Quaternion(Vector3(0, 0, 1), 0.4), Quaternion(Vector3(1, 0, 0), 0.9),
			Quaternion(Vector3(0, 0, 1), 0.3)])
	var rig := Rig.make(3, IKChain.SOLVER_DLS, Vector3(9, 9, 9))
	var ik: IKChain = rig["ik"]
	ik.use_target_transform = true
	ik.target_transform = Transform3D(Basis(), goal)
	var skel: Skeleton3D = rig["skeleton"]
	var cap := {}
	skel.skeleton_updated.connect(func(): cap["tip"] = Arm.tip_world(skel))
	Rig.add_to(case_root, rig)
	await frames(2)
	if check(not cap.is_empty(), "skeleton_updated"):
		check_le((cap["tip"] as Vector3).distance_to(goal), 1e-3, "tip reaches target_transform (m)")


# extend_tip_bone: the tip bone is a joint and the effector sits along its axis.
func test_extend_tip_bone() -> void:
	var rotations := [Quaternion(Vector3(0, 0, 1), 0.5), Quaternion(Vector3(1, 0, 0), 0.7),
			Quaternion(Vector3(0, 0, 1), -0.4)]
	var rig := Rig.make(3, IKChain.SOLVER_DLS, Vector3.ZERO)
	var ik: IKChain = rig["ik"]
	var skel: Skeleton3D = rig["skeleton"]
	ik.root_bone = "j0"
	ik.tip_bone = "j2"
	ik.extend_tip_bone = true
	ik.tip_extension_axis = IKChain.AXIS_PLUS_Y
	ik.tip_extension_length = Arm.lengths(3)[2]
	var goal := Arm.fk_tip_world(3, rotations)
	(rig["target"] as Marker3D).position = goal
	var cap := {}
	skel.skeleton_updated.connect(func(): cap["tip"] = Arm.tip_world(skel))
	Rig.add_to(case_root, rig)
	await frames(2)
	check_eq(ik.get_chain_bones(), PackedInt32Array([skel.find_bone("j0"), skel.find_bone("j1"), skel.find_bone("j2")]),
			"get_chain_bones() with extend_tip_bone")
	if check(not cap.is_empty(), "skeleton_updated"):
		check_le((cap["tip"] as Vector3).distance_to(goal), 1e-3, "extended tip (the tip bone's origin here) on target (m)")


# Joint settings survive an editor-style save and load.
func test_joints_and_goals_survive_save_and_load() -> void:
	var rig := leg_rig(IKChain.SOLVER_DLS, Vector3(0.1, 0.5, 0.2))
	var ik: IKChain = rig["ik"]
	var g := IKChainGoal.new()
	g.bone_name = "shin"
	g.kind = IKChainGoal.KIND_AIM
	g.weight = 0.25
	g.aim_axis = Vector3(0, 0, 1)
	g.target = NodePath("../../Target")
	ik.goals = [g]
	Rig.add_to(case_root, rig)
	_own(rig["container"])
	var packed := PackedScene.new()
	check_eq(packed.pack(rig["container"]), OK, "pack")
	check_eq(ResourceSaver.save(packed, "user://ikchain_features.tscn"), OK, "save")
	var loaded: Node = (ResourceLoader.load("user://ikchain_features.tscn", "", ResourceLoader.CACHE_MODE_IGNORE) as PackedScene).instantiate()
	var ik2: IKChain = loaded.get_node("Skeleton/IKChain")
	check_eq(ik2.joints.size(), 1, "joints size")
	var j: IKChainJoint = ik2.joints[0]
	check_eq(j.bone_name, "shin", "joint bone_name")
	check_eq(j.type, IKChainJoint.JOINT_HINGE, "joint type")
	check_near(j.hinge_min, KNEE_MIN, 1e-6, "hinge_min")
	check_eq(j.hinge_limit_enabled, true, "hinge_limit_enabled")
	check_eq(ik2.goals.size(), 1, "goals size")
	var g2: IKChainGoal = ik2.goals[0]
	check_eq(g2.kind, IKChainGoal.KIND_AIM, "goal kind")
	check_near(g2.weight, 0.25, 1e-9, "goal weight")
	check_eq(g2.aim_axis, Vector3(0, 0, 1), "goal aim_axis")
	loaded.free()


func _own(node: Node) -> void:
	for c in node.get_children():
		c.owner = node
		_own_rec(c, node)


func _own_rec(node: Node, owner: Node) -> void:
	for c in node.get_children():
		c.owner = owner
		_own_rec(c, owner)


# Misconfigured joints and goals give a warning naming the fix and no error; the pose stays.
func test_joint_and_goal_misconfiguration_warnings() -> void:
	var rig := leg_rig(IKChain.SOLVER_DLS, Vector3(0.1, 0.5, 0.2))
	var ik: IKChain = rig["ik"]
	var stray := IKChainJoint.new()
	stray.bone_name = "pelvis"  # not a joint of thigh..foot
	var bad_limits := knee_joint()
	bad_limits.hinge_min = 0.5
	bad_limits.hinge_max = -0.5
	ik.joints = [stray, bad_limits]
	var g := IKChainGoal.new()
	g.bone_name = "shin"
	ik.set("goals", [g, 42])  # untyped on purpose: an element that is no IKChainGoal
	Rig.add_to(case_root, rig)
	await frames(3)
	var w := " | ".join(ik._get_configuration_warnings())
	check(w.contains("joints[0]") and w.contains("pelvis"), "warning names joints[0] and its bone: " + w)
	check(w.contains("hinge_min"), "warning names hinge_min > hinge_max: " + w)
	check(w.contains("goals[0]") and w.contains("target"), "warning names goals[0]'s missing target: " + w)
	check(w.contains("goals[1]") and w.contains("IKChainGoal"), "warning names goals[1] that is no IKChainGoal: " + w)
	check_eq(ik.get_last_result()["usable"], false, "not usable while misconfigured")


# An unchanged property re-assigned every frame does not rebuild (no allocation, no warning churn),
# and a renamed root bone is noticed.
func test_renamed_root_bone_is_noticed() -> void:
	var rig := Rig.make(3, IKChain.SOLVER_DLS, Arm.fk_tip_world(3, Arm.random_rotations(RandomNumberGenerator.new(), 3)))
	var ik: IKChain = rig["ik"]
	var skel: Skeleton3D = rig["skeleton"]
	Rig.add_to(case_root, rig)
	await frames(2)
	check_eq(ik.get_last_result()["usable"], true, "usable before the rename")
	skel.set_bone_name(skel.find_bone("j0"), "shoulder")
	await frames(2)
	check_eq(ik.get_last_result()["usable"], false, "not usable after root_bone was renamed away")
	check(" ".join(ik._get_configuration_warnings()).contains("root_bone"), "warning names root_bone")
	ik.root_bone = "shoulder"
	await frames(2)
	check_eq(ik.get_last_result()["usable"], true, "usable again with the new name")


## Issue 16 item 11: the goals of IKChainGoal as the class reference states them, one check per
## sentence. The arm's pose from Arm.fk_chain gives every bone's frame, so each goal below is met
## exactly by one pose; the rig's main target is that pose's tip.
const ITEM11_ROTATIONS := [Vector3(0, 0, 0.7), Vector3(-0.5, 0, 0), Vector3(0, 0, 0.9)]


func _item11_rig(goal: IKChainGoal, goal_world: Transform3D, tip_world: Vector3) -> Dictionary:
	var rig := Rig.make(3, IKChain.SOLVER_DLS, tip_world)
	var ik: IKChain = rig["ik"]
	ik.max_iterations = 300
	ik.deterministic = true
	var marker := Node3D.new()
	marker.name = "GoalTarget"
	marker.transform = goal_world
	rig["container"].add_child(marker)
	if goal != null:
		goal.target = NodePath("../../GoalTarget")
		ik.goals = [goal]
	return rig


func _item11_pose() -> Array:
	var rots := []
	for v in ITEM11_ROTATIONS:
		rots.append(Quaternion.from_euler(v))
	var frames_world := []  # base, j0, j1, j2, tip
	for t in Arm.fk_chain(3, rots):
		frames_world.append(Arm.SKELETON_TRANSFORM * (t as Transform3D))
	return frames_world


## Captures each bone's global frame (world) in the next skeleton updates.
func _item11_solve(rig: Dictionary) -> Dictionary:
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var cap := {}
	skel.skeleton_updated.connect(func():
		for name in ["j0", "j1", "j2", "tip"]:
			cap[name] = skel.global_transform * skel.get_bone_global_pose(skel.find_bone(name))
		cap["result"] = ik.get_last_result())
	Rig.add_to(case_root, rig)
	await frames(3)
	return cap


## "KIND_ORIENTATION: the bone takes the target's global rotation": bone_name's own frame turns
## (j1 here), not its parent's.
func test_orientation_goal_orients_its_own_bone() -> void:
	var pose := _item11_pose()
	var want: Transform3D = pose[2]  # j1
	var g := IKChainGoal.new()
	g.bone_name = "j1"
	g.kind = IKChainGoal.KIND_ORIENTATION
	var cap := await _item11_solve(_item11_rig(g, Transform3D(want.basis, Vector3(2, 2, 2)), (pose[4] as Transform3D).origin))
	if check(not cap.is_empty(), "skeleton_updated"):
		var got: Transform3D = cap["j1"]
		check_le(got.basis.get_rotation_quaternion().angle_to(want.basis.get_rotation_quaternion()), 2e-3,
				"j1 (bone_name) takes the target's rotation (rad)")
		check_le((cap["tip"] as Transform3D).origin.distance_to((pose[4] as Transform3D).origin), 1e-3, "the tip still on its target (m)")


## "KIND_AIM: aim_axis, in the frame of the bone named by bone_name, points at the target, from
## that bone's end (the next chain bone's origin)": j1's axis, seen from j2's origin.
func test_aim_goal_aims_its_own_bone() -> void:
	var pose := _item11_pose()
	var j1: Transform3D = pose[2]
	var j2: Transform3D = pose[3]
	var aim_axis := Vector3(1, 0, 0)
	var g := IKChainGoal.new()
	g.bone_name = "j1"
	g.kind = IKChainGoal.KIND_AIM
	g.aim_axis = aim_axis
	var aim_point := j2.origin + j1.basis * aim_axis * 3.0
	var cap := await _item11_solve(_item11_rig(g, Transform3D(Basis(), aim_point), (pose[4] as Transform3D).origin))
	if check(not cap.is_empty(), "skeleton_updated"):
		var got: Transform3D = cap["j1"]
		var axis := (got.basis * aim_axis).normalized()
		check_le(axis.angle_to(aim_point - (cap["j2"] as Transform3D).origin), 2e-3,
				"j1's own aim_axis points at the target from j1's end (rad)")
		check_le((cap["tip"] as Transform3D).origin.distance_to((pose[4] as Transform3D).origin), 1e-3, "the tip still on its target (m)")


## rotation_weight "is used by use_target_rotation and by orientation goals": at 0 an orientation
## goal has no effect (the pose equals the pose without it), at 1 it is met (above).
func test_rotation_weight_scales_orientation_goals() -> void:
	var pose := _item11_pose()
	var tip: Vector3 = (pose[4] as Transform3D).origin
	# A rotation for j1 the arm cannot take together with its tip on the target.
	var twisted := Transform3D(Basis(Vector3(1, 0, 0), 1.2), Vector3(2, 2, 2))
	var without := await _item11_solve(_item11_rig(null, twisted, tip))
	for weight in [0.0, 1.0]:
		var g := IKChainGoal.new()
		g.bone_name = "j1"
		g.kind = IKChainGoal.KIND_ORIENTATION
		var rig := _item11_rig(g, twisted, tip)
		rig["container"].name = "RigWeight%d" % int(weight)
		(rig["ik"] as IKChain).rotation_weight = weight
		var cap := await _item11_solve(rig)
		if not check(not cap.is_empty() and not without.is_empty(), "weight %.0f: skeleton_updated" % weight):
			continue
		var moved := 0.0
		for name in ["j0", "j1", "j2"]:
			moved = maxf(moved, (cap[name] as Transform3D).basis.get_rotation_quaternion().angle_to(
					(without[name] as Transform3D).basis.get_rotation_quaternion()))
		if weight == 0.0:
			check_le(moved, 1e-6, "rotation_weight 0: the orientation goal changes nothing (rad)")
		else:
			check(moved > 1e-2, "rotation_weight 1: the orientation goal moves the chain (%f rad)" % moved)


## "With KIND_ORIENTATION and KIND_AIM the bone must be a joint of the chain ... A goal on a bone
## it cannot move is a configuration warning, and the chain is not solved": an orientation goal on
## tip_bone (not a joint without extend_tip_bone) and a position goal on root_bone are refused.
func test_goal_on_a_bone_it_cannot_move_is_refused() -> void:
	var pose := _item11_pose()
	for c in [["tip", IKChainGoal.KIND_ORIENTATION], ["j0", IKChainGoal.KIND_POSITION]]:
		var g := IKChainGoal.new()
		g.bone_name = c[0]
		g.kind = c[1]
		var rig := _item11_rig(g, Transform3D(Basis(), Vector3(1, 1, 1)), (pose[4] as Transform3D).origin)
		rig["container"].name = "Rig_" + c[0]
		var ik: IKChain = rig["ik"]
		Rig.add_to(case_root, rig)
		await frames(2)
		var w := " | ".join(ik._get_configuration_warnings())
		check(w.contains("cannot move"), "goal kind %d on %s: a configuration warning, got: %s" % [c[1], c[0], w])
		check_eq(ik.is_last_usable(), false, "goal kind %d on %s: the chain is not solved" % [c[1], c[0]])


# Issue 16, item 14: a foot target within the leg's length (0.85 of 0.87 m) but 42° off the hip's
# rest direction, beyond what a 15° hip cone and a nearly straight knee allow, is
# out of reach because of the limits: the solve stops as stalled, not at max_iterations, and the
# result says the limits hold the pose (joints_at_limit: the hip on its cone).
func test_limits_holding_the_pose_are_reported() -> void:
	var rig := leg_rig(IKChain.SOLVER_DLS, Vector3(0.1 + 0.85 * sin(deg_to_rad(42.0)), 1.0 - 0.85 * cos(deg_to_rad(42.0)), 0.0))
	var ik: IKChain = rig["ik"]
	ik.max_iterations = 64
	var hip := IKChainJoint.new()
	hip.bone_name = "thigh"
	hip.cone_limit_enabled = true
	hip.cone_angle = deg_to_rad(15.0)
	ik.joints = [hip, knee_joint()]
	case_root.add_child(rig["container"])
	await frames(2)
	var r: Dictionary = ik.solve_now()
	check_eq(r.get("reason"), "stalled", "reason of a target the hip cone keeps out of reach")
	check(r.get("iterations") < 64, "stopped before max_iterations (%d)" % r.get("iterations"))
	check(r.get("joints_at_limit") >= 1, "the hip rests on its cone (%d)" % r.get("joints_at_limit"))
	check_eq(ik.get_last_joints_at_limit(), r.get("joints_at_limit"), "typed getter agrees")
	check(r.get("position_error") > 0.05, "held short of the target (%.3f)" % r.get("position_error"))
	(rig["target"] as Node3D).position = Vector3(0.1, 0.16, 0.0)  # 0.84 m straight down
	r = ik.solve_now()
	check_eq(r.get("reason"), "converged", "a target within the limits")
	check_eq(r.get("joints_at_limit"), 0, "no joint on a limit")


# Issue 16, item 15: soft reach. The foot target moves 2 mm a frame down through the leg's full
# length (0.87 m): without soft_reach the knee snaps its last degrees straight within a few frames;
# with soft_reach = 5 % of the leg it straightens gradually (at most 2° a frame, never re-bending),
# never quite locks, and get_last_result() reports the pull.
func test_soft_reach_straightens_the_knee_without_a_snap() -> void:
	for soft in [0.0, 0.0435]:
		var rig := leg_rig(IKChain.SOLVER_DLS, Vector3(0.1, 0.3, 0.05))
		var skel: Skeleton3D = rig["skeleton"]
		var ik: IKChain = rig["ik"]
		ik.soft_reach = soft
		var target: Marker3D = rig["target"]
		var knees := []
		skel.skeleton_updated.connect(func(): knees.append(knee_angle(skel)))
		Rig.add_to(case_root, rig)
		var pulls := []
		for f in 100:
			target.position = Vector3(0.1, 1.0 - 0.70 - 0.002 * f, 0.05)
			await process_frame
			pulls.append(ik.get_last_result().get("soft_pull"))
		var label := "soft_reach %.4f" % soft
		var largest_turn := 0.0
		var rebent := false
		for i in range(10, knees.size()):
			largest_turn = maxf(largest_turn, absf(knees[i] - knees[i - 1]))
			rebent = rebent or absf(knees[i]) > absf(knees[i - 1]) + 1e-4
		if soft > 0.0:
			check_le(largest_turn, deg_to_rad(2.0), label + ": largest knee turn in a frame (rad)")
			check(not rebent, label + ": the knee never bends back while the target moves away")
			check(absf(knees[knees.size() - 1]) > 1e-3, label + ": the knee never quite locks straight")
			check(pulls[pulls.size() - 1] > 0.01, label + ": soft_pull reported (%.4f)" % pulls[pulls.size() - 1])
		else:
			check(largest_turn >= deg_to_rad(4.0), label + ": the snap soft reach removes (%.1f°)" % rad_to_deg(largest_turn))
			check_eq(pulls[pulls.size() - 1], 0.0, label + ": no pull")
		(rig["container"] as Node).free()
