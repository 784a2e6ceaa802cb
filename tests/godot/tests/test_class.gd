# The IKChain class as scripts see it: registration, constants, property defaults and types,
# both property paths (typed ptrcall and Variant set/get), and get_last_result() before any solve.
extends "res://lib/ik_test.gd"


func test_class_is_registered() -> void:
	check(ClassDB.class_exists("IKChain"), "ClassDB knows IKChain")
	check_eq(ClassDB.get_parent_class("IKChain"), &"SkeletonModifier3D", "IKChain's parent class")
	check(ClassDB.can_instantiate("IKChain"), "IKChain can be instantiated")
	var ik := IKChain.new()
	check(ik is SkeletonModifier3D, "IKChain.new() is SkeletonModifier3D")
	check(ik is Node3D, "IKChain.new() is Node3D")
	check_eq(ik.get_class(), "IKChain", "get_class()")
	ik.free()
	var by_name: Object = ClassDB.instantiate("IKChain")
	check(by_name is SkeletonModifier3D, "ClassDB.instantiate(\"IKChain\") is SkeletonModifier3D")
	by_name.free()


func test_solver_constants() -> void:
	check_eq(IKChain.SOLVER_TWO_BONE, 0, "SOLVER_TWO_BONE")
	check_eq(IKChain.SOLVER_CCD, 1, "SOLVER_CCD")
	check_eq(IKChain.SOLVER_JACOBIAN, 2, "SOLVER_JACOBIAN")
	check_eq(IKChain.SOLVER_DLS, 3, "SOLVER_DLS")
	check_eq(IKChain.SOLVER_BFGS, 4, "SOLVER_BFGS")
	check_eq(IKChain.SOLVER_FABRIK, 5, "SOLVER_FABRIK")
	check_eq(IKChain.SOLVER_AUTO, 6, "SOLVER_AUTO")
	for c in ["SOLVER_TWO_BONE", "SOLVER_CCD", "SOLVER_JACOBIAN", "SOLVER_DLS", "SOLVER_BFGS", "SOLVER_FABRIK",
			"SOLVER_AUTO"]:
		check(ClassDB.class_has_integer_constant("IKChain", c), "ClassDB has constant " + c)


func test_property_defaults() -> void:
	var ik := IKChain.new()
	check_eq(ik.root_bone, "", "root_bone default")
	check_eq(ik.tip_bone, "", "tip_bone default")
	check_eq(ik.target, NodePath(), "target default")
	check_eq(ik.solver, IKChain.SOLVER_AUTO, "solver default")
	check_eq(ik.max_iterations, 64, "max_iterations default")
	check_near(ik.tolerance, 0.0001, 1e-9, "tolerance default")
	check_eq(ik.deterministic, false, "deterministic default")
	check(ik.active, "active (inherited) default true")
	ik.free()


func test_property_types() -> void:
	var ik := IKChain.new()
	var want := {"root_bone": TYPE_STRING, "tip_bone": TYPE_STRING, "target": TYPE_NODE_PATH,
			"solver": TYPE_INT, "max_iterations": TYPE_INT, "tolerance": TYPE_FLOAT,
			"deterministic": TYPE_BOOL}
	var seen := {}
	for p in ik.get_property_list():
		if want.has(p["name"]):
			seen[p["name"]] = true
			check_eq(p["type"], want[p["name"]], "type of property " + p["name"])
			check((p["usage"] & PROPERTY_USAGE_STORAGE) != 0, "property %s is stored in scenes" % p["name"])
	for name in want:
		check(seen.has(name), "property %s is listed" % name)
	ik.free()


func test_typed_setters_round_trip() -> void:
	var ik := IKChain.new()
	ik.root_bone = "upper_arm"
	ik.tip_bone = "hand"
	ik.target = NodePath("../../Target")
	ik.solver = IKChain.SOLVER_FABRIK
	ik.max_iterations = 7
	ik.tolerance = 0.002
	ik.deterministic = true
	check_eq(ik.root_bone, "upper_arm", "root_bone")
	check_eq(ik.tip_bone, "hand", "tip_bone")
	check_eq(ik.target, NodePath("../../Target"), "target")
	check_eq(ik.solver, IKChain.SOLVER_FABRIK, "solver")
	check_eq(ik.max_iterations, 7, "max_iterations")
	check_near(ik.tolerance, 0.002, 1e-9, "tolerance")
	check_eq(ik.deterministic, true, "deterministic")
	ik.free()


