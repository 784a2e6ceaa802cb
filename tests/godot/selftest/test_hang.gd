# Harness self-test fixture: a case that never finishes is killed by the per-file timeout.
# timeout: 3
# selftest-expect: FAIL ::waits_forever: did not finish \(timed out after 3 s
extends "res://lib/ik_test.gd"

signal never


func test_waits_forever() -> void:
	check(true, "reached")
	await never
