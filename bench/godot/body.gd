extends "res://bench/common.gd"
## The full body in Godot: IKBody (setup_humanoid()) on a humanoid built from
## SkeletonProfileHumanoid's reference pose, targets on hips, hands, feet and head moving smoothly,
## next to a stack of IKChain nodes and Godot's FABRIK3D on the same skeleton and targets. Run by
## tools/bench_godot.py (--body); the method is in docs/benchmarks.md ("Full body in Godot").
##
##   godot --headless --path <proj> --script res://bench/body.gd -- --mode=MODE --out=FILE
##
## Modes:
##   cost       under callgrind, as bench.gd's cost mode (READY, --ack, one symlink() per phase
##              boundary): per system, F frames with the modifiers active, then F inactive
##   walltime   --characters=K characters, alternating active / inactive blocks, main-thread CPU time
##   stability  --characters=K IKBody characters for --frames=F frames: effector errors, knee/elbow
##              flips, pops, and a SHA-256 of every solved bone's pose per frame (--deterministic=1)
##   replay     --clip=FILE (tools/bvh_replay.py's JSON of a CMU clip): one IKBody character replays
##              the recording's effector goals; success, flips, pops against the recording, SHA-256

const EFFECTORS := ["Hips", "LeftHand", "RightHand", "LeftFoot", "RightFoot", "Head"]
## The stack and FABRIK3D's settings: legs from the hip, arms from the collar, spine to head.
const LIMBS := [
	["LeftUpperLeg", "LeftFoot"], ["RightUpperLeg", "RightFoot"],
	["LeftShoulder", "LeftHand"], ["RightShoulder", "RightHand"], ["Spine", "Head"],
]
## Knees and elbows: [upper bone, hinge bone, end bone].
const HINGES := [
	["LeftUpperLeg", "LeftLowerLeg", "LeftFoot"], ["RightUpperLeg", "RightLowerLeg", "RightFoot"],
	["LeftUpperArm", "LeftLowerArm", "LeftHand"], ["RightUpperArm", "RightLowerArm", "RightHand"],
]
const CYCLE := 120  # frames per motion cycle (2 s at 60 fps)
const POP_M := 0.05
## A target moving more than this between two recorded frames is a cut in the recording, not
## motion (CMU's clips start with a calibration T-pose: 01_01's hands jump 0.55-0.64 m into frame
## 1). Such frame pairs are not scored for pops; the replay reports how many there were.
const CUT_M := 0.25

var _rigs: Array = []


func _run(mode: String) -> Variant:
	match mode:
		"cost":
			return await _cost()
		"walltime":
			return await _walltime()
		"stability":
			return await _stability()
		"replay":
			return await _replay()
	return null


# ------------------------------------------------------------------ the character

## SkeletonProfileHumanoid's 56 bones, rests = its reference pose (a T-pose, 1.7 m or so).
static func make_humanoid() -> Skeleton3D:
	var prof := SkeletonProfileHumanoid.new()
	var skel := Skeleton3D.new()
	skel.name = "S"
	for i in prof.bone_size:
		skel.add_bone(prof.get_bone_name(i))
	for i in prof.bone_size:
		var parent := prof.get_bone_parent(i)
		if parent != StringName():
			skel.set_bone_parent(i, skel.find_bone(parent))
		skel.set_bone_rest(i, prof.get_reference_pose(i))
	skel.reset_bone_poses()
	return skel


