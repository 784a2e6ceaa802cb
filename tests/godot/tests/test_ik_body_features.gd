# IKBody's game-developer features on a humanoid built from Godot's SkeletonProfileHumanoid: a
# look spread over spine, neck and head (IKBodyEffector.look_at / look_shares), baking the IK over
# an animation into a new Animation (IKBodyBaker), and foot placement on physics ground
# (IKFootPlacement). Poses are read inside skeleton_updated (the modifier's output) and checked by
# forward kinematics.
extends "res://lib/ik_test.gd"

const Body := preload("res://lib/body.gd")

const FLOAT_SLACK := 2e-5
const DEG := PI / 180.0
## Head, neck, upper chest, chest, spine: the look's share per bone (the effector's bone first).
const SHARES := [0.35, 0.25, 0.15, 0.15, 0.1]
const LOOK_BONES := ["Head", "Neck", "UpperChest", "Chest", "Spine"]


# ------------------------------------------------------------------ fixtures

func _target(name: String, t: Transform3D) -> Node3D:
	return Body.target(case_root, name, t)


func _cone(bone: String, cone_deg: float, twist_deg: float) -> IKChainJoint:
	var j := IKChainJoint.new()
	j.bone_name = bone
	j.cone_limit_enabled = true
	j.cone_angle = cone_deg * DEG
	j.twist_limit_enabled = true
	j.twist_min = -twist_deg * DEG
	j.twist_max = twist_deg * DEG
	return j


## The poses at the next skeleton_updated (lib/body.gd capture()).
func _capture(skel: Skeleton3D, body: IKBody) -> Dictionary:
	return await Body.capture(self, skel, body)


# ------------------------------------------------------------------ look-at spread

## A body whose head looks at `target` with SHARES over head..spine, cones on the spine and neck.
func _look_rig(target_position: Vector3, neck_twist_deg := 60.0) -> Dictionary:
	var skel := Body.humanoid()
	case_root.add_child(skel)
	var head := skel.find_bone("Head")
	var head_rest := skel.get_bone_global_pose(head)
	var t := _target("LookTarget", Transform3D(Basis(), target_position))
	var e := Body.effector("Head", t, 1, 0.0, 1.0)
	e.look_at = true
	# The head's own axis that faces the character's forward (+Z) at rest.
	e.look_axis = (head_rest.basis.inverse() * Vector3(0, 0, 1)).normalized()
	e.look_shares = SHARES
	var body := IKBody.new()
	body.root_bone = "Hips"
	body.joints = [_cone("Spine", 30, 30), _cone("Chest", 30, 30), _cone("UpperChest", 30, 30),
			_cone("Neck", 40, neck_twist_deg)]
	body.effectors = [e]
	skel.add_child(body)
	return {"skeleton": skel, "body": body, "effector": e, "head_rest": head_rest}


## How far each of LOOK_BONES turned from its rest (rad) and the head's aim error (rad).
func _look_measure(skel: Skeleton3D, cap: Dictionary, e: IKBodyEffector, target_position: Vector3) -> Dictionary:
	var turns := {}
	for bone in LOOK_BONES:
		var i := skel.find_bone(bone)
		var rest := skel.get_bone_rest(i).basis.get_rotation_quaternion()
		turns[bone] = Body.angle(rest, (cap["locals"][i] as Transform3D).basis.get_rotation_quaternion())
	var head_global: Transform3D = cap["globals"][skel.find_bone("Head")]
	var facing := (head_global.basis * e.look_axis).normalized()
	var wanted := (target_position - head_global.origin).normalized()
	return {"turns": turns, "aim_error": facing.angle_to(wanted)}


# A target 60 degrees to the side: the head aims at it within 1 degree, each bone takes its set
# share of the turn within 2 degrees (so the torso does not turn as a block), the cones hold.
func test_look_at_spreads_the_turn_by_share() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var target_position := head_origin + 2.0 * Vector3(sin(60 * DEG), 0, cos(60 * DEG))
	var rig := _look_rig(target_position)
	var skel: Skeleton3D = rig["skeleton"]
	var body: IKBody = rig["body"]
	var cap := await _capture(skel, body)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var m := _look_measure(skel, cap, rig["effector"], target_position)
	check_le(m["aim_error"], 1.0 * DEG, "the head aims at the target (rad)")
	check(body.is_last_usable(), "usable: " + body.get_last_reason())
	check_le(body.get_last_effector_rotation_error(0), 1.0 * DEG, "the reported aim error (rad)")
	var total := 0.0
	for bone in LOOK_BONES:
		total += m["turns"][bone]
	check_near(total, 60 * DEG, 3 * DEG, "the bones' turns add up to the look (rad)")
	for k in LOOK_BONES.size():
		var bone: String = LOOK_BONES[k]
		print("  look share %-10s set %.2f  turned %5.1f deg (%.2f of the turn)" % [bone, SHARES[k],
				m["turns"][bone] / DEG, m["turns"][bone] / total])
		check_near(m["turns"][bone], SHARES[k] * 60 * DEG, 2 * DEG, bone + " turned its share (rad)")
	# Not as a block: the spine turns a fraction of the head's turn.
	check_le(m["turns"]["Spine"], 0.2 * 60 * DEG, "the spine turns little (rad)")
	for bone in ["Spine", "Chest", "UpperChest"]:
		check_le(m["turns"][bone], 30 * DEG + 1e-3, bone + " within its limits (rad)")


