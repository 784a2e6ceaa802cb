# Harness self-test fixture: a script that does not parse fails the file.
# selftest-expect: FAIL test_parse_error: completion sentinel missing .*SCRIPT ERROR: Parse Error
extends "res://lib/ik_test.gd"


func test_bad() -> void:
	var x: int = "not an int"
	check(x == 0, "never runs")
