extends "res://bench/common.gd"
## IKChain next to Godot 4.6's own IK nodes, in one headless Godot process. Run by
## tools/bench_godot.py (scripts/bench), which copies this directory into a throw-away project;
## the method is in docs/benchmarks.md ("IKChain vs Godot's built-in IK").
##
##   godot --headless --path <proj> --script res://bench/bench.gd -- --mode=MODE --out=FILE [--quick]
##
## Modes:
##   accuracy  every system on chains of 2, 10 and 30 unit bones: first-frame error from the rest
##             pose for 100 random reachable targets, then 120 frames tracking a moving target
##   walltime  1,000 ten-bone chains per frame: median frame time with the modifiers active and with
##             them inactive (active = false), same scene, same moving targets
##   cost      meant to run under `valgrind --tool=callgrind --instr-atstart=no
##             --dump-before=*symlink*`: prints "[GBENCH] READY" and waits until the driver has
##             switched instrumentation on (it creates the file given by --ack); then every phase
##             boundary is one DirAccess.create_link() call (libc symlink: a callgrind dump, and
##             nothing else in Godot calls it); the phase labels go into --out in order.
## Results are written as JSON to --out; the driver aggregates them into build/bench/godot.json.

const FloorModifier := preload("res://bench/floor_modifier.gd")

const TRACK_FRAMES := 120
## A reached target: tip within SUCCESS_FRACTION * L (L = chain length = n unit bones).
const SUCCESS_FRACTION := 1e-3
## Random joint rotations that make the targets: uniform axis, angle in [MIN_ANGLE, MAX_ANGLE] rad.
const MIN_ANGLE := 0.2
const MAX_ANGLE := 1.0

var _errors := PackedFloat64Array()  # [frame * chains + chain] = tip distance, NaN = no update
var _first_last := PackedFloat64Array()  # frame 0: error after the frame's last modifier pass
var _updates := PackedInt32Array()   # skeleton_updated count per chain in the current frame
var _frame := 0
var _rigs: Array = []
var _reasons := {}  # IKChain first-frame get_last_result().reason -> count
var _iterations := [[], []]  # IKChain get_last_result().iterations: [first frame, tracking frames]


func _run(mode: String) -> Variant:
	match mode:
		"accuracy":
			return await _accuracy()
		"walltime":
			return await _walltime()
		"cost":
			return await _cost()
	return null


# ------------------------------------------------------------------ systems

## Every configuration compared. `settings`: "default" = the node as created; "converge" = Godot's
## IterateIK3D with 64 iterations and no angle cap (angular_delta_limit = 180°); "floor" = writes
## the same n rotations without solving.
static func configs(n: int) -> Array:
	var out := []
	var names := ["TWO_BONE", "CCD", "JACOBIAN", "DLS", "BFGS", "FABRIK"]
	for s in 6:
		if s == 0 and n != 2:
			continue
		out.append({"system": "IKChain", "solver": names[s], "settings": "default", "id": s})
	if n == 2:
		out.append({"system": "Godot", "solver": "TwoBoneIK3D", "settings": "default"})
	for cls in ["CCDIK3D", "FABRIK3D", "JacobianIK3D"]:
		out.append({"system": "Godot", "solver": cls, "settings": "default"})
		out.append({"system": "Godot", "solver": cls, "settings": "converge"})
	return out


static func floor_configs() -> Array:
	return [
		# Godot's own C++ iterate-IK path with zero iterations: reads the chain, writes n rotations.
		{"system": "floor", "solver": "FABRIK3D", "settings": "floor"},
		# A GDScript SkeletonModifier3D writing n precomputed rotations.
		{"system": "floor", "solver": "GDScript", "settings": "floor"},
	]


static func config_name(c: Dictionary) -> String:
	return "%s/%s/%s" % [c["system"], c["solver"], c["settings"]]