# Tracking: the target sweeps from 60 degrees left to 40 degrees right over 30 frames (each frame
# warm-starts from the last solution): the shares hold at the end as they do from rest.
func test_look_at_tracking_a_moving_target_keeps_the_shares() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var at := func(deg: float) -> Vector3:
		return head_origin + 2.0 * Vector3(sin(deg * DEG), 0, cos(deg * DEG))
	var rig := _look_rig(at.call(60.0))
	var skel: Skeleton3D = rig["skeleton"]
	var t: Node3D = case_root.get_node("LookTarget")
	var cap := {}
	for i in 31:
		t.position = at.call(60.0 - 100.0 * i / 30.0)
		cap = await _capture(skel, rig["body"])
		if not check(not cap.is_empty(), "frame %d: skeleton_updated came" % i):
			return
	var m := _look_measure(skel, cap, rig["effector"], at.call(-40.0))
	check_le(m["aim_error"], 1.0 * DEG, "the head aims at the target after the sweep (rad)")
	for k in LOOK_BONES.size():
		var bone: String = LOOK_BONES[k]
		check_near(m["turns"][bone], SHARES[k] * 40 * DEG, 2 * DEG, bone + " holds its share (rad)")


# A neck whose twist limit (5 degrees) is below its share: the neck stops at its limit, the head
# takes what the neck withholds and still aims within 1 degree.
func test_look_at_limits_hold_and_pass_the_rest_on() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var target_position := head_origin + 2.0 * Vector3(sin(60 * DEG), 0, cos(60 * DEG))
	var rig := _look_rig(target_position, 5.0)
	var skel: Skeleton3D = rig["skeleton"]
	var body: IKBody = rig["body"]
	var cap := await _capture(skel, body)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var m := _look_measure(skel, cap, rig["effector"], target_position)
	check_le(m["aim_error"], 1.0 * DEG, "the head still aims at the target (rad)")
	check_le(m["turns"]["Neck"], 5 * DEG + 1e-3, "the neck holds its 5 degree twist limit (rad)")
	check(m["turns"]["Head"] > SHARES[0] * 60 * DEG + 5 * DEG, "the head took what the neck withheld")


# Influence 0.5: the look turns half way from the animated (rest) pose.
func test_look_at_influence_turns_part_way() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var target_position := head_origin + 2.0 * Vector3(sin(60 * DEG), 0, cos(60 * DEG))
	var rig := _look_rig(target_position)
	(rig["effector"] as IKBodyEffector).influence = 0.5
	var skel: Skeleton3D = rig["skeleton"]
	var cap := await _capture(skel, rig["body"])
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var m := _look_measure(skel, cap, rig["effector"], target_position)
	check_near(m["aim_error"], 30 * DEG, 2 * DEG, "the head turned half way (rad)")


# Without look_shares the look is still an aim goal: the solver spreads it by motion cost.
func test_look_at_without_shares_still_aims() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var target_position := head_origin + 2.0 * Vector3(sin(40 * DEG), 0.3, cos(40 * DEG))
	var rig := _look_rig(target_position)
	(rig["effector"] as IKBodyEffector).look_shares = []
	var skel: Skeleton3D = rig["skeleton"]
	var cap := await _capture(skel, rig["body"])
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var m := _look_measure(skel, cap, rig["effector"], target_position)
	check_le(m["aim_error"], 1.0 * DEG, "the head aims at the target (rad)")


