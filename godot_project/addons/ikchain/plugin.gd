@tool
extends EditorPlugin
## Registers the IKChain gizmo (gizmo/ik_chain_gizmo_plugin.gd). The node itself comes from the
## GDExtension, which loads without this plugin; the plugin only adds the drawing.

const GizmoPlugin := preload("res://addons/ikchain/gizmo/ik_chain_gizmo_plugin.gd")

var _gizmo_plugin: EditorNode3DGizmoPlugin


func _enter_tree() -> void:
	_gizmo_plugin = GizmoPlugin.new()
	add_node_3d_gizmo_plugin(_gizmo_plugin)


func _exit_tree() -> void:
	remove_node_3d_gizmo_plugin(_gizmo_plugin)
	_gizmo_plugin.shutdown()
	_gizmo_plugin = null
