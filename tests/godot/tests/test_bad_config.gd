# Bad configurations: each must give a configuration warning naming the problem and print NO error
# (like Godot's own modifiers: an IKChain not configured yet shows the warning triangle, it does not
# fill the output with ERROR lines; any ERROR line fails the case), leave every bone pose unchanged
# and finite, report a not-usable result, and never crash.
# Finally, fixing the property must make the chain work without a restart.
#
# The arm is the 3-joint arm of lib/arm.gd, posed with non-rest joint rotations so that "unchanged"
# is not the same as "reset to rest". Poses are compared inside skeleton_updated and the modifier's
# modification_processed (where a modifier's output would be visible) against poses composed from
# the local poses set before the scene entered the tree.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")
const Rig := preload("res://lib/rig.gd")

const FRAMES := 5


func test_no_skeleton_parent() -> void:
	await _bad("skeleton3d", "skeleton3d", func(rig: Dictionary) -> void:
		# IKChain under a plain Node3D next to the skeleton, otherwise correctly configured.
		var ik: IKChain = rig["ik"]
		var holder := Node3D.new()
		holder.name = "Holder"
		ik.get_parent().remove_child(ik)
		holder.add_child(ik)
		rig["container"].add_child(holder))


func test_root_bone_not_found() -> void:
	await _bad("root_bone", "root_bone", func(rig: Dictionary) -> void: rig["ik"].root_bone = "no_such_bone")


func test_root_bone_empty() -> void:
	await _bad("root_bone", "root_bone", func(rig: Dictionary) -> void: rig["ik"].root_bone = "")


func test_tip_bone_not_found() -> void:
	await _bad("tip_bone", "tip_bone", func(rig: Dictionary) -> void: rig["ik"].tip_bone = "no_such_bone")


func test_tip_bone_empty() -> void:
	await _bad("tip_bone", "tip_bone", func(rig: Dictionary) -> void: rig["ik"].tip_bone = "")


func test_tip_above_root() -> void:
	await _bad("tip_bone|root_bone", "tip_bone|root_bone", func(rig: Dictionary) -> void:
		rig["ik"].root_bone = "j1"
		rig["ik"].tip_bone = "j0")


func test_tip_on_other_branch() -> void:
	await _bad("tip_bone|root_bone", "tip_bone|root_bone", func(rig: Dictionary) -> void:
		rig["ik"].root_bone = "j0"
		rig["ik"].tip_bone = "side")


func test_tip_equals_root() -> void:
	await _bad("tip_bone|root_bone", "tip_bone|root_bone", func(rig: Dictionary) -> void:
		rig["ik"].root_bone = "j1"
		rig["ik"].tip_bone = "j1")


func test_target_empty() -> void:
	await _bad("target", "target", func(rig: Dictionary) -> void: rig["ik"].target = NodePath())


func test_target_path_missing() -> void:
	await _bad("target", "target", func(rig: Dictionary) -> void: rig["ik"].target = NodePath("../../Nowhere"))


func test_target_not_node3d() -> void:
	await _bad("target", "target", func(rig: Dictionary) -> void:
		var plain := Node.new()
		plain.name = "PlainNode"
		rig["container"].add_child(plain)
		rig["ik"].target = NodePath("../../PlainNode"))


func test_two_bone_with_three_joints() -> void:
	await _bad("solver|two_bone", "solver|two_bone", func(rig: Dictionary) -> void:
		rig["ik"].solver = IKChain.SOLVER_TWO_BONE)


## The node's configuration warnings as scripts can see them, or null (after a failed check).
## Godot 4.6 does not bind Node.get_configuration_warnings() for scripts, and the virtual
## _get_configuration_warnings() an extension overrides is not a bound method either; so IKChain
## must bind one of them itself for the warnings to be observable outside the editor.
func warnings_of(node: Node) -> Variant:
	for method in ["get_configuration_warnings", "_get_configuration_warnings"]:
		if node.has_method(method):
			var w = node.call(method)
			if check(w is PackedStringArray or w is Array, "%s() returns a string array, got %s" % [method, type_string(typeof(w))]):
				return PackedStringArray(w)
			return null
	fail("%s binds neither get_configuration_warnings() nor _get_configuration_warnings(): its warnings cannot be checked from a script" % node.get_class())
	return null