# setup_humanoid() leaves the head ready to look: turning on look_at and giving it a target is all;
# the feet stay planted (level 1) while the head (level 3) looks 50 degrees aside and up.
func test_look_at_on_the_set_up_humanoid() -> void:
	var skel := Body.humanoid()
	case_root.add_child(skel)
	var body := IKBody.new()
	skel.add_child(body)
	check(body.setup_humanoid(), "set up")
	var head_origin := skel.get_bone_global_pose(skel.find_bone("Head")).origin
	var target_position := head_origin + 2.0 * Vector3(sin(50 * DEG), 0.3, cos(50 * DEG))
	var t := _target("LookTarget", Transform3D(Basis(), target_position))
	var kept: Array[IKBodyEffector] = []
	for e in body.effectors:
		if e.bone_name in ["Hips", "LeftFoot", "RightFoot"]:
			e.use_target_transform = true
			e.target_transform = skel.get_bone_global_pose(skel.find_bone(e.bone_name))
			kept.append(e)
		elif e.bone_name == "Head":
			check_eq(e.look_shares.size(), 5, "the head's look spreads over five bones")
			e.look_at = true
			e.target = NodePath("../../LookTarget")
			kept.append(e)
	body.effectors = kept
	var cap := await _capture(skel, body)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var head_global: Transform3D = cap["globals"][skel.find_bone("Head")]
	var facing := (head_global.basis * Vector3(0, 0, 1)).normalized()
	check_le(facing.angle_to((target_position - head_global.origin).normalized()), 1.0 * DEG,
			"the head aims at the target (rad)")
	for bone in ["LeftFoot", "RightFoot"]:
		var g: Transform3D = cap["globals"][skel.find_bone(bone)]
		check_le(g.origin.distance_to(skel.get_bone_global_pose(skel.find_bone(bone)).origin), 1e-3,
				bone + " stays planted (m)")
	check(body.is_last_level_met(1), "level 1 (feet, hips) met")
	check(t != null, "fixture")


# A look target on the head's own origin: no direction to look along; a defined, finite pose.
func test_look_at_target_on_the_bone_keeps_a_defined_pose() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var rig := _look_rig(head_origin)
	var skel: Skeleton3D = rig["skeleton"]
	var cap := await _capture(skel, rig["body"])
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	for i in skel.get_bone_count():
		if not check((cap["globals"][i] as Transform3D).is_finite(), "finite pose"):
			break
	var head := skel.find_bone("Head")
	check_le(Body.angle(skel.get_bone_rest(head).basis.get_rotation_quaternion(),
			(cap["locals"][head] as Transform3D).basis.get_rotation_quaternion()), 1e-3, "the head does not turn")


# The gizmo draws a look as the line to the target and the bone's look axis, as long: after the
# solve they coincide (the look's error is the angle between them).
func test_look_at_gizmo_draws_the_look_axis() -> void:
	var skel0 := Body.humanoid()
	var head_origin := skel0.get_bone_global_pose(skel0.find_bone("Head")).origin
	skel0.free()
	var target_position := head_origin + 2.0 * Vector3(sin(60 * DEG), 0, cos(60 * DEG))
	var rig := _look_rig(target_position)
	var skel: Skeleton3D = rig["skeleton"]
	var BodyDrawer: GDScript = load("res://addons/ikchain/ik_body_drawer.gd")
	var lines := {}
	var grab := func():
		if lines.is_empty():
			lines.merge(BodyDrawer.build(rig["body"]))
	skel.skeleton_updated.connect(grab)
	for i in 4:
		if lines.is_empty():
			await process_frame
	skel.skeleton_updated.disconnect(grab)
	if not check(not lines.is_empty(), "drawn in skeleton_updated"):
		return
	var target: PackedVector3Array = lines["target"]
	# A cross (3 segments) and the line to the target, then the look axis.
	if not check_eq(target.size(), 3 * 2 + 2 + 2, "a cross, the line to the target and the look axis"):
		return
	var to_target := target[7] - target[6]
	var look := target[9] - target[8]
	check_near(look.length(), to_target.length(), 1e-4, "the look axis is as long as the line to the target (m)")
	check_le(look.angle_to(to_target), 1.0 * DEG, "after the solve they coincide (rad)")


