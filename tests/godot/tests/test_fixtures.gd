# Checks the test oracle itself (lib/arm.gd): its forward kinematics must agree with Skeleton3D's
# own, otherwise every reach test would measure against the wrong point. Needs no IKChain.
extends "res://lib/ik_test.gd"

const Arm := preload("res://lib/arm.gd")


func test_fk_matches_skeleton3d() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 7
	for n in [2, 3, 4]:
		var skel := Arm.make_skeleton(n)
		var rotations := Arm.random_rotations(rng, n)
		Arm.pose_joints(skel, rotations)
		case_root.add_child(skel)
		# No modifier here, so no skeleton_updated: read the (forced) global poses directly.
		await frames(1)
		var captured := {"tip": Arm.tip_world(skel), "globals": []}
		for i in skel.get_bone_count():
			captured["globals"].append(skel.get_bone_global_pose(i))
		var expected_tip := Arm.fk_tip_world(n, rotations)
		check((captured["tip"] as Vector3).distance_to(expected_tip) < 1e-5,
				"%d joints: FK tip %s == Skeleton3D tip %s" % [n, fmt_v(expected_tip), fmt_v(captured["tip"])])
		var composed := Arm.compose_globals(skel)
		for i in skel.get_bone_count():
			check(transforms_near(composed[i], captured["globals"][i], 1e-5),
					"%d joints: composed global pose of bone %d matches Skeleton3D" % [n, i])
		var fk := Arm.fk_chain(n, rotations)
		check(transforms_near(fk[1], captured["globals"][skel.find_bone("j0")], 1e-5),
				"%d joints: FK root joint matches Skeleton3D" % n)
		check(Arm.root_joint_world().distance_to(skel.global_transform * (fk[1] as Transform3D).origin) < 1e-5,
				"%d joints: root_joint_world() matches" % n)
		skel.free()


func test_random_targets_are_reachable_and_bent() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 11
	for k in 20:
		var n := 2 + k % 3
		var target := Arm.fk_tip_world(n, Arm.random_rotations(rng, n))
		var d := target.distance_to(Arm.root_joint_world())
		check(d <= Arm.chain_length(n) + 1e-6, "target %d within reach (%.4f <= %.4f)" % [k, d, Arm.chain_length(n)])
		check(d < Arm.chain_length(n) - 1e-3, "target %d not at full stretch (%.4f)" % [k, d])
