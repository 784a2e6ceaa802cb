# The Godot layer's contracts with scenes and with the other nodes of a scene: solver values saved
# in a scene keep their meaning, an edited resource rebuilds only the node that holds it, and the
# configuration warnings and the rebuild come from one configuration pass (they agree).
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")

# What each saved value means, for ever (a scene saved today must load with the same solver).
const SAVED_SOLVERS := {
	0: ["SOLVER_TWO_BONE", "Two Bone"],
	1: ["SOLVER_CCD", "Cyclic Coordinate Descent"],
	2: ["SOLVER_JACOBIAN", "Jacobian Pseudo-Inverse"],
	3: ["SOLVER_DLS", "Damped Least Squares"],
	4: ["SOLVER_BFGS", "BFGS"],
	5: ["SOLVER_FABRIK", "FABRIK"],
	6: ["SOLVER_AUTO", "Damped Least Squares"],  # Auto on a 3-joint chain
}


func test_solver_values_saved_in_a_scene_keep_their_meaning() -> void:
	# A scene as the editor saves it: the enum as its integer value.
	var tscn := "[gd_scene format=3]\n\n[node name=\"Root\" type=\"Node3D\"]\n\n"
	for value in SAVED_SOLVERS:
		tscn += "[node name=\"IK%d\" type=\"IKChain\" parent=\".\"]\nsolver = %d\n\n" % [value, value]
	tscn += "[node name=\"Body\" type=\"IKBody\" parent=\".\"]\nsolver = 3\n"
	var path := "user://ikchain_layer_solvers.tscn"
	var f := FileAccess.open(path, FileAccess.WRITE)
	f.store_string(tscn)
	f.close()
	var loaded: Node = (ResourceLoader.load(path, "", ResourceLoader.CACHE_MODE_IGNORE) as PackedScene).instantiate()
	for value in SAVED_SOLVERS:
		var constant: String = SAVED_SOLVERS[value][0]
		check_eq(ClassDB.class_get_integer_constant("IKChain", constant), value, "IKChain.%s" % constant)
		check_eq(ClassDB.class_get_integer_constant("IKBody", constant), value, "IKBody.%s" % constant)
		var ik: IKChain = loaded.get_node("IK%d" % value)
		check_eq(ik.solver, value, "saved solver %d loads as %d" % [value, value])
		# And it runs the solver the value always meant (Two Bone needs exactly two joints).
		var n := 2 if value == 0 else 3
		var rng := RandomNumberGenerator.new()
		rng.seed = 77 + value
		var rig := Rig.make(n, value, Arm.fk_tip_world(n, Arm.random_rotations(rng, n)))
		var skel: Skeleton3D = rig["skeleton"]
		skel.remove_child(rig["ik"])
		(rig["ik"] as Node).free()
		loaded.remove_child(ik)
		ik.name = "IKChain"
		ik.root_bone = "j0"
		ik.tip_bone = "tip"
		ik.target = NodePath("../../Target")
		skel.add_child(ik)
		Rig.add_to(case_root, rig)
		var r: Dictionary = ik.solve_now()
		check_eq(r["solver"], SAVED_SOLVERS[value][1], "saved solver %d solves with" % value)
	check_eq((loaded.get_node("Body") as IKBody).solver, IKBody.SOLVER_DLS, "IKBody's saved solver 3")
	loaded.free()


# Two IKChains in one scene, each with its own IKChainJoint. Editing one joint rebuilds the chain
# that holds it and no other: a rebuilt chain starts its next solve from the animated pose (a
# large initial error), an untouched one continues from its last solution (initial error within
# tolerance).
func test_editing_a_joint_rebuilds_only_the_chain_that_holds_it() -> void:
	var a := _rig_with_joint(11, Vector3(0, 0, 0))
	var b := _rig_with_joint(12, Vector3(3, 0, 0))
	await frames(4)
	var ik_a: IKChain = a["ik"]
	var ik_b: IKChain = b["ik"]
	check(ik_a.is_last_reached() and ik_b.is_last_reached(), "both chains reached their targets")
	check_le(ik_b.get_last_initial_error(), 1e-3, "B: a warm frame before the edit (initial error)")
	(a["joint"] as IKChainJoint).twist_limit_enabled = false  # any setter: the joint emits `changed`
	await frames(1)
	check(ik_a.get_last_initial_error() > 1e-2,
			"A (its joint edited) was rebuilt: initial error %f from the animated pose" % ik_a.get_last_initial_error())
	check_le(ik_b.get_last_initial_error(), 1e-3, "B (untouched) was not rebuilt: initial error")
	await frames(1)
	check_le(ik_a.get_last_initial_error(), 1e-3, "A is warm again the frame after its rebuild")