func test_look_at_bad_settings_are_named_with_their_fix() -> void:
	var t := _target("T", Transform3D(Basis(), Vector3(1, 1.5, 1)))
	var cases := [
		[[0.5, -1.0], 1.0, "look_shares holds a negative, non-finite or non-number entry"],
		[[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1], 1.0, "look_shares has 8 entries, but only 6 bones"],
		[[0.0, 0.0], 1.0, "look_shares are all 0"],
		[[0.5, 0.5], 0.0, "look_at aims the bone with rotation_weight, which is 0"],
	]
	for c in cases:
		var skel := Body.humanoid()
		case_root.add_child(skel)
		var e := Body.effector("Head", t, 1, 1.0, c[1])
		e.look_at = true
		e.look_shares = c[0]
		var body := IKBody.new()
		body.root_bone = "Hips"
		body.effectors = [e]
		skel.add_child(body)
		var w := Body.warnings(body)
		check(w.contains(c[2]), "warning contains '%s'; got: %s" % [c[2], w])
		# The body still runs (or keeps the animated pose): a defined, finite pose either way.
		var cap := await _capture(skel, body)
		for i in skel.get_bone_count():
			var g: Transform3D = cap["globals"][i] if not cap.is_empty() else skel.get_bone_global_pose(i)
			if not check(g.is_finite(), c[2] + ": finite pose"):
				break
		skel.free()
	var e2 := IKBodyEffector.new()
	expect_error("look_axis must be a finite non-zero vector", 1)
	e2.look_axis = Vector3.ZERO
	check_eq(e2.look_axis, Vector3(0, 0, 1), "a zero look_axis is refused; the default stays")
	check_eq(e2.look_at, false, "look_at default")


# ------------------------------------------------------------------ bake

const Baker := preload("res://addons/ikchain/ik_body_baker.gd")


## A humanoid, a player with the animation "move" (`seconds` long: the left hand's target moves,
## the spine and the left thigh are animated) and a body reaching both hands (deterministic).
func _bake_rig(seconds := 2.0) -> Dictionary:
	var skel := Body.humanoid()
	case_root.add_child(skel)
	var lhand := skel.get_bone_global_pose(skel.find_bone("LeftHand")).origin
	var rhand := skel.get_bone_global_pose(skel.find_bone("RightHand")).origin
	var lt := _target("LH", Transform3D(Basis(), lhand))
	var rt := _target("RH", Transform3D(Basis(), rhand + Vector3(0, -0.1, 0.2)))
	var anim := Animation.new()
	anim.length = seconds
	var t := anim.add_track(Animation.TYPE_POSITION_3D)
	anim.track_set_path(t, NodePath("LH"))
	anim.position_track_insert_key(t, 0.0, lhand + Vector3(-0.15, -0.1, 0.15))
	anim.position_track_insert_key(t, seconds * 0.5, lhand + Vector3(-0.1, 0.05, 0.25))
	anim.position_track_insert_key(t, seconds, lhand + Vector3(-0.2, -0.15, 0.2))
	var spine_rest := skel.get_bone_rest(skel.find_bone("Spine")).basis.get_rotation_quaternion()
	t = anim.add_track(Animation.TYPE_ROTATION_3D)
	anim.track_set_path(t, NodePath("Skeleton:Spine"))
	anim.rotation_track_insert_key(t, 0.0, spine_rest * Quaternion(Vector3.RIGHT, 0.1))
	anim.rotation_track_insert_key(t, seconds, spine_rest * Quaternion(Vector3.RIGHT, -0.1))
	var leg_rest := skel.get_bone_rest(skel.find_bone("LeftUpperLeg")).basis.get_rotation_quaternion()
	t = anim.add_track(Animation.TYPE_ROTATION_3D)
	anim.track_set_path(t, NodePath("Skeleton:LeftUpperLeg"))
	anim.rotation_track_insert_key(t, 0.0, leg_rest)
	anim.rotation_track_insert_key(t, seconds, leg_rest * Quaternion(Vector3.RIGHT, 0.4))
	var lib := AnimationLibrary.new()
	lib.add_animation(&"move", anim)
	var player := AnimationPlayer.new()
	player.name = "Player"
	case_root.add_child(player)
	player.add_animation_library(&"", lib)
	var body := IKBody.new()
	body.root_bone = "Hips"
	body.deterministic = true
	body.max_iterations = 200
	body.effectors = [Body.effector("LeftHand", lt), Body.effector("RightHand", rt)]
	skel.add_child(body)
	return {"skeleton": skel, "body": body, "player": player, "animation": anim, "library": lib}


## Where the body puts the hands at `time` of the source animation: the baker's step, by hand.
func _ik_hands_at(rig: Dictionary, time: float) -> Array:
	var skel: Skeleton3D = rig["skeleton"]
	var body: IKBody = rig["body"]
	var player: AnimationPlayer = rig["player"]
	player.assigned_animation = &"move"
	player.seek(time, true)
	var bones := body.get_body_bones()
	var incoming := []
	for b in bones:
		incoming.append(skel.get_bone_pose_rotation(b))
	body.solve_now()
	var out := [skel.get_bone_global_pose(skel.find_bone("LeftHand")).origin,
			skel.get_bone_global_pose(skel.find_bone("RightHand")).origin, body.is_last_usable()]
	for k in bones.size():
		skel.set_bone_pose_rotation(bones[k], incoming[k])
	return out


