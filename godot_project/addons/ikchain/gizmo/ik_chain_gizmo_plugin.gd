@tool
extends EditorNode3DGizmoPlugin
## The IKChain gizmo: for each selected IKChain, the lines of ik_chain_drawer.gd (bones, joint
## limits, target, pole, extra goals), drawn on top of the scene like Godot's own IK gizmos.
##
## The skeleton shows the solved pose only while it emits `skeleton_updated` (it restores the
## unmodified pose afterwards, before the deferred gizmo redraw runs), so the lines are built
## there, kept per node, and _redraw() draws the latest ones.

const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")

var _lines := {}  # IKChain instance id -> the drawer's Dictionary, global space
var _watched := {}  # IKChain instance id -> the Skeleton3D whose skeleton_updated we listen to


func _init() -> void:
	for c in Drawer.CATEGORIES:
		create_material(c, Drawer.COLORS[c], false, true)
	EditorInterface.get_selection().selection_changed.connect(_on_selection_changed)


## Disconnects everything (the plugin is being removed).
func shutdown() -> void:
	var selection := EditorInterface.get_selection()
	if selection.selection_changed.is_connected(_on_selection_changed):
		selection.selection_changed.disconnect(_on_selection_changed)
	for id in _watched.keys():
		_unwatch(id)


func _get_gizmo_name() -> String:
	return "IKChain"


func _has_gizmo(node: Node3D) -> bool:
	return node.is_class("IKChain")


func _redraw(gizmo: EditorNode3DGizmo) -> void:
	gizmo.clear()
	var ik := gizmo.get_node_3d()
	if ik == null or not ik.is_inside_tree() or not _is_selected(ik):
		return
	_watch(ik)
	var id := ik.get_instance_id()
	var lines: Dictionary = _lines[id] if _lines.has(id) else Drawer.build(ik)
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
	for id in _watched:
		ids[id] = true
	for node in EditorInterface.get_selection().get_selected_nodes():
		if node.is_class("IKChain"):
			ids[node.get_instance_id()] = true
	for id in ids:
		var ik := instance_from_id(id) as Node3D
		if ik == null:
			_unwatch(id)
			continue
		if not _is_selected(ik):
			_unwatch(id)
		ik.update_gizmos()


func _watch(ik: Node3D) -> void:
	var id := ik.get_instance_id()
	var skel := ik.get_parent() as Skeleton3D
	if _watched.get(id) == skel:
		return
	_unwatch(id)
	if skel == null:
		return
	skel.skeleton_updated.connect(_on_skeleton_updated.bind(id))
	_watched[id] = skel


func _unwatch(id: int) -> void:
	var skel = _watched.get(id)
	_watched.erase(id)
	_lines.erase(id)
	if is_instance_valid(skel) and skel.skeleton_updated.is_connected(_on_skeleton_updated):
		skel.skeleton_updated.disconnect(_on_skeleton_updated)


func _on_skeleton_updated(id: int) -> void:
	var ik := instance_from_id(id) as Node3D
	if ik == null or not ik.is_inside_tree():
		_unwatch(id)
		return
	_lines[id] = Drawer.build(ik)
	ik.update_gizmos()
