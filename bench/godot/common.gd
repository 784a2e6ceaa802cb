extends SceneTree
## What the Godot benchmark scripts (bench.gd, body.gd: each extends this) share: the command line
## (--key=value, a bare --key is "1"), running the mode named by --mode and writing its result as
## JSON to --out, the cost modes' callgrind handshake and phase markers, the thread's CPU time.

var _args := {}
var _markers: Array = []
var _dir: DirAccess


func _initialize() -> void:
	for a in OS.get_cmdline_user_args():
		var kv: PackedStringArray = a.trim_prefix("--").split("=", true, 1)
		_args[kv[0]] = kv[1] if kv.size() > 1 else "1"
	_main()


## The script's modes: runs `mode` and returns its result (a Dictionary), or null for a mode it
## does not have.
func _run(_mode: String) -> Variant:
	return null


func _main() -> void:
	await process_frame
	var mode: String = _args.get("mode", "")
	var out: Variant = await _run(mode)
	if out == null:
		push_error("%s: no mode '%s' (the script's header lists its modes)" % [
				(get_script() as Script).resource_path.get_file(), mode])
		quit(2)
		return
	var f := FileAccess.open(_args["out"], FileAccess.WRITE)
	f.store_string(JSON.stringify(out, " "))
	f.close()
	print("[GBENCH] DONE")
	quit()


# ------------------------------------------------------------------ instruction counts

## The cost modes run under callgrind with instrumentation off: print "[GBENCH] READY", wait until
## the driver has switched it on (it creates the file --ack), then mark the set-up's end.
func wait_for_instrumentation() -> void:
	_dir = DirAccess.open(_args["marker_dir"])
	print("[GBENCH] READY")
	while not FileAccess.file_exists(_args["ack"]):
		OS.delay_msec(20)
	marker("setup")


## One callgrind dump boundary (libc symlink(), which nothing else in Godot calls): the dump that
## this call triggers holds everything since the previous marker, so `label` names the phase that
## just ended.
func marker(label: String) -> void:
	_markers.append(label)
	_dir.create_link("/nonexistent-gbench-marker", _args["marker_dir"].path_join("m%d" % _markers.size()))


# ------------------------------------------------------------------ wall time

## CPU time of the calling thread so far, in microseconds (Linux).
static func _cpu_usec() -> float:
	var f := FileAccess.open("/proc/thread-self/schedstat", FileAccess.READ)
	if f == null:
		return NAN
	return float(f.get_line().get_slice(" ", 0)) / 1000.0