# A 2 s animation whose left-hand target moves (and whose spine is animated): the baked animation,
# played back with the body off, puts the hands where the body put them (1e-4 m) at every frame;
# the bones the body does not solve keep their source tracks.
func test_bake_plays_back_what_the_body_did() -> void:
	var rig := _bake_rig(2.0)
	var skel: Skeleton3D = rig["skeleton"]
	var body: IKBody = rig["body"]
	var player: AnimationPlayer = rig["player"]
	var fps := 30.0
	var baked: Animation = Baker.bake(body, player, &"move", fps)
	if not check(baked != null, "bake returned an Animation"):
		return
	check_near(baked.length, 2.0, 1e-6, "the baked animation is as long as the source")
	var bones := body.get_body_bones()
	for b in bones:
		var track := baked.find_track(NodePath("Skeleton:" + skel.get_bone_name(b)), Animation.TYPE_ROTATION_3D)
		if check(track >= 0, "a rotation track for " + skel.get_bone_name(b)):
			check_eq(baked.track_get_key_count(track), 61, skel.get_bone_name(b) + ": a key per frame (2 s at 30 fps)")
	check(baked.find_track(NodePath("Skeleton:LeftUpperLeg"), Animation.TYPE_ROTATION_3D) >= 0,
			"the thigh's source track is kept (the body does not solve it)")
	check(baked.find_track(NodePath("LH"), Animation.TYPE_POSITION_3D) >= 0, "the target's track is kept")
	check(not player.is_playing(), "the player is left stopped, as it was found")

	# Where the body put the hands, frame by frame (deterministic: the same solve again).
	var expected := []
	for f in 61:
		expected.append(_ik_hands_at(rig, f / fps))
	# Played back without the body.
	body.active = false
	rig["library"].add_animation(&"move_baked", baked)
	player.assigned_animation = &"move_baked"
	var worst := 0.0
	for f in 61:
		player.seek(f / fps, true)
		var lh := skel.get_bone_global_pose(skel.find_bone("LeftHand")).origin
		var rh := skel.get_bone_global_pose(skel.find_bone("RightHand")).origin
		check(expected[f][2], "frame %d: the body's solve was usable" % f)
		worst = maxf(worst, maxf(lh.distance_to(expected[f][0]), rh.distance_to(expected[f][1])))
	print("  bake: worst playback distance from the body's hands %.3f um over 61 frames" % (worst * 1e6))
	check_le(worst, 1e-4, "the baked animation puts the hands where the body put them (m)")
	# And the body reached the moving target.
	var lt: Node3D = case_root.get_node("LH")
	player.assigned_animation = &"move"
	player.seek(1.0, true)
	player.assigned_animation = &"move_baked"
	player.seek(1.0, true)
	check_le(skel.get_bone_global_pose(skel.find_bone("LeftHand")).origin.distance_to(lt.global_position),
			body.tolerance + FLOAT_SLACK, "at 1 s the baked hand sits on the moving target (m)")


# Frames baked per second on the humanoid (printed, not asserted: timing depends on the machine).
func test_bake_throughput_is_printed() -> void:
	var rig := _bake_rig(10.0)
	var fps := 120.0
	var start := Time.get_ticks_usec()
	var baked: Animation = Baker.bake(rig["body"], rig["player"], &"move", fps)
	var seconds := (Time.get_ticks_usec() - start) * 1e-6
	if not check(baked != null, "bake returned an Animation"):
		return
	var frames := int(10.0 * fps) + 1
	print("  bake: %d frames in %.3f s = %.0f frames per second (target >= 1000)" % [frames, seconds,
			frames / maxf(seconds, 1e-9)])
	check_eq(baked.track_get_key_count(baked.find_track(NodePath("Skeleton:LeftHand"), Animation.TYPE_ROTATION_3D)),
			frames, "every frame keyed")


func test_bake_floating_root_records_the_root_position() -> void:
	var rig := _bake_rig(1.0)
	var body: IKBody = rig["body"]
	body.floating_root = true
	var baked: Animation = Baker.bake(body, rig["player"], &"move", 20.0)
	if not check(baked != null, "bake returned an Animation"):
		return
	var track := baked.find_track(NodePath("Skeleton:Hips"), Animation.TYPE_POSITION_3D)
	if check(track >= 0, "a position track for the floating root"):
		check_eq(baked.track_get_key_count(track), 21, "a root position key per frame")