## Per frame k of character c: the effector targets in skeleton space (the rig and skeleton sit at
## the origin). Hips lowered 6-9 cm and swaying, feet lifting 4 cm in turn, hands brought in front
## of the body on circles of 8 cm, head turning +-25 deg and nodding 10 deg: every target reachable.
static func targets_at(rest: Dictionary, c: int, k: int) -> Dictionary:
	var w := TAU * float(k) / CYCLE + 0.37 * c
	var out := {}
	var hips: Transform3D = rest["Hips"]
	var hips_offset := Vector3(0.02 * sin(w), -0.075 - 0.015 * sin(2.0 * w), 0.02 * cos(w))
	out["Hips"] = Transform3D(hips.basis.rotated(Vector3.UP, deg_to_rad(5.0) * sin(w)), hips.origin + hips_offset)
	for side in ["Left", "Right"]:
		var foot: Transform3D = rest[side + "Foot"]
		var lift := 0.04 * maxf(0.0, sin(w) if side == "Left" else -sin(w))
		out[side + "Foot"] = Transform3D(foot.basis, foot.origin + Vector3(0, lift, 0))
		var hand: Transform3D = rest[side + "Hand"]
		var inward := -signf(hand.origin.x)
		out[side + "Hand"] = Transform3D(hand.basis, hand.origin + Vector3(
				inward * 0.25, -0.25 + 0.08 * sin(w + 1.0), 0.2 + 0.08 * cos(w + 1.0)))
	var head: Transform3D = rest["Head"]
	var turn := Basis(Vector3.UP, deg_to_rad(25.0) * sin(0.5 * w)) * Basis(Vector3.RIGHT, deg_to_rad(10.0) * cos(w))
	out["Head"] = Transform3D(turn * head.basis, head.origin + hips_offset + Vector3(0.03 * sin(w), 0, 0.03 * cos(w)))
	return out


## The modifier(s) of one system under `skel`; targets are the rig's children "T_<bone>".
static func make_system(system: String, skel: Skeleton3D) -> Array:
	var mods := []
	match system:
		"IKBody", "IKBody_deterministic":
			var body := IKBody.new()
			skel.add_child(body)
			body.setup_humanoid()
			body.deterministic = system == "IKBody_deterministic"
			for e in body.effectors:
				e.target = body.get_path_to(skel.get_parent().get_node("T_" + e.bone_name))
			mods.append(body)
		"IKChain_stack":
			for limb in LIMBS:
				var ik := IKChain.new()
				skel.add_child(ik)
				ik.root_bone = limb[0]
				ik.tip_bone = limb[1]
				ik.target = ik.get_path_to(skel.get_parent().get_node("T_" + limb[1]))
				mods.append(ik)
		"FABRIK3D_default", "FABRIK3D_converge":
			var g := FABRIK3D.new()
			skel.add_child(g)
			g.setting_count = LIMBS.size()
			for i in LIMBS.size():
				g.set("settings/%d/root_bone_name" % i, LIMBS[i][0])
				g.set("settings/%d/end_bone_name" % i, LIMBS[i][1])
				g.set("settings/%d/target_node" % i, g.get_path_to(skel.get_parent().get_node("T_" + LIMBS[i][1])))
			if system == "FABRIK3D_converge":
				g.max_iterations = 64
				g.angular_delta_limit = PI
			mods.append(g)
	return mods


## K characters "R<c>" = { S (Skeleton3D) - modifiers, T_<bone> targets }.
func build(system: String, characters: int) -> Node3D:
	var root_node := Node3D.new()
	root_node.name = "Bench"
	_rigs.clear()
	for c in characters:
		var rig := Node3D.new()
		rig.name = "R%d" % c
		var skel := make_humanoid()
		rig.add_child(skel)
		var rest := {}
		for b in EFFECTORS:
			rest[b] = skel.get_bone_global_rest(skel.find_bone(b))
			var t := Node3D.new()
			t.name = "T_" + b
			rig.add_child(t)
		var mods := make_system(system, skel)
		root_node.add_child(rig)
		_rigs.append({"skel": skel, "mods": mods, "rest": rest, "c": c,
				"hips": skel.find_bone("Hips"), "hips_rest": skel.get_bone_rest(skel.find_bone("Hips")).origin,
				"moves_hips": not system.begins_with("IKBody")})
	return root_node


## Targets to frame k. The stack and FABRIK3D cannot move the hips: for them the script puts the
## hips where the hips target is, as an animation would (the same work in active and inactive
## phases, so it cancels in the cost).
func move(k: int) -> void:
	for r in _rigs:
		var t := targets_at(r["rest"], r["c"], k)
		var rig: Node3D = r["skel"].get_parent()
		for b in EFFECTORS:
			(rig.get_node("T_" + b) as Node3D).transform = t[b]
		if r["moves_hips"]:
			var hips_target: Transform3D = t["Hips"]
			r["skel"].set_bone_pose_position(r["hips"], r["hips_rest"] + hips_target.origin - r["rest"]["Hips"].origin)


