extends SceneTree
## Base of the headless Godot tests; run by tests/godot/run (see its header).
##
## A test file `extends "res://lib/ik_test.gd"` and defines `func test_<name>()` methods. Each is one
## case, run in declaration order; it may `await`; it gets a fresh `case_root` (a Node3D in the tree)
## that is freed afterwards, so nodes added under it cannot leak. A case must make at least one
## check. This script never names IKChain, so it parses even when the extension failed to load.
##
## Protocol (stdout, one line each, parsed by the runner):
##   [IKTEST] BEGIN <file>::<case>
##   [IKTEST] EXPECT_ERROR <count>\t<regex>     count -1 = at least once
##   [IKTEST] FAIL <file>::<case>: <message>    the failure sentinel
##   [IKTEST] END <file>::<case>
##   [IKTEST] DONE <passed> <failed>            the completion sentinel

## A case still running after this long is reported as hung (e.g. a script error inside a coroutine
## leaves its caller waiting forever); well below the runner's per-file timeout.
const CASE_TIMEOUT_MSEC := 20000

var case_root: Node3D

var _file := ""
var _current := ""
var _case_failed := false
var _checks := 0
var _passed := 0
var _failed := 0
var _case_started_msec := 0


func _initialize() -> void:
	_file = (get_script() as Script).resource_path.get_file().get_basename()
	_run_all()


func _process(_delta: float) -> bool:
	if _current != "" and Time.get_ticks_msec() - _case_started_msec > CASE_TIMEOUT_MSEC:
		_emit_fail("hung: still running after %d ms" % CASE_TIMEOUT_MSEC)
		quit(1)
	return false


func _run_all() -> void:
	await process_frame  # start from a running main loop, like a scene would
	var filter := OS.get_environment("IKCHAIN_TEST_FILTER")
	var names: Array[String] = []
	for m in (get_script() as Script).get_script_method_list():
		var n: String = m["name"]
		if n.begins_with("test_") and not names.has(n):
			names.append(n)
	if names.is_empty():
		print("[IKTEST] FAIL (file): no test_* methods found")
	for n in names:
		var full := "%s::%s" % [_file, n.trim_prefix("test_")]
		if filter != "" and not full.contains(filter):
			continue
		_current = full
		_case_failed = false
		_checks = 0
		_case_started_msec = Time.get_ticks_msec()
		print("[IKTEST] BEGIN " + full)
		case_root = Node3D.new()
		case_root.name = "Case"
		root.add_child(case_root)
		await call(n)
		if _checks == 0:
			_emit_fail("case made no assertions")
		case_root.free()
		case_root = null
		await process_frame  # deferred errors caused by the case still land inside it
		if _case_failed:
			_failed += 1
		else:
			_passed += 1
		print("[IKTEST] END " + full)
		_current = ""
	print("[IKTEST] DONE %d %d" % [_passed, _failed])
	quit(0 if _failed == 0 else 1)


func _emit_fail(message: String) -> void:
	_case_failed = true
	print("[IKTEST] FAIL %s: %s" % [_current if _current != "" else "(file)", message.replace("\n", " ")])


# ------------------------------------------------------------------ assertions

## Records a check; on failure prints the failure sentinel. Returns `condition`.
func check(condition: bool, message: String) -> bool:
	_checks += 1
	if not condition:
		_emit_fail(message)
	return condition


func check_eq(actual: Variant, expected: Variant, what: String) -> bool:
	return check(typeof(actual) == typeof(expected) and actual == expected,
			"%s: expected %s (%s), got %s (%s)" % [what, var_to_str(expected), type_string(typeof(expected)),
			var_to_str(actual), type_string(typeof(actual))])


func check_near(actual: float, expected: float, tolerance: float, what: String) -> bool:
	return check(is_finite(actual) and absf(actual - expected) <= tolerance,
			"%s: expected %.9f ± %s, got %.9f" % [what, expected, str(tolerance), actual])


func check_le(actual: float, limit: float, what: String) -> bool:
	return check(is_finite(actual) and actual <= limit, "%s: expected <= %.9f, got %.9f" % [what, limit, actual])


func fail(message: String) -> void:
	check(false, message)


## Declares that the current case provokes an engine error whose `ERROR:` line matches `regex`
## (case-insensitive, awk ERE). count = -1: at least once; otherwise exactly that many times.
## Errors declared this way do not fail the case; declared errors that do not appear do.
func expect_error(regex: String, count: int = -1) -> void:
	print("[IKTEST] EXPECT_ERROR %d\t%s" % [count, regex])


# ------------------------------------------------------------------ helpers

func frames(n: int) -> void:
	for i in n:
		await process_frame


static func transform_is_finite(t: Transform3D) -> bool:
	return t.basis.x.is_finite() and t.basis.y.is_finite() and t.basis.z.is_finite() and t.origin.is_finite()


static func transforms_near(a: Transform3D, b: Transform3D, eps: float) -> bool:
	for i in 3:
		if not (a.basis[i] - b.basis[i]).length() <= eps:
			return false
	return (a.origin - b.origin).length() <= eps


static func fmt_v(v: Vector3) -> String:
	return "(%.6f, %.6f, %.6f)" % [v.x, v.y, v.z]
