# Harness self-test fixture: a script that exits 0 without the completion sentinel fails.
# selftest-expect: FAIL test_no_sentinel: completion sentinel missing \(exit code 0\)
extends SceneTree


func _initialize() -> void:
	print("doing nothing")
	quit(0)