func test_variant_set_get_round_trip() -> void:
	# Untyped set()/get() go through the Variant call path, where an int may arrive for a float.
	var ik: Object = ClassDB.instantiate("IKChain")
	ik.set("root_bone", "j0")
	ik.set("tip_bone", "tip")
	ik.set("target", NodePath("Target"))
	ik.set("solver", 1)
	ik.set("max_iterations", 12)
	ik.set("tolerance", 1)  # an int for a float property
	ik.set("deterministic", true)
	check_eq(ik.get("root_bone"), "j0", "get(root_bone)")
	check_eq(ik.get("tip_bone"), "tip", "get(tip_bone)")
	check_eq(ik.get("target"), NodePath("Target"), "get(target)")
	check_eq(ik.get("solver"), 1, "get(solver)")
	check_eq(ik.get("max_iterations"), 12, "get(max_iterations)")
	check_eq(ik.get("tolerance"), 1.0, "get(tolerance) after set(int 1)")
	check_eq(ik.get("deterministic"), true, "get(deterministic)")
	ik.set("tolerance", 0.25)
	check_eq(ik.get("tolerance"), 0.25, "get(tolerance) after set(0.25)")
	ik.free()


func test_last_result_before_any_solve() -> void:
	var ik := IKChain.new()
	var r: Dictionary = ik.get_last_result()
	for key in ["reason", "usable", "iterations", "initial_error", "final_error", "solver_final_error",
			"position_error", "orientation_error", "microseconds", "reached", "budget_exhausted", "restarts",
			"escapes", "joints_at_limit", "soft_pull", "solver", "message"]:
		check(r.has(key), "get_last_result() has key " + key)
	for key in ["restarts", "escapes", "joints_at_limit"]:
		check_eq(r.get(key), 0, key + " before any solve")
	check_eq(r.get("reason"), "not_run", "reason before any solve")
	check_eq(r.get("usable"), false, "usable before any solve")
	for key in ["initial_error", "final_error"]:
		check(typeof(r.get(key)) == TYPE_FLOAT and not is_nan(r.get(key)), "%s is a float, not NaN" % key)
	check(typeof(r.get("iterations")) == TYPE_INT, "iterations is an int")
	ik.free()


# Out-of-range values from scripts: clamped to the nearest valid value (a defined result), each
# with one ERROR line naming the property, its range and the value used; NaN keeps the last value.
func test_out_of_range_properties_are_clamped_with_an_error() -> void:
	var ik := IKChain.new()
	expect_error("max_iterations must be in 1\\.\\.1000, got 0; using 1", 1)
	ik.max_iterations = 0
	check_eq(ik.max_iterations, 1, "max_iterations = 0")
	expect_error("max_iterations must be in 1\\.\\.1000, got 5000; using 1000", 1)
	ik.set("max_iterations", 5000)
	check_eq(ik.max_iterations, 1000, "max_iterations = 5000 (Variant path)")
	expect_error("tolerance must be in \\[1e-06, 1\\] \\(skeleton units\\), got -1; using 1e-06", 1)
	ik.tolerance = -1.0
	check_eq(ik.tolerance, 1e-6, "tolerance = -1")
	expect_error("tolerance must be in \\[1e-06, 1\\] \\(skeleton units\\), got nan; using 1e-06", 1)
	ik.tolerance = NAN
	check_eq(ik.tolerance, 1e-6, "tolerance = NAN keeps the last value")
	expect_error("solver must be in 0\\.\\.6 .*got 9; using 6", 1)
	ik.solver = 9
	check_eq(ik.solver, IKChain.SOLVER_AUTO, "solver = 9")
	ik.free()