## The modifier for one chain (root "b0", tip "tip"; joints b0..b<n-1>), a child of `skel`;
## its target is "../../T" (and the pole "../../P").
static func make_modifier(c: Dictionary, skel: Skeleton3D, n: int, floor_rotations: Array) -> SkeletonModifier3D:
	var m: SkeletonModifier3D
	if c["system"] == "IKChain":
		var ik := IKChain.new()
		skel.add_child(ik)
		ik.root_bone = "b0"
		ik.tip_bone = "tip"
		ik.target = NodePath("../../T")
		ik.solver = c["id"]
		m = ik
	elif c["solver"] == "GDScript":
		var f := FloorModifier.new()
		skel.add_child(f)
		for i in n:
			f.bones.append(skel.find_bone("b%d" % i))
			f.rotations.append(floor_rotations[i])
		m = f
	elif c["solver"] == "TwoBoneIK3D":
		var t := TwoBoneIK3D.new()
		skel.add_child(t)
		t.setting_count = 1
		t.set("settings/0/root_bone_name", "b0")
		t.set("settings/0/middle_bone_name", "b1")
		t.set("settings/0/end_bone_name", "tip")
		t.set("settings/0/target_node", NodePath("../../T"))
		t.set("settings/0/pole_node", NodePath("../../P"))
		m = t
	else:
		var g: SkeletonModifier3D = ClassDB.instantiate(c["solver"])
		skel.add_child(g)
		g.set("setting_count", 1)
		g.set("settings/0/root_bone_name", "b0")
		g.set("settings/0/end_bone_name", "tip")
		g.set("settings/0/target_node", NodePath("../../T"))
		if c["settings"] == "converge":
			g.set("max_iterations", 64)
			g.set("angular_delta_limit", PI)
		elif c["settings"] == "floor":
			g.set("max_iterations", 0)
		m = g
	m.name = "M"
	return m


# ------------------------------------------------------------------ chains and targets

## n unit bones along +Y from the skeleton origin: b0..b<n-1>, then "tip" (the effector).
static func make_skeleton(n: int) -> Skeleton3D:
	var skel := Skeleton3D.new()
	skel.name = "S"
	for i in n + 1:
		var bone := skel.add_bone("tip" if i == n else "b%d" % i)
		skel.set_bone_parent(bone, bone - 1)
		skel.set_bone_rest(bone, Transform3D(Basis(), Vector3(0, 0 if i == 0 else 1, 0)))
	skel.reset_bone_poses()
	return skel


static func random_rotations(rng: RandomNumberGenerator, n: int) -> Array:
	var out := []
	for i in n:
		var axis := Vector3(rng.randfn(), rng.randfn(), rng.randfn())
		while axis.length() < 1e-3:
			axis = Vector3(rng.randfn(), rng.randfn(), rng.randfn())
		out.append(Quaternion(axis.normalized(), rng.randf_range(MIN_ANGLE, MAX_ANGLE)))
	return out


## Joint origins b0..b<n-1> and the tip, in skeleton space, for local joint rotations `q`.
static func fk(q: Array) -> PackedVector3Array:
	var pts := PackedVector3Array([Vector3.ZERO])
	var rot := Quaternion.IDENTITY
	for i in q.size():
		rot = rot * (q[i] as Quaternion)
		pts.append(pts[i] + rot * Vector3(0, 1, 0))
	return pts


## Per chain: frame 0 = FK of random rotations A (reached from the rest pose); for the first
## `track_chains` chains, frames 1..frames follow FK of the per-joint slerp from A to random
## rotations B (reachable, smooth). The pole (TwoBoneIK3D needs one) sits 1 unit off the generating
## pose's elbow, away from the root-tip line.
static func sequences(n: int, chains: int, frames: int, seed_value: int, track_chains := -1) -> Dictionary:
	var rng := RandomNumberGenerator.new()
	rng.seed = seed_value
	var targets := []
	var poles := []
	var first_pose := []
	for c in chains:
		var a := random_rotations(rng, n)
		var b := random_rotations(rng, n)
		var t := PackedVector3Array()
		var p := PackedVector3Array()
		var last := frames if track_chains < 0 or c < track_chains else 0
		for k in last + 1:
			var q := []
			for i in n:
				q.append((a[i] as Quaternion).slerp(b[i], float(k) / frames))
			var pts := fk(q)
			t.append(pts[n])
			var away := pts[1] - (pts[0] + pts[n]) * 0.5
			p.append(pts[1] + (away.normalized() if away.length() > 1e-6 else Vector3(1, 0, 0)))
		targets.append(t)
		poles.append(p)
		first_pose.append(a)
	return {"targets": targets, "poles": poles, "first_pose": first_pose}


