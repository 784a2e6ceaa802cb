@tool
extends EditorPlugin
## Run by tools/editor_screenshots (a throw-away copy of godot_project, under Xvfb with software
## OpenGL). Never part of the addon. Drives the editor by frame count, saves the editor window:
## - IKChain: opens the arm demo, selects the IKChain (editor-ikchain-selected.png), then shows a
##   hinge IKChainJoint in the inspector (editor-ikchain-joint.png);
## - IKBody, the three inspector actions of docs/full-body.md on the demo's humanoid
##   (humanoid_shots.tscn: demo/character/humanoid.tscn instanced with editable children, and six
##   Marker3D targets): an IKBody added under the Skeleton3D and selected
##   (editor-ikbody-added.png); the inspector's "Set up humanoid" button pressed
##   (editor-ikbody-humanoid.png); every effector's target assigned, the effectors list open at the
##   left hand (editor-ikbody-targets.png).
## IKCHAIN_SHOTS_ONLY=body skips the IKChain shots. Quits after the last one.

const OUT_ENV := "IKCHAIN_SHOTS_DIR"
const BODY_SCENE := "res://addons/shots/humanoid_shots.tscn"
const SETUP_BUTTON := "Set up humanoid"  # ik_body_inspector.gd's BUTTON_TEXT
## Where the 3D view looks from and at for the humanoid (metres; the skeleton stands at the origin).
const BODY_EYE := Vector3(1.32, 1.26, 1.26)
const BODY_LOOK := Vector3(0.0, 0.85, 0.1)
## The effector shown unfolded in the last shot.
const SHOWN_EFFECTOR := "LeftHand"

var _frame := 0
var _out := ""
var _joint: Resource
var _body_start := 210
var _body: Node


func _enter_tree() -> void:
	_out = OS.get_environment(OUT_ENV)
	if OS.get_environment("IKCHAIN_SHOTS_ONLY") == "body":
		_body_start = 30
	set_process(not _out.is_empty())


func _process(_delta: float) -> void:
	_frame += 1
	if _body_start > 30:
		_chain_step(_frame)
	_body_step(_frame - _body_start)


func _chain_step(f: int) -> void:
	var ei := get_editor_interface()
	match f:
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


func _body_step(f: int) -> void:
	var ei := get_editor_interface()
	match f:
		0:
			ei.open_scene_from_path(BODY_SCENE)
		30:
			# Action 1: an IKBody child of the Skeleton3D (Add Child Node), selected.
			var root := ei.get_edited_scene_root()
			var skel := root.get_node("Humanoid/Skeleton3D")
			for child in skel.get_children():
				child.set_display_folded(true)  # the mannequin's BoneAttachment3Ds, one row each
			root.get_node("Targets").set_display_folded(true)
			_body = ClassDB.instantiate("IKBody")
			_body.name = "IKBody"
			skel.add_child(_body, true)
			_body.owner = root
			_select("Humanoid/Skeleton3D/IKBody")
		35:
			_fold_scene_rows()
			_widen_inspector()
		50:
			_frame_body()
		90:
			_save("editor-ikbody-added.png")
		100:
			# Action 2: the inspector's "Set up humanoid" button.
			var button := _find_button(ei.get_inspector(), SETUP_BUTTON)
			if button == null:
				push_error("shots: no '%s' button in the inspector" % SETUP_BUTTON)
			else:
				button.pressed.emit()
		130:
			_frame_body()
		170:
			_save("editor-ikbody-humanoid.png")
		180:
			# Action 3: each effector's target, a marker of the scene: the other effectors' through
			# the editor's undo-redo (as the inspector sets them), the one shown through its
			# inspector property (below), as the user's pick does.
			var undo := get_undo_redo()
			for e in _body.get("effectors"):
				if String(e.get("bone_name")) == SHOWN_EFFECTOR:
					continue
				undo.create_action("Set target")
				undo.add_do_property(e, &"target", _target_path(String(e.get("bone_name"))))
				undo.add_undo_property(e, &"target", e.get("target"))
				undo.commit_action()
			ei.get_selection().clear()
		190:
			_select("Humanoid/Skeleton3D/IKBody")
		210:
			var effectors := _find_property(ei.get_inspector(), "effectors")
			if effectors == null:
				push_error("shots: no effectors property in the inspector")
			else:
				var edit := _first_button(effectors)
				edit.button_pressed = true  # a toggle: the click that unfolds the list
				edit.pressed.emit()
		230:
			_unfold_effector(SHOWN_EFFECTOR)
		250:
			var shown := _find_property(ei.get_inspector(), "target")
			if shown == null:
				push_error("shots: the %s effector's target is not in the inspector" % SHOWN_EFFECTOR)
			else:
				shown.emit_changed(&"target", _target_path(SHOWN_EFFECTOR))
			_frame_body()
		300:
			_save("editor-ikbody-targets.png")
			var r: Dictionary = _body.call(&"get_last_result")
			var errors := []
			for i in _body.get("effectors").size():
				errors.append("%s %.4f m %.4f rad" % [_body.get("effectors")[i].get("bone_name"),
						_body.call(&"get_last_effector_position_error", i), _body.call(&"get_last_effector_rotation_error", i)])
			print("BODY %s, %d iterations; %s" % [r.get("reason"), r.get("iterations"), ", ".join(errors)])
		310:
			print("SHOTS_DONE")
			ei.get_base_control().get_tree().quit()


