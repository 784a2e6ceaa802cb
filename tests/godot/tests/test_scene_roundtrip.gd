# Properties survive a .tscn round trip: PackedScene.pack → ResourceSaver.save (user://) → load →
# instantiate, for non-default values and for defaults; the loaded chain still solves.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")

const PATH := "user://ikchain_roundtrip.tscn"


func _make_scene(custom: bool) -> Node3D:
	var scene_root := Node3D.new()
	scene_root.name = "Scene"
	var skel := Arm.make_skeleton(3)
	scene_root.add_child(skel)
	skel.owner = scene_root
	var target := Marker3D.new()
	target.name = "Target"
	scene_root.add_child(target)
	target.owner = scene_root
	var ik := IKChain.new()
	ik.name = "IKChain"
	skel.add_child(ik)
	ik.owner = scene_root
	if custom:
		ik.root_bone = "j0"
		ik.tip_bone = "tip"
		ik.target = NodePath("../../Target")
		ik.solver = IKChain.SOLVER_FABRIK
		ik.max_iterations = 17
		ik.tolerance = 0.0025
		ik.deterministic = true
		target.position = Arm.fk_tip_world(3, [Quaternion(Vector3.RIGHT, 0.5), Quaternion(Vector3.FORWARD, 0.7), Quaternion(Vector3.UP, 0.2)])
	return scene_root


func _save_and_load(scene_root: Node3D) -> Node3D:
	var packed := PackedScene.new()
	var err := packed.pack(scene_root)
	check_eq(err, OK, "PackedScene.pack")
	err = ResourceSaver.save(packed, PATH)
	check_eq(err, OK, "ResourceSaver.save " + PATH)
	var text := FileAccess.get_file_as_string(PATH)
	check(text.contains("type=\"IKChain\""), "the .tscn names the IKChain type")
	var loaded := ResourceLoader.load(PATH, "", ResourceLoader.CACHE_MODE_IGNORE) as PackedScene
	if not check(loaded != null, "load " + PATH):
		return null
	var inst := loaded.instantiate() as Node3D
	check(inst != null, "instantiate the loaded scene")
	DirAccess.remove_absolute(ProjectSettings.globalize_path(PATH))
	return inst


func test_custom_values_survive() -> void:
	var original := _make_scene(true)
	var inst := _save_and_load(original)
	original.free()
	if inst == null:
		return
	var ik := inst.get_node_or_null("Skeleton/IKChain") as IKChain
	if check(ik != null, "Skeleton/IKChain exists and is an IKChain after loading"):
		check_eq(ik.root_bone, "j0", "root_bone")
		check_eq(ik.tip_bone, "tip", "tip_bone")
		check_eq(ik.target, NodePath("../../Target"), "target")
		check_eq(ik.solver, IKChain.SOLVER_FABRIK, "solver")
		check_eq(ik.max_iterations, 17, "max_iterations")
		check_near(ik.tolerance, 0.0025, 1e-9, "tolerance")
		check_eq(ik.deterministic, true, "deterministic")
		# The loaded node is a working chain: it reaches its (reachable) target.
		var skel := inst.get_node("Skeleton") as Skeleton3D
		var target := inst.get_node("Target") as Node3D
		var cap := {}
		skel.skeleton_updated.connect(func():
			if cap.is_empty():
				cap["tip"] = Arm.tip_world(skel)
				cap["reason"] = ik.get_last_result().get("reason"))
		case_root.add_child(inst)
		await frames(2)
		if check(not cap.is_empty(), "loaded scene: skeleton_updated"):
			check_le((cap["tip"] as Vector3).distance_to(target.global_position), 0.0025 + 2e-6, "loaded scene: tip to target (m)")
			check_eq(cap["reason"], "converged", "loaded scene: reason")
		return
	inst.free()


func test_defaults_survive() -> void:
	var original := _make_scene(false)
	var inst := _save_and_load(original)
	original.free()
	if inst == null:
		return
	var ik := inst.get_node_or_null("Skeleton/IKChain") as IKChain
	if check(ik != null, "Skeleton/IKChain exists and is an IKChain after loading"):
		check_eq(ik.root_bone, "", "root_bone")
		check_eq(ik.tip_bone, "", "tip_bone")
		check_eq(ik.target, NodePath(), "target")
		check_eq(ik.solver, IKChain.SOLVER_DLS, "solver")
		check_eq(ik.max_iterations, 64, "max_iterations")
		check_near(ik.tolerance, 0.0001, 1e-9, "tolerance")
		check_eq(ik.deterministic, false, "deterministic")
	inst.free()