func set_active(on: bool) -> void:
	for r in _rigs:
		for m in r["mods"]:
			m.active = on


static func systems_list(arg: String) -> PackedStringArray:
	return arg.split(",")


# ------------------------------------------------------------------ cost (callgrind)

func _cost() -> Dictionary:
	var characters := int(_args.get("characters", "10"))
	var frames := int(_args.get("frames", "10"))
	var systems := systems_list(_args.get("systems", "IKBody,IKChain_stack,FABRIK3D_default,FABRIK3D_converge"))
	wait_for_instrumentation()
	var phases := []
	for system in systems:
		var scene := build(system, characters)
		root.add_child(scene)
		var k := 0
		for phase in ["active", "inactive"]:
			set_active(phase == "active")
			for w in 5:  # warm-up: builds, first solves, warm start settles
				k += 1
				move(k)
				await process_frame
			marker("warmup")
			var iterations := 0
			for f in frames:
				k += 1
				move(k)
				await process_frame
				# The same calls in both phases (they cancel); in the inactive one they read the last
				# active frame's count.
				for r in _rigs:
					if r["mods"][0] is IKBody:
						iterations += (r["mods"][0] as IKBody).get_last_iterations()
			var label := "%s|%s" % [system, phase]
			marker(label)
			phases.append({"label": label, "system": system, "phase": phase, "characters": characters,
					"frames": frames, "iterations": iterations})
		scene.queue_free()
		await process_frame
		marker("teardown")
	return {"markers": _markers, "phases": phases}


# ------------------------------------------------------------------ wall time

static func _median(values: Array) -> float:
	var v := values.duplicate()
	v.sort()
	return v[v.size() / 2] if not v.is_empty() else NAN


func _walltime() -> Dictionary:
	var characters := int(_args.get("characters", "500"))
	var blocks := int(_args.get("blocks", "6"))
	var block_frames := int(_args.get("block_frames", "8"))
	var systems := systems_list(_args.get("systems", "IKBody,IKChain_stack,FABRIK3D_converge"))
	var records := []
	for system in systems:
		var scene := build(system, characters)
		root.add_child(scene)
		var k := 0
		for w in 5:
			k += 1
			move(k)
			await process_frame
		var cpu_diffs := []
		var wall_diffs := []
		for blk in blocks:
			var cpu := {}
			var wall := {}
			for on in [true, false]:
				set_active(on)
				for w in 2:
					k += 1
					move(k)
					await process_frame
				var c0 := _cpu_usec()
				var t0 := Time.get_ticks_usec()
				for f in block_frames:
					k += 1
					move(k)
					await process_frame
				cpu[on] = (_cpu_usec() - c0) / block_frames
				wall[on] = float(Time.get_ticks_usec() - t0) / block_frames
			cpu_diffs.append(cpu[true] - cpu[false])
			wall_diffs.append(wall[true] - wall[false])
		scene.queue_free()
		await process_frame
		var rec := {"system": system, "characters": characters, "frames_each": blocks * block_frames,
				"cpu_ms_per_frame": _median(cpu_diffs) / 1000.0,
				"wall_ms_per_frame": _median(wall_diffs) / 1000.0,
				"cpu_ms_per_100_characters": _median(cpu_diffs) / 1000.0 * 100.0 / characters,
				"block_cpu_differences_ms": cpu_diffs.map(func(d): return d / 1000.0)}
		print("[GBENCH] body walltime %s: %d characters, %.2f ms CPU per frame (%.3f ms per 100)" % [
				system, characters, rec["cpu_ms_per_frame"], rec["cpu_ms_per_100_characters"]])
		records.append(rec)
	return {"records": records}


# ------------------------------------------------------------------ stability

