# Harness self-test fixture: an unmet `# expect-error:` header fails the file.
# expect-error: never-printed
# selftest-expect: PASS
# selftest-expect: FAIL test_header_unmet: expected error /never-printed/ not seen
extends "res://lib/ik_test.gd"


func test_quiet() -> void:
	check(true, "reached")
