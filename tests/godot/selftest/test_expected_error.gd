# Harness self-test fixture: declared errors pass; missing or miscounted ones fail.
# selftest-expect: PASS
# selftest-expect: FAIL ::missing: expected error /never-printed/ at least once, seen 0
# selftest-expect: FAIL ::twice: expected error /once-only/ 1 time\(s\), seen 2
extends "res://lib/ik_test.gd"


func test_declared() -> void:
	expect_error("root_bone|tip_bone", 1)
	push_error("IKChain: ROOT_BONE 'x' not found")  # matched case-insensitively
	await frames(1)
	check(true, "reached")


func test_missing() -> void:
	expect_error("never-printed")
	check(true, "reached")


func test_twice() -> void:
	expect_error("once-only", 1)
	push_error("once-only")
	push_error("once-only")
	check(true, "reached")
