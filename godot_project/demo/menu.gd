extends Control
## The demos' menu (the project's main scene): opens the arm-reach, missile-guidance or character
## scene.
## Each scene comes back here with its "Back to the menu" button or Esc.

const SCENES := {
	"arm_reach": "res://demo/arm_reach.tscn",
	"missile_guidance": "res://demo/missile_guidance.tscn",
	"character": "res://demo/character.tscn",
}


func _ready() -> void:
	$Center/VBox/ArmReach/VBox/Open.pressed.connect(open.bind("arm_reach"))
	$Center/VBox/MissileGuidance/VBox/Open.pressed.connect(open.bind("missile_guidance"))
	$Center/VBox/Character/VBox/Open.pressed.connect(open.bind("character"))
	$Center/VBox/Quit.pressed.connect(get_tree().quit)
	$Center/VBox/ArmReach/VBox/Open.grab_focus.call_deferred()


func open(demo: String) -> void:
	get_tree().change_scene_to_file(SCENES[demo])


func _unhandled_input(event: InputEvent) -> void:
	var key := event as InputEventKey
	if key == null or not key.pressed or key.echo:
		return
	match key.keycode:
		KEY_1:
			open("arm_reach")
		KEY_2:
			open("missile_guidance")
		KEY_3:
			open("character")
		KEY_ESCAPE:
			get_tree().quit()