## K rigs "R<c>" = { S (Skeleton3D) ─ M (modifier), T (target), P (pole) }, not yet in the tree.
func build_rigs(c: Dictionary, n: int, seqs: Dictionary, chains: int) -> Node3D:
	var bench_root := Node3D.new()
	bench_root.name = "Bench"
	_rigs.clear()
	for i in chains:
		var rig := Node3D.new()
		rig.name = "R%d" % i
		var skel := make_skeleton(n)
		rig.add_child(skel)
		var t := Node3D.new()
		t.name = "T"
		t.position = seqs["targets"][i][0]
		rig.add_child(t)
		var p := Node3D.new()
		p.name = "P"
		p.position = seqs["poles"][i][0]
		rig.add_child(p)
		var m := make_modifier(c, skel, n, seqs["first_pose"][i])
		bench_root.add_child(rig)
		_rigs.append({"skel": skel, "mod": m, "t": t, "p": p, "tip": skel.find_bone("tip")})
	return bench_root


func move_targets(seqs: Dictionary, k: int) -> void:
	var frames: int = seqs["targets"][0].size()
	var kk := k % frames
	for i in _rigs.size():
		_rigs[i]["t"].position = seqs["targets"][i][kk]
		_rigs[i]["p"].position = seqs["poles"][i][kk]


## Frame 0 of a rig makes its skeleton update (and run the modifiers) twice; the error after the
## FIRST pass is the one scored, the one after the frame's last pass is kept beside it.
func _on_skeleton_updated(i: int, target_seq: PackedVector3Array, chains: int) -> void:
	var r: Dictionary = _rigs[i]
	var skel: Skeleton3D = r["skel"]
	var tip := skel.global_transform * skel.get_bone_global_pose(r["tip"]).origin
	var e := tip.distance_to(target_seq[_frame])
	if _frame == 0:
		_first_last[i] = e
	var first_pass := _updates[i] == 0
	_updates[i] += 1
	if not first_pass:
		return
	_errors[_frame * chains + i] = e
	if r["mod"] is IKChain:
		var result: Dictionary = (r["mod"] as IKChain).get_last_result()
		_iterations[0 if _frame == 0 else 1].append(result["iterations"])
		if _frame == 0:
			_reasons[result["reason"]] = _reasons.get(result["reason"], 0) + 1


# ------------------------------------------------------------------ accuracy

func _accuracy() -> Dictionary:
	var first_chains := 100 if _args.has("quick") else 1000
	var track_chains := 20 if _args.has("quick") else 100
	var lengths := [2, 10] if _args.has("quick") else [2, 10, 30]
	var records := []
	for n in lengths:
		var seqs := sequences(n, first_chains, TRACK_FRAMES, 7000 + n, track_chains)
		for c in configs(n):
			records.append(await _accuracy_one(c, n, seqs, first_chains, track_chains))
	return {"records": records, "first_frame_chains": first_chains, "tracking_chains": track_chains}


