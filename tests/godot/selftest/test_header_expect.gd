# Harness self-test fixture: a `# expect-error:` header covers the whole file.
# expect-error: header-declared
# selftest-expect: PASS
extends "res://lib/ik_test.gd"


func test_prints_declared() -> void:
	push_error("header-declared error")
	check(true, "reached")