func test_bake_bad_inputs_return_null_with_the_fix() -> void:
	var rig := _bake_rig(1.0)
	var body: IKBody = rig["body"]
	var player: AnimationPlayer = rig["player"]
	expect_error("body is not an IKBody in the scene tree", 1)
	check(Baker.bake(null, player, &"move", 30.0) == null, "no body: null")
	expect_error("player is not an AnimationPlayer", 1)
	check(Baker.bake(body, null, &"move", 30.0) == null, "no player: null")
	expect_error("the player has no animation 'nope'", 1)
	check(Baker.bake(body, player, &"nope", 30.0) == null, "missing animation: null")
	expect_error("fps must be in \\(0, 1000\\], got 0", 1)
	check(Baker.bake(body, player, &"move", 0.0) == null, "fps 0: null")
	expect_error("fps must be in \\(0, 1000\\], got nan", 1)
	check(Baker.bake(body, player, &"move", NAN) == null, "fps NaN: null")
	body.root_bone = ""
	expect_error("the body is not configured", 1)
	check(Baker.bake(body, player, &"move", 30.0) == null, "unconfigured body: null")


func test_bake_inspector_action_compiles() -> void:
	var Inspector: GDScript = load("res://addons/ikchain/ik_body_inspector.gd")
	if not check(Inspector != null, "ik_body_inspector.gd compiles"):
		return
	var constants := Inspector.get_script_constant_map()
	check_eq(constants.get("BAKE_TEXT"), "Bake animation...", "the bake button's text")
	# The dialog lists every (player, animation) of the scene.
	var rig := _bake_rig(1.0)
	var found: Array = Inspector.animations_in(case_root)
	check_eq(found.size(), 1, "one animation in the scene")
	if found.size() == 1:
		check(found[0][0] == rig["player"] and found[0][1] == &"move", "the player and its animation")
	check_eq(Inspector.animations_in(null).size(), 0, "no scene: nothing")


# ------------------------------------------------------------------ foot placement

const FootPlacement := preload("res://addons/ikchain/ik_foot_placement.gd")


## A box of `size` whose top face's centre is at `top_center`, tilted by `tilt` (the top's normal
## is tilt * up).
func _ground(name: String, top_center: Vector3, size: Vector3, tilt := Basis()) -> StaticBody3D:
	var body := StaticBody3D.new()
	body.name = name
	var shape := CollisionShape3D.new()
	var box := BoxShape3D.new()
	box.size = size
	shape.shape = box
	body.add_child(shape)
	body.transform = Transform3D(tilt, top_center - tilt * Vector3(0, size.y * 0.5, 0))
	case_root.add_child(body)
	return body


## A humanoid with the set-up body (floating root, hips and feet at level 1) and an
## IKFootPlacement driven by hand (enabled off; the test calls place()).
func _foot_rig() -> Dictionary:
	var body := Body.set_up_humanoid(case_root)
	var skel := body.get_parent() as Skeleton3D
	body.max_iterations = 300
	# Only the feet and the hips: the hands and the head follow the animation.
	var kept: Array[IKBodyEffector] = []
	for e in body.effectors:
		if e.bone_name in ["Hips", "LeftFoot", "RightFoot"]:
			kept.append(e)
	body.effectors = kept
	var feet: Node = FootPlacement.new()
	feet.enabled = false
	body.add_child(feet)
	return {"skeleton": skel, "body": body, "feet": feet}


## place() `frames` times at 60 Hz, then the pose the body makes of it.
func _settle(rig: Dictionary, frames: int) -> Dictionary:
	for i in frames:
		check(rig["feet"].place(1.0 / 60.0), "place() ran")
	return await _capture(rig["skeleton"], rig["body"])


func _foot_error(skel: Skeleton3D, cap: Dictionary, bone: String, rest_height: float, plane_point: Vector3,
		normal: Vector3) -> Dictionary:
	var g: Transform3D = cap["globals"][skel.find_bone(bone)]
	var rest_up_local := skel.get_bone_global_pose(skel.find_bone(bone)).basis.inverse() * Vector3.UP
	return {
		"height": absf((g.origin - plane_point).dot(normal) - rest_height),
		"tilt": (g.basis * rest_up_local).normalized().angle_to(normal),
	}