# A joint no longer in the array no longer rebuilds the chain; a joint appended in place (no
# setter runs) still takes effect.
func test_replaced_and_appended_joints() -> void:
	var a := _rig_with_joint(13, Vector3(0, 0, 0))
	var ik: IKChain = a["ik"]
	var old_joint: IKChainJoint = a["joint"]
	await frames(3)
	ik.joints = []
	await frames(2)
	old_joint.twist_limit_enabled = false
	await frames(1)
	check_le(ik.get_last_initial_error(), 1e-3, "a joint the chain dropped does not rebuild it")
	var hinge := IKChainJoint.new()
	hinge.bone_name = "j1"
	hinge.type = IKChainJoint.JOINT_HINGE
	hinge.hinge_axis = Vector3(1, 0, 0)
	hinge.hinge_limit_enabled = true
	hinge.hinge_min = -0.01
	hinge.hinge_max = 0.01
	ik.joints.append(hinge)  # in place: no setter of the IKChain runs
	await frames(1)
	check(ik.get_last_initial_error() > 1e-2, "the appended joint rebuilt the chain (initial error %f)" % ik.get_last_initial_error())
	# The modified pose is visible only while the skeleton updates.
	var seen := [0.0]
	var grab := func() -> void: seen[0] = skel_angle(a["skeleton"], "j1", Vector3(1, 0, 0))
	ik.modification_processed.connect(grab)
	await frames(2)
	ik.modification_processed.disconnect(grab)
	var angle: float = seen[0]
	check_le(absf(angle), 0.0105, "the appended hinge's limit holds (j1 turned %f rad about +X)" % angle)
	check_le(ik.get_last_initial_error(), 1e-2, "warm again")
	hinge.hinge_max = 0.02  # the appended joint is listened to as well
	await frames(1)
	check(ik.get_last_initial_error() > 1e-2,
			"editing the appended joint rebuilds the chain (initial error %f)" % ik.get_last_initial_error())


# An IKBody listens to its own joints and effectors only: editing an IKChain's joint does not
# rebuild it, and an effector's weight (read every frame) does not either.
func test_body_ignores_other_nodes_resources() -> void:
	var a := _rig_with_joint(14, Vector3(0, 0, 0))
	var body_rig := _small_body()
	await frames(4)
	var body: IKBody = body_rig["body"]
	var warm := body.get_last_iterations()
	(a["joint"] as IKChainJoint).twist_limit_enabled = false
	(body_rig["effector"] as IKBodyEffector).position_weight = 1.0
	await frames(1)
	var after_edits := body.get_last_iterations()
	(body_rig["effector"] as IKBodyEffector).bone_name = "LeftHand"  # reshapes the body: rebuilds
	await frames(1)
	var rebuilt := body.get_last_iterations()
	check(body.is_last_usable(), "the body still solves")
	check(after_edits < rebuilt, "the body kept its warm start through edits that do not reshape it (%d iterations; a rebuild takes %d)" % [after_edits, rebuilt])


func _rig_with_joint(seed_value: int, offset: Vector3) -> Dictionary:
	var rng := RandomNumberGenerator.new()
	rng.seed = seed_value
	var rig := Rig.make(3, IKChain.SOLVER_DLS, Arm.fk_tip_world(3, Arm.random_rotations(rng, 3)))
	var joint := IKChainJoint.new()
	joint.bone_name = "j1"
	joint.twist_limit_enabled = true
	joint.twist_min = -3.0
	joint.twist_max = 3.0
	(rig["ik"] as IKChain).joints = [joint]
	(rig["container"] as Node3D).position = offset
	Rig.add_to(case_root, rig)
	rig["joint"] = joint
	return rig


