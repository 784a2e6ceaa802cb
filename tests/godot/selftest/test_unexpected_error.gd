# Harness self-test fixture: an undeclared ERROR line fails the case that printed it.
# selftest-expect: FAIL ::noisy: unexpected "ERROR: boom-undeclared"
# selftest-expect: PASS
extends "res://lib/ik_test.gd"


func test_noisy() -> void:
	push_error("boom-undeclared")
	check(true, "reached")


func test_quiet() -> void:
	check(true, "reached")
