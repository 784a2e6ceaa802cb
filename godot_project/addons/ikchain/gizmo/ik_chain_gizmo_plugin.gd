@tool
extends EditorNode3DGizmoPlugin
## The IKChain gizmo: for each selected IKChain, the lines of ik_chain_drawer.gd (bones, joint
## limits, target, pole, extra goals), and for each selected IKBody those of ik_body_drawer.gd
## (bones, limits, effectors by level, targets, poles), drawn on top of the scene like Godot's own
## IK gizmos.
##
## The skeleton shows the solved pose only while it emits `skeleton_updated` (it restores the
## unmodified pose afterwards, before the deferred gizmo redraw runs), so the lines are built
## there, kept per node, and _redraw() draws the latest ones.

const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")
const Lines := preload("res://addons/ikchain/gizmo/ik_chain_gizmo_lines.gd")

## The lines of the selected IKChains, rebuilt in their skeletons' updates (one connection per
## skeleton, however many of its chains are selected).
var _lines := Lines.new()


func _init() -> void:
	for c in Drawer.CATEGORIES:
		create_material(c, Drawer.COLORS[c], false, true)
	_lines.lines_changed.connect(func(ik: Node3D): ik.update_gizmos())
	EditorInterface.get_selection().selection_changed.connect(_on_selection_changed)


## Disconnects everything (the plugin is being removed).
func shutdown() -> void:
	var selection := EditorInterface.get_selection()
	if selection.selection_changed.is_connected(_on_selection_changed):
		selection.selection_changed.disconnect(_on_selection_changed)
	_lines.unwatch_all()


func _get_gizmo_name() -> String:
	return "IKChain"


func _has_gizmo(node: Node3D) -> bool:
	return node.is_class("IKChain") or node.is_class("IKBody")


func _redraw(gizmo: EditorNode3DGizmo) -> void:
	gizmo.clear()
	var ik := gizmo.get_node_3d()
	if ik == null or not ik.is_inside_tree() or not _is_selected(ik):
		return
	_lines.watch(ik)
	var lines: Dictionary = _lines.lines_of(ik)
	var to_local := ik.global_transform.affine_inverse()
	for c in Drawer.CATEGORIES:
		var segments: PackedVector3Array = lines[c]
		if not segments.is_empty():
			gizmo.add_lines(to_local * segments, get_material(c, gizmo))


func _is_selected(node: Node) -> bool:
	return EditorInterface.get_selection().get_selected_nodes().has(node)


func _on_selection_changed() -> void:
	# Redraw IKChains that were or are selected: a deselected one clears its lines.
	var ids := {}
	for id in _lines.watched_ids():
		ids[id] = true
	for node in EditorInterface.get_selection().get_selected_nodes():
		if node.is_class("IKChain") or node.is_class("IKBody"):
			ids[node.get_instance_id()] = true
	for id in ids:
		var ik := instance_from_id(id) as Node3D
		if ik == null:
			_lines.unwatch(id)
			continue
		if not _is_selected(ik):
			_lines.unwatch(id)
		ik.update_gizmos()

