@tool
extends EditorPlugin
## Run by tools/editor_screenshots (a throw-away copy of godot_project, under Xvfb with software
## OpenGL): opens the demo scene, selects the IKChain, saves the whole editor window, then adds a
## hinge IKChainJoint in the inspector and saves again; quits. Never part of the addon.

const OUT_ENV := "IKCHAIN_SHOTS_DIR"
var _frame := 0
var _out := ""
var _joint: Resource


func _enter_tree() -> void:
	_out = OS.get_environment(OUT_ENV)
	set_process(not _out.is_empty())


func _process(_delta: float) -> void:
	_frame += 1
	var ei := get_editor_interface()
	match _frame:
		30:
			ei.open_scene_from_path("res://demo/arm_reach.tscn")
		60:
			_select("Arm/IKChain")
		120:
			_save("editor-ikchain-selected.png")
		130:
			var ik := ei.get_edited_scene_root().get_node("Arm/IKChain")
			_joint = ClassDB.instantiate("IKChainJoint")
			_joint.set("bone_name", "forearm")
			_joint.set("type", 1)
			_joint.set("hinge_axis", Vector3(1, 0, 0))
			_joint.set("hinge_limit_enabled", true)
			_joint.set("hinge_min", 0.0)
			_joint.set("hinge_max", deg_to_rad(150.0))
			ei.inspect_object(_joint)
		150:
			_unfold_sections(get_editor_interface().get_inspector())
		190:
			_save("editor-ikchain-joint.png")
		200:
			print("SHOTS_DONE")
			ei.get_base_control().get_tree().quit()


func _select(path: String) -> void:
	var ei := get_editor_interface()
	var node := ei.get_edited_scene_root().get_node_or_null(path)
	if node == null:
		push_error("shots: no node " + path)
		return
	ei.get_selection().clear()
	ei.get_selection().add_node(node)
	ei.edit_node(node)


## Unfolds every group (Hinge, Cone, Twist) of what the inspector shows.
func _unfold_sections(node: Node) -> void:
	if node.get_class() == "EditorInspectorSection" and node.has_method("unfold"):
		node.call("unfold")
	for child in node.get_children():
		_unfold_sections(child)


func _save(name: String) -> void:
	var img := get_editor_interface().get_base_control().get_viewport().get_texture().get_image()
	var err := img.save_png(_out.path_join(name))
	print("SHOT %s %dx%d err=%d" % [name, img.get_width(), img.get_height(), err])