## Issue 16 item 9: assigning an Array property (joints, goals) from a script leaked one Array per
## assignment (the binding constructed the argument over an already constructed Array). Every
## script path to the setters (property, set(), call(), typed call) and the other builtin
## arguments converted the same way (String, StringName, NodePath) must leave the engine's
## tracked memory where it was.
func test_property_assignments_do_not_leak() -> void:
	var ik := IKChain.new()
	var joint := IKChainJoint.new()
	var goal := IKChainGoal.new()
	var joints: Array[IKChainJoint] = [joint]
	var goals: Array[IKChainGoal] = [goal]
	var plain := []
	const N := 5000
	var paths := {
		"ik.joints = a": func(): ik.joints = joints,
		"ik.goals = a": func(): ik.goals = goals,
		"ik.set(\"joints\", a)": func(): ik.set("joints", plain),
		"ik.set(\"goals\", a)": func(): ik.set("goals", plain),
		"ik.call(\"set_joints\", a)": func(): ik.call("set_joints", joints),
		"ik.set_joints(a)": func(): ik.set_joints(joints),
		"ik.set(\"root_bone\", String)": func(): ik.set("root_bone", "j0"),
		"ik.set(\"tip_bone\", StringName)": func(): ik.set("tip_bone", &"tip"),
		"ik.set(\"target\", NodePath)": func(): ik.set("target", NodePath("../T")),
		"ik.set(\"pole_target\", String)": func(): ik.set("pole_target", "../P"),
	}
	for what in paths:
		var assign: Callable = paths[what]
		for i in 50:  # warm-up: first-use allocations (caches, interned names)
			assign.call()
		var before := OS.get_static_memory_usage()
		for i in N:
			assign.call()
		var grown := OS.get_static_memory_usage() - before
		# A leak of one Array (80 bytes) per assignment grows by 400 kB; allow 1 byte per call.
		check_le(grown, N, "%s x %d: tracked memory growth (bytes)" % [what, N])
	ik.free()


## get_last_result()'s keys against the typed getters named after them (issue 16 item 16).
func _check_getters_agree(ik: IKChain, what: String) -> void:
	var r: Dictionary = ik.get_last_result()
	check_eq(ik.get_last_reason(), r["reason"], what + ": get_last_reason()")
	check_eq(ik.is_last_usable(), r["usable"], what + ": is_last_usable()")
	check_eq(ik.is_last_reached(), r["reached"], what + ": is_last_reached()")
	check_eq(ik.get_last_iterations(), r["iterations"], what + ": get_last_iterations()")
	check_eq(ik.get_last_initial_error(), r["initial_error"], what + ": get_last_initial_error()")
	check_eq(ik.get_last_final_error(), r["final_error"], what + ": get_last_final_error()")
	check_eq(ik.get_last_position_error(), r["position_error"], what + ": get_last_position_error()")
	check_eq(ik.get_last_orientation_error(), r["orientation_error"], what + ": get_last_orientation_error()")
	check_eq(ik.get_last_microseconds(), r["microseconds"], what + ": get_last_microseconds()")


## Issue 16 item 16: typed getters for the last solve (reason, errors, iterations, time), equal to
## the Dictionary's keys before any solve, after a converged, an unreachable, a blended
## (influence < 1) and an invalid solve, and cheaper to read than the Dictionary.
func test_last_result_typed_getters() -> void:
	var Rig := preload("res://lib/rig.gd")
	var Arm := preload("res://lib/arm.gd")
	var rng := RandomNumberGenerator.new()
	rng.seed = 16
	var goal := Arm.fk_tip_world(3, Arm.random_rotations(rng, 3))
	var rig := Rig.make(3, IKChain.SOLVER_DLS, goal)
	var ik: IKChain = rig["ik"]
	_check_getters_agree(ik, "before any solve")
	check_eq(ik.get_last_reason(), "not_run", "reason before any solve")
	case_root.add_child(rig["container"])
	await frames(2)
	ik.solve_now()
	_check_getters_agree(ik, "converged")
	check_eq(ik.get_last_reason(), "converged", "reason of a reachable target")
	check(ik.is_last_reached(), "reached a reachable target")
	check(ik.get_last_iterations() >= 0 and ik.get_last_microseconds() > 0.0, "work and time reported")
	(rig["target"] as Node3D).global_position = goal + (goal - Arm.root_joint_world()) * 5.0
	ik.solve_now()
	_check_getters_agree(ik, "out of reach")
	check(not ik.is_last_reached() and ik.get_last_position_error() > 0.1, "out of reach: not reached, error shown")
	ik.influence = 0.5
	ik.solve_now()
	_check_getters_agree(ik, "influence 0.5")
	ik.influence = 1.0
	ik.tip_bone = "no such bone"
	ik.solve_now()
	_check_getters_agree(ik, "misconfigured")
	check_eq(ik.get_last_reason(), "invalid_input", "reason of a misconfigured chain")
	check(not ik.is_last_usable(), "misconfigured: not usable")
	# Cost: one typed read against one Dictionary (best of 3 rounds, loose: the Dictionary
	# builds 15 entries and its String keys).
	var best_typed := INF
	var best_dict := INF
	for round in 3:
		var t0 := Time.get_ticks_usec()
		for i in 2000:
			ik.get_last_position_error()
		var t1 := Time.get_ticks_usec()
		for i in 2000:
			ik.get_last_result()
		var t2 := Time.get_ticks_usec()
		best_typed = minf(best_typed, t1 - t0)
		best_dict = minf(best_dict, t2 - t1)
	check_le(best_typed * 2.0, best_dict, "2000 typed reads cost at most half of 2000 get_last_result() (us)")