# The signed angle of a bone's pose rotation about `axis` (its twist about that axis).
static func skel_angle(skel: Skeleton3D, bone: String, axis: Vector3) -> float:
	var q := skel.get_bone_pose_rotation(skel.find_bone(bone))
	return 2.0 * atan2(Vector3(q.x, q.y, q.z).dot(axis), q.w)


const Body := preload("res://lib/body.gd")


func _small_body() -> Dictionary:
	var container := Node3D.new()
	container.position = Vector3(-3, 0, 0)
	var skel := Body.humanoid()
	container.add_child(skel)
	var target := Marker3D.new()
	target.name = "HandTarget"
	container.add_child(target)
	var body := IKBody.new()
	body.name = "IKBody"
	body.root_bone = "Hips"
	skel.add_child(body)
	case_root.add_child(container)
	var hand := skel.get_bone_global_pose(skel.find_bone("LeftHand")).origin
	target.global_position = skel.global_transform * (hand + Vector3(0.05, 0.05, 0.05))
	var e := Body.effector("LeftHand", target)
	body.effectors = [e]
	return {"body": body, "effector": e}


# The warnings and the rebuild come from one configuration pass: what stops the chain (the
# result's message after a solve) is among the warnings, a chain that runs has none, and reading
# the warnings of an unchanged node does not rebuild it (its next frame stays warm).
func test_warnings_and_rebuild_agree() -> void:
	# Limits the chain builder rejects (min > max).
	var a := _rig_with_joint(21, Vector3(0, 0, 0))
	var bad: IKChainJoint = a["joint"]
	bad.type = IKChainJoint.JOINT_HINGE
	bad.hinge_limit_enabled = true
	bad.hinge_min = 1.0
	bad.hinge_max = -1.0
	# A goal on the root bone's origin, which no joint of the chain moves.
	var b := _rig_with_joint(22, Vector3(3, 0, 0))
	var goal := IKChainGoal.new()
	goal.bone_name = "j0"
	goal.target = NodePath("../../Target")
	(b["ik"] as IKChain).goals = [goal]
	var good := _rig_with_joint(23, Vector3(6, 0, 0))
	await frames(2)
	for rig in [a, b]:
		var ik: IKChain = rig["ik"]
		var warnings := ik._get_configuration_warnings()
		var r: Dictionary = ik.solve_now()
		check(not r["usable"], "%s: the chain does not run" % rig["container"].name)
		check(String(r["message"]) != "" and String(r["message"]) in warnings,
				"the rebuild's problem '%s' is a warning: %s" % [r["message"], warnings])
	var ik_good: IKChain = good["ik"]
	check_eq(ik_good._get_configuration_warnings().size(), 0, "a chain that runs: no warning")
	for i in 3:
		ik_good._get_configuration_warnings()
	await frames(1)
	check(ik_good.is_last_usable(), "the good chain runs")
	check_le(ik_good.get_last_initial_error(), 1e-3, "reading the warnings did not rebuild the chain (still warm)")
	# Fixed, the warnings and the chain agree again, without a frame in between.
	bad.hinge_max = 1.5
	check_eq((a["ik"] as IKChain)._get_configuration_warnings().size(), 0, "fixed limits: no warning")
	check((a["ik"] as IKChain).solve_now()["usable"], "fixed limits: the chain runs")


func test_body_warnings_and_rebuild_agree() -> void:
	var body_rig := _small_body()
	var body: IKBody = body_rig["body"]
	var knee := IKChainJoint.new()
	knee.bone_name = "LeftLowerArm"
	knee.type = IKChainJoint.JOINT_HINGE
	knee.hinge_limit_enabled = true
	knee.hinge_min = 1.0
	knee.hinge_max = -1.0
	body.joints = [knee]
	await frames(2)
	var warnings := body._get_configuration_warnings()
	var r: Dictionary = body.solve_now()
	check(not r["usable"], "the body does not run")
	check(String(r["message"]) != "" and String(r["message"]) in warnings,
			"the rebuild's problem '%s' is a warning: %s" % [r["message"], warnings])
	knee.hinge_max = 1.5
	check_eq(body._get_configuration_warnings().size(), 0, "fixed: no warning")
	check(body.solve_now()["usable"], "fixed: the body runs")