var _frame := 0
var _seen := PackedInt32Array()
var _samples := []  # per character: per frame {bones: PackedVector3Array, ...}
var _hash := HashingContext.new()
var _solved: PackedInt32Array
var _watch: Array  # bone indices recorded per frame: solved bones + effectors
var _eff_errors := {}  # effector -> Array of position errors (m)
var _rot_errors := {}  # effector -> Array of rotation errors (rad)
var _level1_frames := 0
var _success := 0
var _level1_met := 0


func _on_updated(c: int) -> void:
	if _seen[c] > 0:
		_seen[c] += 1
		return
	_seen[c] += 1
	var r: Dictionary = _rigs[c]
	var skel: Skeleton3D = r["skel"]
	var body: IKBody = r["mods"][0]
	var t := targets_at(r["rest"], c, _frame)
	var pts := PackedVector3Array()
	var bytes := PackedByteArray()
	for b in _watch:
		var g := skel.get_bone_global_pose(b)
		pts.append(g.origin)
	for b in _solved:
		var pose := PackedFloat32Array()
		var q := skel.get_bone_pose_rotation(b)
		var p := skel.get_bone_pose_position(b)
		pose.append_array([q.x, q.y, q.z, q.w, p.x, p.y, p.z])
		bytes.append_array(pose.to_byte_array())
	_hash.update(bytes)
	var ok := true
	for name in EFFECTORS:
		var g := skel.get_bone_global_pose(skel.find_bone(name))
		var tg: Transform3D = t[name]
		if name != "Head":
			var ep := g.origin.distance_to(tg.origin)
			_eff_errors[name].append(ep)
			ok = ok and ep <= 1e-3
		if name in ["LeftFoot", "RightFoot", "Head", "Hips"]:
			var dq := (Quaternion(g.basis.orthonormalized()).inverse() * Quaternion(tg.basis.orthonormalized())).normalized()
			var er := 2.0 * atan2(Vector3(dq.x, dq.y, dq.z).length(), absf(dq.w))
			_rot_errors[name].append(er)
			ok = ok and er <= deg_to_rad(1.0)
	if ok:
		_success += 1
	_level1_frames += 1
	if body.is_last_level_met(1):
		_level1_met += 1
	_samples[c].append(pts)


