@tool
extends EditorInspectorPlugin
## The IKBody inspector's action: a "Set up humanoid" button at the top of an IKBody's inspector
## runs IKBody.setup_humanoid() as one undoable action (undo brings back the root bone, floating
## root, effectors and joints it replaced). The class is named by string, so this script parses
## even when the extension did not load.

const BUTTON_TEXT := "Set up humanoid"
const TOOLTIP := "Create the effectors (hips, feet, hands, head) and joint limits (knees, elbows, spine, neck) " \
		+ "for a skeleton with Godot's humanoid bone names (SkeletonProfileHumanoid). Assign the effectors' " \
		+ "targets afterwards."
## What setup_humanoid() replaces, restored by undo.
const REPLACED := ["root_bone", "floating_root", "effectors", "joints"]

var undo_redo: EditorUndoRedoManager


func _can_handle(object: Object) -> bool:
	return object != null and object.is_class("IKBody")


func _parse_begin(object: Object) -> void:
	var button := Button.new()
	button.text = BUTTON_TEXT
	button.tooltip_text = TOOLTIP
	button.pressed.connect(_set_up_humanoid.bind(object))
	add_custom_control(button)


func _set_up_humanoid(body: Object) -> void:
	if undo_redo == null:
		body.call("setup_humanoid")
		return
	undo_redo.create_action("IKBody: set up humanoid", UndoRedo.MERGE_DISABLE, body)
	undo_redo.add_do_method(body, &"setup_humanoid")
	for property in REPLACED:
		undo_redo.add_undo_property(body, property, body.get(property))
	undo_redo.commit_action()
