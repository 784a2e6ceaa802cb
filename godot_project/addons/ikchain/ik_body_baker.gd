@tool
@icon("res://addons/ikchain/icons/IKBody.svg")
class_name IKBodyBaker
extends RefCounted
## Bakes an IKBody's result over an animation into a new Animation.
##
## [method bake] steps the source animation of an [AnimationPlayer] frame by frame (the skeleton's
## bones and every other track it drives, animated effector targets included), runs the body's IK
## on each frame as it runs in the game (from the animated pose, with the effectors' targets as they
## are on that frame) and records the bones the body solves: a rotation key per bone per frame, and
## the root bone's position when [member IKBody.floating_root] is on. The result is a copy of the
## source animation whose tracks for those bones are replaced by the baked ones, so it plays back
## without the IKBody (turn the IKBody off, or remove it). The editor's IKBody inspector has a
## "Bake animation..." button that runs this and saves the result as a resource.
##
## [codeblock]
## var baked := IKBodyBaker.bake($Skeleton3D/IKBody, $AnimationPlayer, &"walk", 60.0)
## ResourceSaver.save(baked, "res://walk_ik.res")
## [/codeblock]

## The highest frame rate [method bake] accepts (frames per second).
const MAX_FPS := 1000.0


## Bakes [param body] over the animation [param animation_name] of [param player] at [param fps]
## frames per second (the animation's end is always keyed). Returns the new [Animation], or
## [code]null[/code] (and an error naming the fix) when an input is unusable. The player, the
## skeleton and the animated nodes are left as they were found (the player's animation and
## position are restored).
static func bake(body: IKBody, player: AnimationPlayer, animation_name: StringName, fps := 30.0) -> Animation:
	if body == null or not is_instance_valid(body) or not body.is_inside_tree():
		push_error("IKBodyBaker.bake(): body is not an IKBody in the scene tree; pass one. Nothing was baked.")
		return null
	if player == null or not is_instance_valid(player) or not player.is_inside_tree():
		push_error("IKBodyBaker.bake(): player is not an AnimationPlayer in the scene tree; pass the one that "
				+ "plays the animation. Nothing was baked.")
		return null
	if not player.has_animation(animation_name):
		push_error("IKBodyBaker.bake(): the player has no animation '%s'; pass one of %s. Nothing was baked."
				% [animation_name, player.get_animation_list()])
		return null
	if not (fps > 0.0 and fps <= MAX_FPS):
		push_error("IKBodyBaker.bake(): fps must be in (0, %d], got %s. Nothing was baked." % [MAX_FPS, fps])
		return null
	var skel := body.get_skeleton()
	var root := player.get_node_or_null(player.root_node)
	if skel == null or root == null:
		push_error("IKBodyBaker.bake(): the body has no Skeleton3D parent or the player's root_node does not "
				+ "resolve; fix the scene. Nothing was baked.")
		return null
	var bones := body.get_body_bones()
	if bones.is_empty():
		push_error("IKBodyBaker.bake(): the body is not configured (see its configuration warnings); fix it "
				+ "first. Nothing was baked.")
		return null

	var source := player.get_animation(animation_name)
	var baked: Animation = source.duplicate(true)
	var skel_path := String(root.get_path_to(skel))
	var floating := body.floating_root
	# The source's tracks for the baked bones go; the baked ones replace them.
	var paths: Array[NodePath] = []
	for b in bones:
		paths.append(NodePath(skel_path + ":" + skel.get_bone_name(b)))
	for k in paths.size():
		_remove_tracks(baked, paths[k], Animation.TYPE_ROTATION_3D)
		if k == 0 and floating:
			_remove_tracks(baked, paths[k], Animation.TYPE_POSITION_3D)
	var rotation_tracks := PackedInt32Array()
	for path in paths:
		var t := baked.add_track(Animation.TYPE_ROTATION_3D)
		baked.track_set_path(t, path)
		rotation_tracks.append(t)
	var position_track := -1
	if floating:
		position_track = baked.add_track(Animation.TYPE_POSITION_3D)
		baked.track_set_path(position_track, paths[0])

	# The player's state, restored at the end.
	var was_assigned := player.assigned_animation
	var was_position := player.current_animation_position if was_assigned != "" else 0.0
	var was_playing := player.is_playing()
	player.pause()
	player.assigned_animation = animation_name

	var length := source.length
	var frames := int(ceil(length * fps - 1e-6)) + 1
	var incoming_rotations: Array[Quaternion] = []
	incoming_rotations.resize(bones.size())
	for f in frames:
		var time := minf(f / fps, length)
		player.seek(time, true)  # applies the animation now: bones and animated targets
		# The animated pose, put back after the solve: each frame starts from the animation, as in
		# the game (Skeleton3D restores it before its modifiers run).
		for k in bones.size():
			incoming_rotations[k] = skel.get_bone_pose_rotation(bones[k])
		var incoming_root := skel.get_bone_pose_position(bones[0])
		body.solve_now()
		for k in bones.size():
			baked.rotation_track_insert_key(rotation_tracks[k], time, skel.get_bone_pose_rotation(bones[k]))
		if floating:
			baked.position_track_insert_key(position_track, time, skel.get_bone_pose_position(bones[0]))
		for k in bones.size():
			skel.set_bone_pose_rotation(bones[k], incoming_rotations[k])
		skel.set_bone_pose_position(bones[0], incoming_root)

	if was_assigned != "" and player.has_animation(was_assigned):
		player.assigned_animation = was_assigned
		player.seek(was_position, true)
		if was_playing:
			player.play()
	return baked


static func _remove_tracks(animation: Animation, path: NodePath, type: Animation.TrackType) -> void:
	var t := animation.find_track(path, type)
	while t >= 0:
		animation.remove_track(t)
		t = animation.find_track(path, type)
