# Harness self-test fixture: a non-zero exit fails even after the sentinel.
# selftest-expect: PASS
# selftest-expect: FAIL test_exit_code: exit code 3
extends SceneTree


func _initialize() -> void:
	print("[IKTEST] BEGIN test_exit_code::x")
	print("[IKTEST] END test_exit_code::x")
	print("[IKTEST] DONE 1 0")
	quit(3)
