@tool
extends RefCounted
## What the gizmo draws for an IKBody, as line segments in global space: the categories and
## colours of ik_chain_drawer.gd (whose helpers it shares), so the IKChain gizmo plugin draws both.
##
## build(body) reads only IKBody's public API (get_body_bones(), effectors, joints) and the parent
## Skeleton3D's bone poses, and returns a Dictionary of PackedVector3Array (segment end-point pairs,
## global space):
##   "bones"   one segment per solved bone: its parent's origin -> its origin
##   "limits"  per IKChainJoint of a solved bone: its hinge arc, cone and twist arc, drawn as
##             ik_chain_drawer.gd draws them (the bone's direction: toward its solved child)
##   "target"  per enabled effector with a target: a cross at the target and the line from the
##             effector's bone to it (its error, visible); a look (look_at) adds its look axis,
##             as long as that line (the angle between them is the look's error)
##   "pole"    per effector with a pole: a cross at the pole and the line from the limb's middle
##             joint to it
##   "goals"   a cross at each effector's bone, its size by priority (level 1 largest)
## and "problems": PackedStringArray, why something could not be drawn; empty when all was drawn.
##
## The modified pose is visible only while the Skeleton3D emits `skeleton_updated`, so callers
## that want the solved body call build() from there (gizmo/ik_chain_gizmo_lines.gd does).

const Drawer := preload("res://addons/ikchain/ik_chain_drawer.gd")

## Cross size at a level-1 effector, as a fraction of the body's size; each lower level is smaller.
const LEVEL_CROSS := 0.04


static func build(body: Node) -> Dictionary:
	var out := {"problems": PackedStringArray()}
	for c in Drawer.CATEGORIES:
		out[c] = PackedVector3Array()
	var skel := body.get_parent() as Skeleton3D
	if skel == null:
		out["problems"].append("the IKBody is not a child of a Skeleton3D")
		return out
	if not skel.is_inside_tree():
		out["problems"].append("the IKBody is not in the scene tree (no global positions yet)")
		return out
	var bones: PackedInt32Array = body.get_body_bones()
	if bones.is_empty():
		out["problems"].append("the body is empty (see the IKBody's configuration warnings)")
		return out
	var skel_global := skel.global_transform
	var global_of := {}
	for b in bones:
		global_of[b] = skel_global * skel.get_bone_global_pose(b)
	var size := 0.0
	var child_of := {}
	for b in bones:
		var parent := skel.get_bone_parent(b)
		if global_of.has(parent):
			var a: Vector3 = global_of[parent].origin
			var p: Vector3 = global_of[b].origin
			size += a.distance_to(p)
			if a.distance_to(p) > Drawer.EPSILON:
				out["bones"].append_array([a, p])
			if not child_of.has(parent):
				child_of[parent] = b
	var cross := maxf(Drawer.CROSS_SIZE * size * 0.25, 0.005)

	for joint in body.get("joints"):
		if joint == null:
			continue
		var bone := skel.find_bone(str(joint.get("bone_name")))
		if not global_of.has(bone):
			continue  # not solved: nothing to draw
		var g: Transform3D = global_of[bone]
		var parent := skel.get_bone_parent(bone)
		var parent_global := skel_global * (skel.get_bone_global_pose(parent) if parent >= 0 else Transform3D())
		var rest_global := parent_global * skel.get_bone_rest(bone)
		rest_global.origin = g.origin
		var toward: Vector3 = global_of[child_of[bone]].origin - g.origin if child_of.has(bone) else g.basis.y
		var length := toward.length() if child_of.has(bone) else size * 0.1
		var dir_in_bone := g.basis.inverse() * toward
		Drawer._add_joint_limits(out["limits"], joint, rest_global, rest_global.basis * dir_in_bone,
				Drawer.LIMIT_RADIUS * maxf(length, Drawer.EPSILON))

	for e in body.get("effectors"):
		if e == null or not e.get("enabled"):
			continue
		var bone := skel.find_bone(str(e.get("bone_name")))
		if not global_of.has(bone):
			continue
		var at: Transform3D = global_of[bone]
		var level := clampi(int(e.get("priority")), 1, 4)
		Drawer._add_cross(out["goals"], Transform3D(Basis(), at.origin), cross * (1.75 - 0.25 * level))
		var target = null
		if e.get("use_target_transform"):
			target = e.get("target_transform")
		else:
			var node := Drawer._node3d_at(body, e.get("target"))
			if node != null:
				target = node.global_transform
		if target != null and _finite(target):
			Drawer._add_cross(out["target"], target, cross)
			out["target"].append_array([at.origin, (target as Transform3D).origin])
			if e.get("look_at"):
				# A look: also the bone's look axis, as long as the line to the target (the angle
				# between the two is the look's error, visible).
				var reach := at.origin.distance_to((target as Transform3D).origin)
				var axis: Vector3 = at.basis * (e.get("look_axis") as Vector3)
				if reach > Drawer.EPSILON and axis.length() > Drawer.EPSILON:
					out["target"].append_array([at.origin, at.origin + axis.normalized() * reach])
		var pole := Drawer._node3d_at(body, e.get("pole_target"))
		var middle := skel.get_bone_parent(bone)
		if pole != null and global_of.has(middle) and pole.global_position.is_finite():
			Drawer._add_cross(out["pole"], Transform3D(Basis(), pole.global_position), cross)
			out["pole"].append_array([global_of[middle].origin, pole.global_position])
	return out


static func _finite(t: Transform3D) -> bool:
	return t.basis.x.is_finite() and t.basis.y.is_finite() and t.basis.z.is_finite() and t.origin.is_finite()
