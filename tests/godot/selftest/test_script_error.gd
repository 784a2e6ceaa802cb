# Harness self-test fixture: a runtime script error fails the case.
# selftest-expect: FAIL ::null_call: unexpected "SCRIPT ERROR
extends "res://lib/ik_test.gd"


func test_null_call() -> void:
	check(true, "reached")
	var n: Node = null
	n.get_name()