func _stability() -> Dictionary:
	var characters := int(_args.get("characters", "10"))
	var frames := int(_args.get("frames", "240"))
	var system := "IKBody_deterministic" if _args.get("deterministic", "0") == "1" else "IKBody"
	var scene := build(system, characters)
	set_active(false)
	root.add_child(scene)
	await process_frame
	await process_frame
	var skel0: Skeleton3D = _rigs[0]["skel"]
	_solved = (_rigs[0]["mods"][0] as IKBody).get_body_bones()
	_watch = Array(_solved)
	for h in HINGES:
		for b in h:
			if not _watch.has(skel0.find_bone(b)):
				_watch.append(skel0.find_bone(b))
	for name in EFFECTORS:
		_eff_errors[name] = []
		_rot_errors[name] = []
	_hash.start(HashingContext.HASH_SHA256)
	_samples.clear()
	_seen.resize(characters)
	for c in characters:
		_samples.append([])
		_rigs[c]["skel"].skeleton_updated.connect(_on_updated.bind(c))
	set_active(true)
	var missing := 0
	for k in frames:
		_frame = k
		_seen.fill(0)
		move(k)
		await process_frame
		for c in characters:
			if _seen[c] == 0:
				missing += 1
				_samples[c].append(null)
	var digest := _hash.finish().hex_encode()
	# Flips: a knee or elbow whose bend plane's normal (upper x lower bone) turns by more than 90
	# degrees between two frames while bent by more than 5 degrees in both.
	var flips := 0
	var bent_frames := 0
	var pops := 0
	var worst_pop := 0.0
	var pairs := 0
	var wi := {}
	for i in _watch.size():
		wi[_watch[i]] = i
	for c in characters:
		var rest: Dictionary = _rigs[c]["rest"]
		var prev_normal := []
		for h in HINGES:
			prev_normal.append(Vector3.ZERO)
		for k in frames:
			var pts = _samples[c][k]
			if pts == null:
				continue
			for hi in HINGES.size():
				var a: Vector3 = pts[wi[skel0.find_bone(HINGES[hi][0])]]
				var b: Vector3 = pts[wi[skel0.find_bone(HINGES[hi][1])]]
				var e: Vector3 = pts[wi[skel0.find_bone(HINGES[hi][2])]]
				var u := (b - a).normalized()
				var l := (e - b).normalized()
				var n := u.cross(l)
				if n.length() > sin(deg_to_rad(5.0)):
					bent_frames += 1
					if prev_normal[hi] != Vector3.ZERO and n.normalized().dot(prev_normal[hi]) < 0.0:
						flips += 1
					prev_normal[hi] = n.normalized()
			if k == 0 or _samples[c][k - 1] == null:
				continue
			# Pop: a bone moving >= 5 cm more than the fastest target moved in this frame.
			var t0 := targets_at(rest, c, k - 1)
			var t1 := targets_at(rest, c, k)
			var target_move := 0.0
			for name in EFFECTORS:
				target_move = maxf(target_move, (t1[name] as Transform3D).origin.distance_to((t0[name] as Transform3D).origin))
			var prev = _samples[c][k - 1]
			var frame_excess := 0.0
			for i in pts.size():
				frame_excess = maxf(frame_excess, (pts[i] as Vector3).distance_to(prev[i]) - target_move)
			pairs += 1
			worst_pop = maxf(worst_pop, frame_excess)
			if frame_excess >= POP_M:
				pops += 1
	var summary := {}
	for name in EFFECTORS:
		var e: Array = _eff_errors[name]
		if not e.is_empty():
			e.sort()
			summary[name + "_position_m"] = {"median": e[e.size() / 2], "max": e[-1]}
		var r: Array = _rot_errors[name]
		if not r.is_empty():
			r.sort()
			summary[name + "_rotation_deg"] = {"median": rad_to_deg(r[r.size() / 2]), "max": rad_to_deg(r[-1])}
	scene.queue_free()
	await process_frame
	var rec := {"system": system, "characters": characters, "frames": frames, "missing_updates": missing,
			"solved_bones": _solved.size(), "sha256_solved_poses": digest,
			"knee_elbow_flips": flips, "bent_hinge_frames": bent_frames,
			"pop_frames": pops, "frame_pairs": pairs, "pop_share": float(pops) / maxi(1, pairs),
			"worst_excess_move_m": worst_pop, "level1_met_share": float(_level1_met) / maxi(1, _level1_frames),
			"success_share_1mm_1deg": float(_success) / maxi(1, _level1_frames),
			"effector_errors": summary}
	print("[GBENCH] body stability %s: flips %d, pops %d / %d (worst %.4f m), level 1 met %.3f, all within 1 mm and 1 deg %.3f, sha %s" % [
			system, flips, pops, pairs, worst_pop, rec["level1_met_share"], rec["success_share_1mm_1deg"], digest.substr(0, 16)])
	return rec


# ------------------------------------------------------------------ CMU clip replay

