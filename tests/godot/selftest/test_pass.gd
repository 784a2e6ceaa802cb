# Harness self-test fixture (tests/godot/run --selftest): two passing cases.
# selftest-expect: PASS
# selftest-expect: PASS
extends "res://lib/ik_test.gd"


func test_sync() -> void:
	check_eq(1 + 1, 2, "sum")


func test_awaits_frames() -> void:
	var n := Node3D.new()
	case_root.add_child(n)
	await frames(2)
	check(n.is_inside_tree(), "node stays in the tree across frames")