# A 20-degree slope across the feet: each foot sits on the surface (its ankle the rest height above
# it, along the normal, within 5 mm), its up axis along the normal within 2 degrees; the hips drop.
func test_foot_placement_on_a_slope() -> void:
	var rig := _foot_rig()
	var skel: Skeleton3D = rig["skeleton"]
	var tilt := Basis(Vector3(0, 0, 1), 20 * DEG)
	var normal := tilt * Vector3.UP
	_ground("Slope", Vector3.ZERO, Vector3(4, 0.2, 4), tilt)
	await physics_frame
	await physics_frame
	var rest_hips := skel.get_bone_global_pose(skel.find_bone("Hips")).origin
	var rest_height := skel.get_bone_global_pose(skel.find_bone("LeftFoot")).origin.y
	var cap := await _settle(rig, 120)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	check(rig["body"].is_last_usable(), "the body solved: " + rig["body"].get_last_reason())
	for bone in ["LeftFoot", "RightFoot"]:
		var err := _foot_error(skel, cap, bone, rest_height, Vector3.ZERO, normal)
		print("  slope: %s %.2f mm off the surface, up axis %.2f deg off the normal" % [bone, err["height"] * 1e3,
				err["tilt"] / DEG])
		check_le(err["height"], 0.005, bone + " on the slope (m)")
		check_le(err["tilt"], 2 * DEG, bone + " up axis along the normal (rad)")
	var hips := (cap["globals"][skel.find_bone("Hips")] as Transform3D).origin
	check(hips.y < rest_hips.y - 0.01, "the hips lowered so the lower foot reaches (%.3f m)" % (rest_hips.y - hips.y))


# A step down under the left foot (15 cm): both feet on their ground within 5 mm, flat, the hips
# lowered; the change from flat ground to the step is spread over frames (bounded per frame).
func test_foot_placement_on_a_step_without_pops() -> void:
	var rig := _foot_rig()
	var skel: Skeleton3D = rig["skeleton"]
	var feet: Node = rig["feet"]
	var body: IKBody = rig["body"]
	var rest_hips := skel.get_bone_global_pose(skel.find_bone("Hips")).origin
	var rest_height := skel.get_bone_global_pose(skel.find_bone("LeftFoot")).origin.y
	var left_x := skel.get_bone_global_pose(skel.find_bone("LeftFoot")).origin.x
	var upper := _ground("Upper", Vector3(-1.0 + left_x * 0.5, 0, 0), Vector3(2.0, 0.2, 2))  # ends between the feet
	var flat := _ground("Flat", Vector3(left_x, 0, 0), Vector3(0.4, 0.2, 2))  # under the left foot, at 0
	_ground("Lower", Vector3(1.0 + left_x * 0.5, -0.15, 0), Vector3(2.0, 0.2, 2))
	await physics_frame
	await physics_frame
	var cap := await _settle(rig, 30)
	check_near(feet.get_foot_offset(0), 0.0, 1e-4, "on flat ground the left foot's offset is 0 (m)")
	# The flat patch goes: the left foot is now over the lower ground, 15 cm down.
	flat.get_parent().remove_child(flat)
	flat.free()
	await physics_frame
	await physics_frame
	# From here the node drives itself, a physics frame at a time, and the body solves in between
	# (so the incoming pose it reads is the animation's, not its own last output).
	var dt := 1.0 / Engine.physics_ticks_per_second
	var bound: float = feet.max_height_speed * dt + 1e-6
	var previous_foot := (body.effectors[1] as IKBodyEffector).target_transform.origin
	var previous_hips := (body.effectors[0] as IKBodyEffector).target_transform.origin
	var worst_foot := 0.0
	var worst_hips := 0.0
	var frames_to_arrive := -1
	feet.enabled = true
	for i in 90:
		await physics_frame
		var foot := (body.effectors[1] as IKBodyEffector).target_transform.origin
		var hips_t := (body.effectors[0] as IKBodyEffector).target_transform.origin
		worst_foot = maxf(worst_foot, foot.distance_to(previous_foot))
		worst_hips = maxf(worst_hips, hips_t.distance_to(previous_hips))
		previous_foot = foot
		previous_hips = hips_t
		if frames_to_arrive < 0 and absf(feet.get_foot_offset(0) + 0.15) < 1e-3:
			frames_to_arrive = i + 1
	feet.enabled = false
	print("  step: worst per-frame move: foot target %.1f mm, hips target %.1f mm (bound %.1f mm); on the step "
			% [worst_foot * 1e3, worst_hips * 1e3, bound * 1e3] + "after %d frames" % frames_to_arrive)
	check_le(worst_foot, bound, "the foot target moves at most max_height_speed per frame (m)")
	check_le(worst_hips, bound, "the hips target moves at most max_height_speed per frame (m)")
	check(frames_to_arrive >= 6, "the 15 cm step is spread over frames (%d)" % frames_to_arrive)
	check(frames_to_arrive > 0 and frames_to_arrive <= 60, "and arrives within 60 frames (%d)" % frames_to_arrive)
	cap = await _capture(skel, body)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	var left := _foot_error(skel, cap, "LeftFoot", rest_height, Vector3(0, -0.15, 0), Vector3.UP)
	var right := _foot_error(skel, cap, "RightFoot", rest_height, Vector3.ZERO, Vector3.UP)
	check_le(left["height"], 0.005, "the left foot on the lower step (m)")
	check_le(right["height"], 0.005, "the right foot on the upper ground (m)")
	check_le(left["tilt"], 2 * DEG, "the left foot flat (rad)")
	check_le(right["tilt"], 2 * DEG, "the right foot flat (rad)")
	var hips := (cap["globals"][skel.find_bone("Hips")] as Transform3D).origin
	check(hips.y < rest_hips.y - 0.1, "the hips lowered on the step (%.3f m)" % (rest_hips.y - hips.y))
	check(upper != null, "fixture")