## First frame: `chains` rigs enter the tree with their modifiers inactive (skeletons at rest); one
## frame later all are activated and the next frame is the first modifier pass that is measured
## (entering the tree makes a skeleton update twice in its first frame). Then the first
## `track_chains` rigs track their moving targets for TRACK_FRAMES frames; the others are freed.
func _accuracy_one(c: Dictionary, n: int, seqs: Dictionary, chains: int, track_chains: int) -> Dictionary:
	var scene := build_rigs(c, n, seqs, chains)
	for r in _rigs:
		r["mod"].active = false
	root_node().add_child(scene)
	await process_frame
	await process_frame
	_errors.resize((TRACK_FRAMES + 1) * chains)
	_errors.fill(NAN)
	_first_last.resize(chains)
	_first_last.fill(NAN)
	_reasons.clear()
	_iterations = [[], []]
	for i in chains:
		_rigs[i]["skel"].skeleton_updated.connect(_on_skeleton_updated.bind(i, seqs["targets"][i], chains))
	var missing := 0
	var repeated := 0
	var first_frame_updates := {}
	for k in TRACK_FRAMES + 1:
		_frame = k
		_updates.resize(_rigs.size())
		_updates.fill(0)
		if k == 0:
			for r in _rigs:
				r["mod"].active = true
		else:
			move_targets(seqs, k)
		await process_frame  # exactly one frame: its (deferred) skeleton update has run by now
		for i in _rigs.size():
			if k == 0:
				first_frame_updates[_updates[i]] = first_frame_updates.get(_updates[i], 0) + 1
			if _updates[i] == 0:
				missing += 1
			elif _updates[i] > 1 and k > 0:
				repeated += 1
		if k == 0:
			for i in range(track_chains, chains):
				_rigs[i]["skel"].get_parent().free()
			_rigs.resize(track_chains)
	scene.queue_free()
	await process_frame
	var L := float(n)
	var first := []
	var track := []
	var reached_first := 0
	var reached_first_last := 0
	var reached_track := 0
	for i in chains:
		var e := _errors[i]
		first.append(e)
		if e <= SUCCESS_FRACTION * L:  # NaN (no update) is a failure
			reached_first += 1
		if _first_last[i] <= SUCCESS_FRACTION * L:
			reached_first_last += 1
	for i in track_chains:
		for k in range(1, TRACK_FRAMES + 1):
			var ek := _errors[k * chains + i]
			track.append(ek)
			if ek <= SUCCESS_FRACTION * L:
				reached_track += 1
	var rec: Dictionary = c.duplicate()
	rec.erase("id")
	rec.merge({
		"joints": n, "chain_length": L, "chains_first_frame": chains, "chains_tracking": track_chains,
		"success_rate_first_frame": float(reached_first) / chains,
		"median_error_first_frame": quantile(first, 0.5),
		"p90_error_first_frame": quantile(first, 0.9),
		"tracking_error_120_frames": quantile(track, 0.5),
		"tracking_error_p95": quantile(track, 0.95),
		"tracking_error_max": quantile(track, 1.0),
		"tracking_success_rate": float(reached_track) / track.size(),
		"success_rate_first_frame_last_pass": float(reached_first_last) / chains,
		"first_frame_updates": first_frame_updates,
		"missing_updates": missing, "repeated_updates_after_first_frame": repeated,
	})
	if not _reasons.is_empty():
		rec["first_frame_reasons"] = _reasons.duplicate()
		rec["median_iterations_first_frame"] = quantile(_iterations[0], 0.5)
		rec["median_iterations_tracking"] = quantile(_iterations[1], 0.5)
	print("[GBENCH] accuracy n=%d %s: first %.1f%%, median %s, tracking median %s" % [
		n, config_name(c), 100.0 * rec["success_rate_first_frame"],
		String.num_scientific(rec["median_error_first_frame"]),
		String.num_scientific(rec["tracking_error_120_frames"])])
	return rec


## Quantile by sorting (NaN sorts as +inf: a missing update counts as the worst error).
static func quantile(values: Array, q: float) -> float:
	var v := []
	for x in values:
		v.append(INF if is_nan(x) else x)
	v.sort()
	if v.is_empty():
		return NAN
	return v[clampi(int(ceil(q * v.size())) - 1, 0, v.size() - 1)]


# ------------------------------------------------------------------ wall time

