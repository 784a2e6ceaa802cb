# Harness self-test fixture: a failed check fails its case only.
# selftest-expect: PASS
# selftest-expect: FAIL ::wrong: value: expected 3
extends "res://lib/ik_test.gd"


func test_right() -> void:
	check_eq(2, 2, "value")


func test_wrong() -> void:
	check_eq(2, 3, "value")
