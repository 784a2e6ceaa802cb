# Harness self-test fixture: a crash fails the running case and names the signal.
# selftest-expect: PASS
# selftest-expect: FAIL ::crashes: did not finish \(crashed \(signal 6
extends "res://lib/ik_test.gd"


func test_before() -> void:
	check(true, "reached")


func test_crashes() -> void:
	check(true, "reached")
	OS.crash("deliberate crash for the harness self-test")
