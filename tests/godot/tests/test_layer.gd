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
