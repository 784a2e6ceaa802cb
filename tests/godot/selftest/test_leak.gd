# Harness self-test fixture: a leaked object at exit fails the file.
# selftest-expect: PASS
# selftest-expect: FAIL test_leak: leak: .*ObjectDB instances leaked
extends "res://lib/ik_test.gd"


func test_leaks_a_node() -> void:
	var orphan := Node.new()
	orphan.name = "Orphan"
	check(orphan != null, "made a node and never freed it")
