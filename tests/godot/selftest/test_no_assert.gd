# Harness self-test fixture: a case that checks nothing fails.
# selftest-expect: FAIL ::checks_nothing: case made no assertions
extends "res://lib/ik_test.gd"


func test_checks_nothing() -> void:
	await frames(1)