# A foot the animation lifts (the thigh swung forward) over a 10 cm box: its target stays lifted by
# the animated height over the box's top, straight above where the animation has it.
func test_foot_placement_keeps_an_animated_lift() -> void:
	var rig := _foot_rig()
	var skel: Skeleton3D = rig["skeleton"]
	var thigh := skel.find_bone("LeftUpperLeg")
	skel.set_bone_pose_rotation(thigh, skel.get_bone_rest(thigh).basis.get_rotation_quaternion()
			* Quaternion(Vector3.RIGHT, 0.5))
	var animated := skel.get_bone_global_pose(skel.find_bone("LeftFoot")).origin
	check(animated.y > 0.05, "the animation lifts the foot (%.3f m)" % animated.y)
	_ground("Box", Vector3(animated.x, 0.1, animated.z), Vector3(0.5, 0.2, 0.5))
	await physics_frame
	await physics_frame
	rig["feet"].place(1.0 / 60.0)
	var target := (rig["body"].effectors[1] as IKBodyEffector).target_transform
	check_near(target.origin.y, 0.1 + animated.y, 1e-4, "lifted by the animated height over the box (m)")
	check_near(Vector2(target.origin.x, target.origin.z).distance_to(Vector2(animated.x, animated.z)), 0.0, 1e-4,
			"straight above the animated foot (m)")


# No ground under the feet (the rays hit nothing): the feet and the hips follow the animation.
func test_foot_placement_without_ground_follows_the_animation() -> void:
	var rig := _foot_rig()
	var skel: Skeleton3D = rig["skeleton"]
	await physics_frame
	var rest := {}
	for bone in ["Hips", "LeftFoot", "RightFoot"]:
		rest[bone] = skel.get_bone_global_pose(skel.find_bone(bone)).origin
	var cap := await _settle(rig, 10)
	if not check(not cap.is_empty(), "skeleton_updated came"):
		return
	check_near(rig["feet"].get_foot_offset(0), 0.0, 0.0, "no hit: no offset")
	check_near(rig["feet"].get_hips_offset(), 0.0, 0.0, "no hit: the hips stay")
	for bone in rest:
		check_le((cap["globals"][skel.find_bone(bone)] as Transform3D).origin.distance_to(rest[bone]), 1e-3,
				bone + " where the animation has it (m)")


func test_foot_placement_warnings_name_the_fix() -> void:
	var rig := _foot_rig()
	var feet: Node = rig["feet"]
	var body: IKBody = rig["body"]
	check_eq(feet._get_configuration_warnings().size(), 0, "the set-up body: no warning")
	feet.feet = PackedStringArray(["LeftFoot", "LeftToes"])
	check(" ".join(feet._get_configuration_warnings()).contains("no effector of the IKBody has bone 'LeftToes'"),
			"a foot without an effector is named")
	feet.feet = PackedStringArray(["LeftFoot", "RightFoot"])
	body.floating_root = false
	check(" ".join(feet._get_configuration_warnings()).contains("floating_root is off"),
			"the hips need a floating root")
	body.floating_root = true
	feet.feet = PackedStringArray(["LeftFoot", "LeftToes"])
	expect_error("no effector of the IKBody has bone 'LeftToes'.*Foot placement is off", 1)
	check(not feet.place(1.0 / 60.0), "place() with a missing foot effector does nothing")
	check(not feet.place(1.0 / 60.0), "and says so once")
	var orphan: Node = FootPlacement.new()
	case_root.add_child(orphan)
	check(" ".join(orphan._get_configuration_warnings()).contains("the parent is not an IKBody"), "outside an IKBody")
	check(not orphan.place(1.0 / 60.0), "place() outside an IKBody does nothing")
