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


## Saves and reloads `original` (freed here) and checks the loaded IKChain's properties against
## `expected` (property name -> value; tolerance compared to 1e-9). Returns the loaded scene root,
## or null (nothing left to free) when loading or finding the chain failed.
func _reload_and_check(original: Node3D, expected: Dictionary) -> Node3D:
	var inst := _save_and_load(original)
	original.free()
	if inst == null:
		return null
	var ik := inst.get_node_or_null("Skeleton/IKChain") as IKChain
	if not check(ik != null, "Skeleton/IKChain exists and is an IKChain after loading"):
		inst.free()
		return null
	for property in expected:
		if property == "tolerance":
			check_near(ik.get(property), expected[property], 1e-9, property)
		else:
			check_eq(ik.get(property), expected[property], property)
	return inst


func test_custom_values_survive() -> void:
	var inst := _reload_and_check(_make_scene(true), {
		"root_bone": "j0", "tip_bone": "tip", "target": NodePath("../../Target"),
		"solver": IKChain.SOLVER_FABRIK, "max_iterations": 17, "tolerance": 0.0025, "deterministic": true})
	if inst == null:
		return
	# The loaded node is a working chain: it reaches its (reachable) target.
	var ik := inst.get_node("Skeleton/IKChain") as IKChain
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


func test_defaults_survive() -> void:
	var inst := _reload_and_check(_make_scene(false), {
		"root_bone": "", "tip_bone": "", "target": NodePath(),
		"solver": IKChain.SOLVER_AUTO, "max_iterations": 64, "tolerance": 0.0001, "deterministic": false})
	if inst != null:
		inst.free()