## Folds the scene dock's rows of the mannequin's meshes (the user's fold arrows), so the
## Skeleton3D and its new IKBody show together.
func _fold_scene_rows() -> void:
	var root := get_editor_interface().get_edited_scene_root()
	var skel := root.get_node("Humanoid/Skeleton3D")
	for tree in get_editor_interface().get_base_control().find_children("*", "Tree", true, false):
		var item: TreeItem = (tree as Tree).get_root()
		if item == null or not (item.get_metadata(0) is NodePath):
			continue
		while item != null:
			var node := root.get_node_or_null(item.get_metadata(0)) if item.get_metadata(0) is NodePath else null
			if node != null and (node.get_parent() == skel and node != _body or node.name == "Targets"):
				item.collapsed = true
			item = item.get_next_in_tree()


## Widens the inspector dock (property values not cut off) and makes the scene dock taller (the
## whole humanoid's rows), as a user drags the docks' dividers; a smaller move/rotate gizmo.
func _widen_inspector() -> void:
	var base := get_editor_interface().get_base_control()
	var right := base.find_child("DockVSplitRightL", true, false) as Control
	if right != null:
		right.custom_minimum_size.x = 360
	var left := base.find_child("DockVSplitLeftR", true, false)
	if left != null:
		left.set("split_offset", 240)
	get_editor_interface().get_editor_settings().set_setting("editors/3d/manipulator_gizmo_size", 45)


## The path from the IKBody to the scene's marker for `bone` (Targets/<bone>Target).
func _target_path(bone: String) -> NodePath:
	var marker := get_editor_interface().get_edited_scene_root().get_node_or_null("Targets/" + bone + "Target")
	if marker == null:
		push_error("shots: no target for " + bone)
		return NodePath()
	return _body.get_path_to(marker)


## Points the 3D view at the humanoid (the editor moves its camera only when its own cursor moves).
func _frame_body() -> void:
	var camera := get_editor_interface().get_editor_viewport_3d(0).get_camera_3d()
	camera.look_at_from_position(BODY_EYE, BODY_LOOK, Vector3.UP)


## Opens the sub-inspector of the effector on `bone` in the unfolded effectors list and scrolls to it.
func _unfold_effector(bone: String) -> void:
	var inspector := get_editor_interface().get_inspector()
	var index := -1
	var list: Array = _body.get("effectors")
	for i in list.size():
		if String(list[i].get("bone_name")) == bone:
			index = i
	for picker in inspector.find_children("*", "EditorResourcePicker", true, false):
		if picker.get("edited_resource") == list[index]:
			var widest: Button = null
			for b in picker.find_children("*", "Button", true, false):
				if widest == null or b.size.x > widest.size.x:
					widest = b
			widest.pressed.emit()  # the resource's button: opens its sub-inspector
			await get_tree().process_frame
			await get_tree().process_frame
			var property := picker.get_parent()
			while property != null and not property is EditorProperty:
				property = property.get_parent()
			if property != null:
				# Its first group, Target (the user's click on the group's title).
				var sections := property.find_children("*", "EditorInspectorSection", true, false)
				if not sections.is_empty():
					sections[0].call("unfold")
				await get_tree().process_frame
				await get_tree().process_frame
				inspector.ensure_control_visible(property)
				inspector.scroll_vertical = maxi(0, inspector.scroll_vertical + int(property.get_global_rect().position.y - inspector.get_global_rect().position.y) - 140)
			return
	push_error("shots: no resource picker for the %s effector" % bone)


func _select(path: String) -> void:
	var ei := get_editor_interface()
	var node := ei.get_edited_scene_root().get_node_or_null(path)
	if node == null:
		push_error("shots: no node " + path)
		return
	ei.get_selection().clear()
	ei.get_selection().add_node(node)
	ei.edit_node(node)


func _find_button(node: Node, text: String) -> Button:
	for b in node.find_children("*", "Button", true, false):
		if (b as Button).text == text and (b as Button).is_visible_in_tree():
			return b
	return null


func _first_button(node: Node) -> Button:
	var found := node.find_children("*", "Button", true, false)
	return found[0] if not found.is_empty() else null


func _find_property(node: Node, property: String) -> EditorProperty:
	for p in node.find_children("*", "EditorProperty", true, false):
		if (p as EditorProperty).get_edited_property() == StringName(property):
			return p
	return null


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