## Active and inactive blocks alternate (load on a shared machine drifts): `blocks` pairs of
## `block_frames` frames each, 2 unmeasured frames after every switch; the figure is the median over
## the pairs of (median active frame - median inactive frame) for the wall-clock frame period, and
## of (mean active frame - mean inactive frame) for the main thread's CPU time
## (/proc/thread-self/schedstat: time on a CPU, so time spent waiting for one on a loaded machine
## is left out; the modifiers run on this thread) and for the wall-clock frame period.
func _walltime() -> Dictionary:
	var n := 10
	var chains := 200 if _args.has("quick") else 1000
	var blocks := 3 if _args.has("quick") else 8
	var block_frames := 5 if _args.has("quick") else 8
	var seqs := sequences(n, chains, TRACK_FRAMES, 9000 + n)
	var records := []
	var wanted := [
		{"system": "IKChain", "solver": "DLS", "settings": "default", "id": 3},
		{"system": "Godot", "solver": "FABRIK3D", "settings": "converge"},
	]
	wanted.append_array(floor_configs())
	for c in wanted:
		var scene := build_rigs(c, n, seqs, chains)
		root_node().add_child(scene)
		var k := 0
		var active := []
		var inactive := []
		var diffs := []
		var cpu_active := []
		var cpu_inactive := []
		var cpu_diffs := []
		for w in 3:  # warm-up: chain builds, first solves, caches
			k += 1
			move_targets(seqs, k)
			await process_frame
		for blk in blocks:
			var med := {}
			var cpu_med := {}
			for on in [true, false]:
				for r in _rigs:
					r["mod"].active = on
				for w in 2:
					k += 1
					move_targets(seqs, k)
					await process_frame
				var times := []
				var cpu := []
				var last := Time.get_ticks_usec()
				var last_cpu := _cpu_usec()
				var block_cpu_start := last_cpu
				for f in block_frames:
					k += 1
					move_targets(seqs, k)
					await process_frame
					var now := Time.get_ticks_usec()
					var now_cpu := _cpu_usec()
					times.append(float(now - last))
					cpu.append(now_cpu - last_cpu)
					last = now
					last_cpu = now_cpu
				(active if on else inactive).append_array(times)
				(cpu_active if on else cpu_inactive).append_array(cpu)
				med[on] = quantile(times, 0.5)
				# The kernel updates a thread's CPU time at scheduler ticks (ms): per-frame values
				# are coarse, a block's mean is not.
				cpu_med[on] = (_cpu_usec() - block_cpu_start) / block_frames
			diffs.append(med[true] - med[false])
			cpu_diffs.append(cpu_med[true] - cpu_med[false])
		scene.queue_free()
		await process_frame
		var rec: Dictionary = c.duplicate()
		rec.erase("id")
		rec.merge({"joints": n, "chains": chains, "frames_each": blocks * block_frames,
				"median_frame_us_active": quantile(active, 0.5),
				"median_frame_us_inactive": quantile(inactive, 0.5),
				"wall_ms_for_chains": quantile(diffs, 0.5) / 1000.0,
				"mean_cpu_us_active": _mean(cpu_active),
				"mean_cpu_us_inactive": _mean(cpu_inactive),
				"cpu_ms_for_chains": quantile(cpu_diffs, 0.5) / 1000.0,
				"block_cpu_differences_ms": cpu_diffs.map(func(d): return d / 1000.0)})
		print("[GBENCH] walltime %s: %d chains, %.2f ms CPU / %.2f ms wall per frame" % [
			config_name(c), chains, rec["cpu_ms_for_chains"], rec["wall_ms_for_chains"]])
		records.append(rec)
	return {"records": records}


static func _mean(values: Array) -> float:
	var total := 0.0
	for v in values:
		total += v
	return total / max(1, values.size())


# ------------------------------------------------------------------ instruction counts

func root_node() -> Node:
	return root


func _cost() -> Dictionary:
	var chains := int(_args.get("chains", "20"))
	var frames := int(_args.get("frames", "10"))
	var lengths: Array = Array(str(_args.get("joints", "10")).split(",")).map(func(s): return int(s))
	var systems: PackedStringArray = str(_args.get("systems", "IKChain,Godot,floor")).split(",")
	wait_for_instrumentation()
	var phases := []
	for n in lengths:
		var seqs := sequences(n, chains, TRACK_FRAMES, 8000 + n)
		var list := configs(n)
		list.append_array(floor_configs())
		for c in list:
			if not systems.has(c["system"]):
				continue
			var scene := build_rigs(c, n, seqs, chains)
			root_node().add_child(scene)
			var k := 0
			for phase in ["active", "inactive"]:
				if phase == "inactive":
					for r in _rigs:
						r["mod"].active = false
				for w in 3:  # warm-up: chain builds, first solves
					k += 1
					move_targets(seqs, k)
					await process_frame
				marker("warmup")
				for f in frames:
					k += 1
					move_targets(seqs, k)
					await process_frame
				var label := "%s|%d|%s" % [config_name(c), n, phase]
				marker(label)
				phases.append({"label": label, "system": c["system"], "solver": c["solver"],
						"settings": c["settings"], "joints": n, "phase": phase,
						"chains": chains, "frames": frames})
			scene.queue_free()
			await process_frame
			marker("teardown")
	return {"markers": _markers, "phases": phases}
