@tool
extends Node3D
## Draws an IKChain the way its editor gizmo does (ik_chain_drawer.gd: bones, joint limits,
## target, pole, extra goals) at run time, e.g. behind a "show limits" toggle in a demo. Lines are
## rebuilt each time the chain's Skeleton3D updates (the only moment its solved pose is visible)
## while this node is visible; hide the node to stop drawing.
##
##   var view := preload("res://addons/ikchain/ik_chain_debug_draw.gd").new()
##   view.ik_chain = view.get_path_to($Skeleton3D/IKChain)   # or set it in the inspector
##   add_child(view)

const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")

## The IKChain to draw.
@export_node_path("SkeletonModifier3D") var ik_chain: NodePath:
	set(value):
		ik_chain = value
		if is_inside_tree():
			_connect()
## Draw through meshes (like the editor gizmo) instead of being hidden by them.
@export var on_top := true:
	set(value):
		on_top = value
		if _material != null:
			_material.no_depth_test = value

## Segments in the last drawing, by category (see ik_chain_drawer.gd), for tests and UI.
var last_lines: Dictionary = {}

var _mesh := ImmediateMesh.new()
var _instance: MeshInstance3D
var _material: StandardMaterial3D
var _skeleton: Skeleton3D


func _ready() -> void:
	_material = StandardMaterial3D.new()
	_material.shading_mode = BaseMaterial3D.SHADING_MODE_UNSHADED
	_material.vertex_color_use_as_albedo = true
	_material.no_depth_test = on_top
	_material.render_priority = 1
	_instance = MeshInstance3D.new()
	_instance.mesh = _mesh
	_instance.material_override = _material
	_instance.cast_shadow = GeometryInstance3D.SHADOW_CASTING_SETTING_OFF
	_instance.top_level = true  # the lines are in global space
	add_child(_instance, false, Node.INTERNAL_MODE_BACK)
	_instance.global_transform = Transform3D()
	_connect()


func _exit_tree() -> void:
	_disconnect()


func _notification(what: int) -> void:
	if what == NOTIFICATION_VISIBILITY_CHANGED and _mesh != null and not is_visible_in_tree():
		_mesh.clear_surfaces()
		last_lines = {}


## Rebuilds the drawing from the IKChain's current state (also called on every skeleton update).
func redraw() -> void:
	_mesh.clear_surfaces()
	last_lines = {}
	var ik := get_node_or_null(ik_chain)
	if ik == null or not is_visible_in_tree():
		return
	last_lines = Drawer.build(ik)
	var count := 0
	for c in Drawer.CATEGORIES:
		count += (last_lines[c] as PackedVector3Array).size()
	if count == 0:
		return
	_mesh.surface_begin(Mesh.PRIMITIVE_LINES)
	for c in Drawer.CATEGORIES:
		_mesh.surface_set_color(Drawer.COLORS[c])
		for p in last_lines[c]:
			_mesh.surface_add_vertex(p)
	_mesh.surface_end()


func _connect() -> void:
	_disconnect()
	var ik := get_node_or_null(ik_chain)
	_skeleton = ik.get_parent() as Skeleton3D if ik != null else null
	if _skeleton != null:
		_skeleton.skeleton_updated.connect(redraw)


func _disconnect() -> void:
	if is_instance_valid(_skeleton) and _skeleton.skeleton_updated.is_connected(redraw):
		_skeleton.skeleton_updated.disconnect(redraw)
	_skeleton = null
