@tool
extends RefCounted
## The gizmo's lines per IKChain (ik_chain_drawer.gd) or IKBody (ik_body_drawer.gd), built while
## the node's Skeleton3D emits `skeleton_updated`: the only moment the solved pose is visible (the
## skeleton restores the unmodified pose afterwards, before the deferred gizmo redraw runs).
##
## One connection per Skeleton3D, shared by all the IKChains of that skeleton that are watched:
## connecting one per chain would connect the same method twice to one signal (Godot refuses the
## second with "Signal 'skeleton_updated' is already connected", and that chain would then be
## drawn at the unsolved pose). Kept apart from the editor plugin so it can be tested without
## the editor.

## Emitted after `ik`'s lines were rebuilt (the gizmo plugin redraws it).
signal lines_changed(ik: Node3D)

const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")
const BodyDrawer := preload("res://addons/ikchain/ik_body_drawer.gd")

var _lines := {}  # IKChain instance id -> the drawer's Dictionary, global space
var _chains := {}  # IKChain instance id -> the Skeleton3D it was watched on
var _connections := {}  # Skeleton3D instance id -> the Callable connected to its skeleton_updated


## Follows `ik`'s skeleton updates (again when it moved to another skeleton).
func watch(ik: Node3D) -> void:
	var id := ik.get_instance_id()
	var skel := ik.get_parent() as Skeleton3D
	if _chains.has(id) and _chains[id] == skel:
		return
	unwatch(id)
	if skel == null:
		return
	_chains[id] = skel
	var skel_id := skel.get_instance_id()
	if not _connections.has(skel_id):
		var callback := _on_skeleton_updated.bind(skel_id)
		skel.skeleton_updated.connect(callback)
		_connections[skel_id] = callback


## Stops following the IKChain with instance id `id`; a skeleton's connection goes with its last
## watched chain.
func unwatch(id: int) -> void:
	_chains.erase(id)
	_lines.erase(id)
	_drop_unused_connections()


func unwatch_all() -> void:
	for id in _chains.keys():
		unwatch(id)


func is_watched(id: int) -> bool:
	return _chains.has(id)


func watched_ids() -> Array:
	return _chains.keys()


## `ik`'s lines as built in the last skeleton update, else built now (the unmodified pose).
func lines_of(ik: Node3D) -> Dictionary:
	var id := ik.get_instance_id()
	return _lines[id] if _lines.has(id) else build(ik)


## The drawing of an IKChain (ik_chain_drawer.gd) or an IKBody (ik_body_drawer.gd).
static func build(ik: Node3D) -> Dictionary:
	return BodyDrawer.build(ik) if ik.is_class("IKBody") else Drawer.build(ik)


func _drop_unused_connections() -> void:
	var used := {}
	for id in _chains:
		if is_instance_valid(_chains[id]):
			used[(_chains[id] as Object).get_instance_id()] = true
	for skel_id in _connections.keys():
		if used.has(skel_id):
			continue
		# A freed skeleton took its connections with it: only the entry is left to drop.
		var skel := instance_from_id(skel_id) as Skeleton3D
		var callback: Callable = _connections[skel_id]
		if skel != null and skel.skeleton_updated.is_connected(callback):
			skel.skeleton_updated.disconnect(callback)
		_connections.erase(skel_id)


func _on_skeleton_updated(skel_id: int) -> void:
	for id in _chains.keys():
		var skel = _chains.get(id)
		if not is_instance_valid(skel) or skel.get_instance_id() != skel_id:
			continue
		var ik := instance_from_id(id) as Node3D
		if ik == null or not ik.is_inside_tree() or ik.get_parent() != skel:
			unwatch(id)
			continue
		_lines[id] = build(ik)
		lines_changed.emit(ik)