## Issue 16 item 10: aim_axis (IKChain and IKChainGoal) is normalised when set; a zero or
## non-finite vector is rejected with an error naming the property, and the previous value stays.
func test_aim_axis_normalised_or_rejected() -> void:
	for obj in [IKChain.new(), IKChainGoal.new()]:
		var what: String = obj.get_class()
		obj.aim_axis = Vector3(0, 0, 2)
		check(obj.aim_axis.is_equal_approx(Vector3(0, 0, 1)), "%s: (0, 0, 2) stored as (0, 0, 1), got %s" % [what, obj.aim_axis])
		obj.set("aim_axis", Vector3(3, 4, 0))
		check(obj.aim_axis.is_equal_approx(Vector3(0.6, 0.8, 0)), "%s: set() (3, 4, 0) stored as (0.6, 0.8, 0), got %s" % [what, obj.aim_axis])
		obj.aim_axis = Vector3(1e30, 0, 0)
		check(obj.aim_axis.is_equal_approx(Vector3(1, 0, 0)), "%s: (1e30, 0, 0) stored as (1, 0, 0), got %s" % [what, obj.aim_axis])
		expect_error(what + ": aim_axis must be a finite, non-zero vector.*keeping the previous value", 3)
		for bad in [Vector3.ZERO, Vector3(NAN, 1, 0), Vector3(0, INF, 0)]:
			obj.aim_axis = bad
			check_eq(obj.aim_axis, Vector3(1, 0, 0), "%s: %s rejected, the previous value kept" % [what, bad])
		if obj is Node:
			obj.free()


## Issue 16 item 10: restart_seed keeps all 64 bits: 1 and 2^32 + 1 give different restarts, the
## same seed the same result.
func test_restart_seed_keeps_64_bits() -> void:
	var Rig := preload("res://lib/rig.gd")
	var Arm := preload("res://lib/arm.gd")
	# A target behind the arm, one iteration per run: the best of 30 random restarts depends on
	# every draw of the generator.
	var goal := Arm.root_joint_world() + Arm.SKELETON_TRANSFORM.basis * Vector3(0.2, -0.3, 0.35)
	var rig := Rig.make(3, IKChain.SOLVER_DLS, goal)
	var ik: IKChain = rig["ik"]
	var skel: Skeleton3D = rig["skeleton"]
	ik.deterministic = true
	ik.max_iterations = 1
	ik.max_restarts = 30
	case_root.add_child(rig["container"])
	await frames(1)
	var runs := {}
	for seed_value in [1, 4294967297, 2, 1]:
		ik.restart_seed = seed_value
		check_eq(ik.restart_seed, seed_value, "restart_seed %d read back" % seed_value)
		var r := ik.solve_now()
		var pose := [r["final_error"]]
		for name in ["j0", "j1", "j2"]:
			pose.append(skel.get_bone_pose_rotation(skel.find_bone(name)))
		check(int(r["restarts"]) > 0, "seed %d: restarts ran" % seed_value)
		if runs.has(seed_value):
			check_eq(pose, runs[seed_value], "seed %d twice: the same result" % seed_value)
		runs[seed_value] = pose
	check(runs[1] != runs[2], "seeds 1 and 2 give different restarts (the case depends on the seed)")
	check(runs[1] != runs[4294967297], "seeds 1 and 2^32 + 1 give different restarts")
