@tool
extends EditorInspectorPlugin
## The IKBody inspector's actions, at the top of an IKBody's inspector:
## - "Set up humanoid" runs IKBody.setup_humanoid() as one undoable action (undo brings back the
##   root bone, floating root, effectors and joints it replaced);
## - "Bake animation..." picks an animation of an AnimationPlayer in the edited scene, bakes the
##   body's IK over it (IKBodyBaker.bake) and saves the new Animation as a resource file.
## The class is named by string, so this script parses even when the extension did not load.

const BUTTON_TEXT := "Set up humanoid"
const TOOLTIP := "Create the effectors (hips, feet, hands, head) and joint limits (knees, elbows, spine, neck) " \
		+ "for a skeleton with Godot's humanoid bone names (SkeletonProfileHumanoid). Assign the effectors' " \
		+ "targets afterwards."
## What setup_humanoid() replaces, restored by undo.
const REPLACED := ["root_bone", "floating_root", "effectors", "joints"]
const BAKE_TEXT := "Bake animation..."
const BAKE_TOOLTIP := "Record this body's IK over an animation of an AnimationPlayer in the scene into a new " \
		+ "Animation resource (the bones the body solves get a key per frame; every other track is kept)."
const Baker := preload("res://addons/ikchain/ik_body_baker.gd")

var undo_redo: EditorUndoRedoManager


func _can_handle(object: Object) -> bool:
	return object != null and object.is_class("IKBody")


func _parse_begin(object: Object) -> void:
	var button := Button.new()
	button.text = BUTTON_TEXT
	button.tooltip_text = TOOLTIP
	button.pressed.connect(_set_up_humanoid.bind(object))
	add_custom_control(button)
	var bake := Button.new()
	bake.text = BAKE_TEXT
	bake.tooltip_text = BAKE_TOOLTIP
	bake.pressed.connect(_open_bake_dialog.bind(object, bake))
	add_custom_control(bake)


func _set_up_humanoid(body: Object) -> void:
	if undo_redo == null:
		body.call("setup_humanoid")
		return
	undo_redo.create_action("IKBody: set up humanoid", UndoRedo.MERGE_DISABLE, body)
	undo_redo.add_do_method(body, &"setup_humanoid")
	for property in REPLACED:
		undo_redo.add_undo_property(body, property, body.get(property))
	undo_redo.commit_action()


## Every (player, animation) of the AnimationPlayers under `scene_root`.
static func animations_in(scene_root: Node) -> Array:
	var out := []
	if scene_root == null:
		return out
	var players := scene_root.find_children("*", "AnimationPlayer", true, false)
	if scene_root is AnimationPlayer:
		players.push_front(scene_root)
	for player in players:
		for name in (player as AnimationPlayer).get_animation_list():
			out.append([player, StringName(name)])
	return out


func _open_bake_dialog(body: Object, anchor: Control) -> void:
	var editor: Object = Engine.get_singleton(&"EditorInterface")
	var scene_root: Node = editor.call(&"get_edited_scene_root") if editor != null else body.get_tree().root
	var choices := animations_in(scene_root)
	var dialog := ConfirmationDialog.new()
	dialog.title = "Bake IKBody animation"
	var box := VBoxContainer.new()
	dialog.add_child(box)
	if choices.is_empty():
		var none := Label.new()
		none.text = "No AnimationPlayer with an animation in this scene: add one, then bake."
		box.add_child(none)
		dialog.get_ok_button().disabled = true
	var pick := OptionButton.new()
	for c in choices:
		pick.add_item("%s : %s" % [scene_root.get_path_to(c[0]), c[1]])
	box.add_child(pick)
	var fps := SpinBox.new()
	fps.min_value = 1
	fps.max_value = Baker.MAX_FPS
	fps.value = 30
	fps.suffix = "fps"
	box.add_child(fps)
	var path := LineEdit.new()
	path.custom_minimum_size.x = 360
	box.add_child(path)
	var suggest := func(index: int):
		if index >= 0 and index < choices.size():
			path.text = "res://%s_ik.res" % String(choices[index][1]).replace("/", "_")
	pick.item_selected.connect(suggest)
	suggest.call(0)
	dialog.confirmed.connect(func():
		var c: Array = choices[pick.selected]
		var baked: Animation = Baker.bake(body, c[0], c[1], fps.value)
		if baked != null:
			var error := ResourceSaver.save(baked, path.text)
			if error != OK:
				push_error("IKBody bake: could not save %s (%s)." % [path.text, error_string(error)])
			elif editor != null:
				editor.call(&"get_resource_filesystem").call(&"scan")
		dialog.queue_free())
	dialog.canceled.connect(dialog.queue_free)
	anchor.add_child(dialog)
	dialog.popup_centered()
