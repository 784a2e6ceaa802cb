@tool
extends EditorPlugin
## Registers the IKChain gizmo (gizmo/ik_chain_gizmo_plugin.gd) and the IKBody inspector's
## "Set up humanoid" action (ik_body_inspector.gd). The nodes themselves come from the GDExtension,
## which loads without this plugin; the plugin only adds the drawing and the editor action.

const GizmoPlugin := preload("res://addons/ikchain/gizmo/ik_chain_gizmo_plugin.gd")
const BodyInspector := preload("res://addons/ikchain/ik_body_inspector.gd")

var _gizmo_plugin: EditorNode3DGizmoPlugin
var _body_inspector: BodyInspector


func _enter_tree() -> void:
	_gizmo_plugin = GizmoPlugin.new()
	add_node_3d_gizmo_plugin(_gizmo_plugin)
	_body_inspector = BodyInspector.new()
	_body_inspector.undo_redo = get_undo_redo()
	add_inspector_plugin(_body_inspector)


func _exit_tree() -> void:
	remove_inspector_plugin(_body_inspector)
	_body_inspector = null
	remove_node_3d_gizmo_plugin(_gizmo_plugin)
	_gizmo_plugin.shutdown()
	_gizmo_plugin = null