func _replay() -> Dictionary:
	var clip: Dictionary = JSON.parse_string(FileAccess.get_file_as_string(_args["clip"]))
	var deterministic: bool = _args.get("deterministic", "0") == "1"
	var frames: int = mini(int(clip["frames"]), int(_args.get("frames", "1000000")))
	var rig := Node3D.new()
	rig.name = "R0"
	var skel := Skeleton3D.new()
	skel.name = "S"
	var bones: Array = clip["bones"]
	for b in bones:
		skel.add_bone(b["name"])
	for i in bones.size():
		var b: Dictionary = bones[i]
		if int(b["parent"]) >= 0:
			skel.set_bone_parent(i, int(b["parent"]))
		var q: Array = b["rotation"]
		var o: Array = b["origin"]
		skel.set_bone_rest(i, Transform3D(Basis(Quaternion(q[0], q[1], q[2], q[3])), Vector3(o[0], o[1], o[2])))
	skel.reset_bone_poses()
	rig.add_child(skel)
	for e in EFFECTORS:
		var t := Node3D.new()
		t.name = "T_" + e
		rig.add_child(t)
	var body := IKBody.new()
	skel.add_child(body)
	if not body.setup_humanoid():
		push_error("body.gd: setup_humanoid() failed on the clip's skeleton")
		return {}
	body.deterministic = deterministic
	for e in body.effectors:
		e.target = body.get_path_to(rig.get_node("T_" + e.bone_name))
	body.active = false
	root.add_child(rig)
	await process_frame
	_solved = body.get_body_bones()
	var hinge_bones := []
	for h in HINGES:
		hinge_bones.append([skel.find_bone(h[0]), skel.find_bone(h[1]), skel.find_bone(h[2])])
	var eff_bones := []
	for e in EFFECTORS:
		eff_bones.append(skel.find_bone(e))
	var state := {"pts": null, "seen": 0}
	var results := {"success": 0, "scored": 0, "missing": 0, "flips": 0, "bent": 0, "pops": 0, "pairs": 0, "cuts": 0,
			"worst": 0.0, "worst_frame": -1, "pop_list": [], "pos_err": [], "rot_err": [], "iterations": []}
	var prev_normal := [Vector3.ZERO, Vector3.ZERO, Vector3.ZERO, Vector3.ZERO]
	var prev_pts = null
	var hash := HashingContext.new()
	hash.start(HashingContext.HASH_SHA256)
	var targets: Array = clip["targets"]
	var recorded: Array = clip["joint_positions"]
	var on_update := func():
		state["seen"] += 1
		if state["seen"] > 1:
			return
		var pts := PackedVector3Array()
		for i in skel.get_bone_count():
			pts.append(skel.get_bone_global_pose(i).origin)
		state["pts"] = pts
		var bytes := PackedByteArray()
		for b in _solved:
			var q := skel.get_bone_pose_rotation(b)
			var p := skel.get_bone_pose_position(b)
			bytes.append_array(PackedFloat32Array([q.x, q.y, q.z, q.w, p.x, p.y, p.z]).to_byte_array())
		hash.update(bytes)
		state["iterations"] = body.get_last_iterations()
		state["poses"] = {}
		for k in EFFECTORS.size():
			state["poses"][EFFECTORS[k]] = skel.get_bone_global_pose(eff_bones[k])
	skel.skeleton_updated.connect(on_update)
	body.active = true
	for f in frames:
		var tf: Dictionary = targets[f]
		for e in EFFECTORS:
			var v: Array = tf[e]
			(rig.get_node("T_" + e) as Node3D).transform = Transform3D(
					Basis(Quaternion(v[3], v[4], v[5], v[6])), Vector3(v[0], v[1], v[2]))
		state["seen"] = 0
		await process_frame
		if state["seen"] == 0:
			results["missing"] += 1
			prev_pts = null
			continue
		results["iterations"].append(state["iterations"])
		# Success: hips, hands and feet within 1 mm, feet and head within 1 degree (the goals
		# setup_humanoid() gives them; the hips' rotation is a soft goal and is reported, not scored).
		var ok := true
		var worst_p := 0.0
		var worst_r := 0.0
		for e in EFFECTORS:
			var v: Array = tf[e]
			var g: Transform3D = state["poses"][e]
			if e != "Head":
				var ep := g.origin.distance_to(Vector3(v[0], v[1], v[2]))
				worst_p = maxf(worst_p, ep)
				ok = ok and ep <= 1e-3
			if e in ["LeftFoot", "RightFoot", "Head"]:
				var dq := (Quaternion(g.basis.orthonormalized()).inverse() * Quaternion(v[3], v[4], v[5], v[6])).normalized()
				var er := 2.0 * atan2(Vector3(dq.x, dq.y, dq.z).length(), absf(dq.w))
				worst_r = maxf(worst_r, er)
				ok = ok and er <= deg_to_rad(1.0)
		results["pos_err"].append(worst_p)
		results["rot_err"].append(rad_to_deg(worst_r))
		results["scored"] += 1
		if ok:
			results["success"] += 1
		var pts: PackedVector3Array = state["pts"]
		for hi in hinge_bones.size():
			var h: Array = hinge_bones[hi]
			var n := (pts[h[1]] - pts[h[0]]).normalized().cross((pts[h[2]] - pts[h[1]]).normalized())
			if n.length() > sin(deg_to_rad(5.0)):
				results["bent"] += 1
				if prev_normal[hi] != Vector3.ZERO and n.normalized().dot(prev_normal[hi]) < 0.0:
					results["flips"] += 1
				prev_normal[hi] = n.normalized()
		# Pops: a solved bone moving >= 5 cm more than the same joint in the recording, over
		# continuous motion (not across a cut in the recording).
		var cut := false
		if f > 0:
			var tp: Dictionary = targets[f - 1]
			for e in EFFECTORS:
				var a: Array = tp[e]
				var b: Array = tf[e]
				if Vector3(a[0], a[1], a[2]).distance_to(Vector3(b[0], b[1], b[2])) > CUT_M:
					cut = true
			if cut:
				results["cuts"] += 1
		if prev_pts != null and f > 0 and not cut:
			var r0: Array = recorded[f - 1]
			var r1: Array = recorded[f]
			var excess := 0.0
			var excess_bone := -1
			for b in _solved:
				var rec_move := Vector3(r1[3 * b], r1[3 * b + 1], r1[3 * b + 2]).distance_to(
						Vector3(r0[3 * b], r0[3 * b + 1], r0[3 * b + 2]))
				var bone_excess := pts[b].distance_to(prev_pts[b]) - rec_move
				if bone_excess > excess:
					excess = bone_excess
					excess_bone = b
			results["pairs"] += 1
			if excess > results["worst"]:
				results["worst"] = excess
				results["worst_frame"] = f
			if excess >= POP_M:
				results["pops"] += 1
				# Which bone popped on which frame, to find the cause (the first 50).
				if results["pop_list"].size() < 50:
					results["pop_list"].append({"frame": f, "bone": skel.get_bone_name(excess_bone), "excess_m": excess})
		prev_pts = pts
	var digest := hash.finish().hex_encode()
	rig.queue_free()
	await process_frame
	var pe: Array = results["pos_err"]
	var re: Array = results["rot_err"]
	var it: Array = results["iterations"]
	pe.sort()
	re.sort()
	it.sort()
	var rec := {"clip": str(clip["source"]).get_file().get_basename(), "system": "IKBody" + ("_deterministic" if deterministic else ""),
			"frames": frames, "scored_frames": results["scored"], "missing_updates": results["missing"],
			"solved_bones": _solved.size(),
			"success_rate_1mm_1deg": float(results["success"]) / maxi(1, results["scored"]),
			"worst_position_error_m": {"p50": pe[pe.size() / 2], "p99": pe[int(pe.size() * 0.99)], "max": pe[-1]},
			"worst_rotation_error_deg": {"p50": re[re.size() / 2], "p99": re[int(re.size() * 0.99)], "max": re[-1]},
			"median_iterations": it[it.size() / 2], "p99_iterations": it[int(it.size() * 0.99)],
			"knee_elbow_flips": results["flips"], "bent_hinge_frames": results["bent"],
			"pop_frames": results["pops"], "frame_pairs": results["pairs"], "recording_cuts": results["cuts"],
			"pop_share": float(results["pops"]) / maxi(1, results["pairs"]),
			"worst_excess_move_m": results["worst"], "worst_excess_frame": results["worst_frame"],
			"pops": results["pop_list"], "sha256_solved_poses": digest}
	print("[GBENCH] replay %s %s: success %.2f%%, flips %d, pops %d / %d (%d cuts in the recording skipped; worst %.4f m at frame %d), median it %d, sha %s" % [
			rec["clip"], rec["system"], 100.0 * rec["success_rate_1mm_1deg"], rec["knee_elbow_flips"], rec["pop_frames"],
			rec["frame_pairs"], rec["recording_cuts"], rec["worst_excess_move_m"], rec["worst_excess_frame"], rec["median_iterations"], digest.substr(0, 16)])
	return rec