## Builds a valid 3-joint rig, breaks it with `breaker`, runs FRAMES frames and checks the outcome.
## error_regex names what the problem concerns (kept for readability); warning_regex is what a
## configuration warning must mention.
func _bad(error_regex: String, warning_regex: String, breaker: Callable) -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 404
	var rotations := Arm.random_rotations(rng, 3)
	var rig := Rig.make(3, IKChain.SOLVER_DLS, Arm.fk_tip_world(3, Arm.random_rotations(rng, 3)), rotations)
	breaker.call(rig)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	var expected_globals := Arm.compose_globals(skel)
	var locals_before := []
	for i in skel.get_bone_count():
		locals_before.append(skel.get_bone_pose(i))
	var captures := []
	var grab := func(): captures.append(Rig.capture(skel, ik))
	skel.skeleton_updated.connect(grab)
	ik.modification_processed.connect(grab)

	Rig.add_to(case_root, rig)
	await frames(FRAMES)

	var warnings = warnings_of(ik)
	if warnings != null:
		check(not (warnings as PackedStringArray).is_empty(), "configuration warnings are not empty")
		var re := RegEx.create_from_string("(?i)" + warning_regex)
		check(re.search(" | ".join(warnings)) != null,
				"a configuration warning mentions /%s/: %s" % [warning_regex, var_to_str(warnings)])

	for c in captures:
		for i in skel.get_bone_count():
			var g: Transform3D = c["globals"][i]
			if not check(transform_is_finite(g) and transforms_near(g, expected_globals[i], 1e-5),
					"bone %s global pose unchanged and finite during the update" % skel.get_bone_name(i)):
				break
	# Without a modifier pass there is nothing to capture; read the poses directly then.
	var globals_now := []
	for i in skel.get_bone_count():
		globals_now.append(skel.get_bone_global_pose(i))
	for i in skel.get_bone_count():
		check(transforms_near(skel.get_bone_pose(i), locals_before[i], 1e-6),
				"bone %s local pose unchanged after %d frames" % [skel.get_bone_name(i), FRAMES])
		check(transform_is_finite(globals_now[i]) and transforms_near(globals_now[i], expected_globals[i], 1e-5),
				"bone %s global pose unchanged and finite after %d frames" % [skel.get_bone_name(i), FRAMES])

	var r := ik.get_last_result()
	check(r.get("reason") in ["invalid_input", "not_run"],
			"reason is invalid_input or not_run, got %s" % var_to_str(r.get("reason")))
	check_eq(r.get("usable"), false, "usable")
	for key in ["initial_error", "final_error"]:
		check(not is_nan(float(r.get(key, NAN))), "%s is not NaN" % key)


# A broken property, once fixed, must take effect (the chain is rebuilt lazily, no re-add needed).
func test_recovers_when_fixed() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 505
	var goal := Arm.fk_tip_world(3, Arm.random_rotations(rng, 3))
	var rig := Rig.make(3, IKChain.SOLVER_DLS, goal)
	var skel: Skeleton3D = rig["skeleton"]
	var ik: IKChain = rig["ik"]
	ik.root_bone = "no_such_bone"
	Rig.add_to(case_root, rig)
	await frames(3)
	var broken = warnings_of(ik)
	if broken != null:
		check(not (broken as PackedStringArray).is_empty(), "broken: a configuration warning")
	ik.root_bone = "j0"
	var cap := {}
	skel.skeleton_updated.connect(func():
		cap["tip"] = Arm.tip_world(skel)
		cap["reason"] = ik.get_last_result().get("reason"))
	await frames(2)
	var fixed = warnings_of(ik)
	if fixed != null:
		check((fixed as PackedStringArray).is_empty(), "fixed: no configuration warnings, got %s" % var_to_str(fixed))
	if check(not cap.is_empty(), "fixed: skeleton_updated"):
		check_le((cap["tip"] as Vector3).distance_to(goal), ik.tolerance + 2e-6, "fixed: tip to target (m)")
		check_eq(cap["reason"], "converged", "fixed: reason")
