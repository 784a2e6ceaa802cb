@tool
extends RefCounted
## What the IKChain gizmo draws, as line segments in global space, shared by the editor gizmo
## (gizmo/ik_chain_gizmo_plugin.gd) and the run-time view (ik_chain_debug_draw.gd).
##
## build(ik) reads only IKChain's public API (its properties, get_chain_bones(), the parent
## Skeleton3D's bone poses) and returns a Dictionary of PackedVector3Array, each a list of segment
## end-point pairs (a, b, a, b, ...), global space:
##   "bones"   one segment per joint: joint k -> joint k+1, the last joint -> the effector
##             (tip_bone's origin, or its extension with extend_tip_bone)
##   "limits"  per IKChainJoint of the chain:
##               hinge, limited:   an arc in the plane perpendicular to hinge_axis, from hinge_min to
##                                 hinge_max (angle 0 = the bone's direction at rest), radius
##                                 LIMIT_RADIUS x the bone's length, plus the two radii at its ends
##               hinge, unlimited: the full circle (CIRCLE_SEGMENTS)
##               cone_limit:       the cone of half-angle cone_angle around twist_axis, slant
##                                 length = that radius: its base circle (CIRCLE_SEGMENTS) and
##                                 CONE_GENERATORS lines from the joint to the base
##               twist_limit:      an arc around twist_axis, from twist_min to twist_max (angle 0 =
##                                 the rest frame's X, or Z when X is along the axis), half that
##                                 radius, at half the cone length along the axis, plus its radii
##             Axes are in the bone's own frame at rest: the parent's current global pose times
##             the bone's rest (so limits follow the chain as the parent moves, not the bone).
##   "target"  a cross (3 segments along the target's own axes) at the target (the `target` node,
##             else `target_transform`); in aim mode also the effector -> target line
##   "pole"    a cross at the pole target and a line from the chain's middle joint to it
##   "goals"   a cross at each extra goal's target
## and "problems": PackedStringArray, why something could not be drawn (no skeleton, no
## get_chain_bones(), ...): empty when everything was drawn.
##
## The modified pose is visible only while the Skeleton3D emits `skeleton_updated` (it restores the
## unmodified pose afterwards), so callers that want the solved chain call build() from there.

const CATEGORIES: Array[String] = ["bones", "limits", "target", "pole", "goals"]
## Colours by category (Godot's gizmo palette: bones like the skeleton gizmo's orange, limits
## yellow like joint gizmos, targets blue, pole purple, extra goals teal).
const COLORS := {
	"bones": Color(1.0, 0.55, 0.2),
	"limits": Color(1.0, 0.85, 0.25),
	"target": Color(0.35, 0.7, 1.0),
	"pole": Color(0.8, 0.45, 1.0),
	"goals": Color(0.3, 0.9, 0.75),
}
const JOINT_BALL := 0
const JOINT_HINGE := 1
const GOAL_MODE_AIM := 1
const AXIS_VECTORS: Array[Vector3] = [Vector3.RIGHT, Vector3.LEFT, Vector3.UP, Vector3.DOWN,
		Vector3.BACK, Vector3.FORWARD]
## Limit drawings' size, as a fraction of the bone's length.
const LIMIT_RADIUS := 0.3
## Half the size of a cross, as a fraction of the chain's length.
const CROSS_SIZE := 0.04
## An arc gets one segment per ARC_STEP radians (at least one).
const ARC_STEP := PI / 16.0
const CIRCLE_SEGMENTS := 32
const CONE_GENERATORS := 4
const EPSILON := 1e-6


static func build(ik: Node) -> Dictionary:
	var out := {"problems": PackedStringArray()}
	for c in CATEGORIES:
		out[c] = PackedVector3Array()
	var skel := _skeleton_of(ik)
	if skel == null:
		out["problems"].append("the IKChain is not a child of a Skeleton3D")
		return out
	if not skel.is_inside_tree():
		out["problems"].append("the IKChain is not in the scene tree (no global positions yet)")
		return out
	if not ik.has_method("get_chain_bones"):
		out["problems"].append("the IKChain has no get_chain_bones() (the node API of issue 7)")
		return out
	var chain: PackedInt32Array = ik.get_chain_bones()
	if chain.is_empty():
		out["problems"].append("the chain is empty (see the IKChain's configuration warnings)")
		return out
	for b in chain:
		if b < 0 or b >= skel.get_bone_count():
			out["problems"].append("get_chain_bones() returned bone %d, not a bone of the skeleton" % b)
			return out

	var skel_global := skel.global_transform
	var joint_globals: Array[Transform3D] = []
	var points := PackedVector3Array()  # joint origins, then the effector
	for b in chain:
		var g := skel_global * skel.get_bone_global_pose(b)
		joint_globals.append(g)
		points.append(g.origin)
	var effector := _effector(ik, skel, chain, joint_globals, out["problems"])
	points.append(effector)

	var chain_length := 0.0
	for k in chain.size():
		var a := points[k]
		var b := points[k + 1]
		chain_length += a.distance_to(b)
		if a.distance_to(b) > EPSILON:
			out["bones"].append_array([a, b])
	var cross := maxf(CROSS_SIZE * chain_length, 0.005)

	if "joints" in ik:
		for joint in ik.get("joints"):
			if joint == null:
				continue
			var k := chain.find(skel.find_bone(str(joint.get("bone_name"))))
			if k < 0:
				continue  # not on the chain: the node's configuration warning says so
			var bone := chain[k]
			var length := points[k].distance_to(points[k + 1])
			var radius := LIMIT_RADIUS * (length if length > EPSILON else chain_length)
			var parent := skel.get_bone_parent(bone)
			var parent_global := skel_global * (skel.get_bone_global_pose(parent) if parent >= 0 else Transform3D())
			var rest_global := parent_global * skel.get_bone_rest(bone)
			rest_global.origin = points[k]
			# The bone's direction in its own frame (fixed in that frame), seen in the rest frame.
			var dir_in_bone := joint_globals[k].basis.inverse() * (points[k + 1] - points[k])
			var dir_at_rest := rest_global.basis * dir_in_bone
			_add_joint_limits(out["limits"], joint, rest_global, dir_at_rest, radius)
	else:
		out["problems"].append("the IKChain has no `joints` property (the node API of issue 7)")

	var target_xform = _target_transform(ik)
	if target_xform != null:
		_add_cross(out["target"], target_xform, cross)
		if "goal_mode" in ik and int(ik.get("goal_mode")) == GOAL_MODE_AIM:
			out["target"].append_array([effector, (target_xform as Transform3D).origin])

	var pole := _node3d_at(ik, ik.get("pole_target") if "pole_target" in ik else NodePath())
	if pole != null:
		_add_cross(out["pole"], Transform3D(Basis(), pole.global_position), cross)
		out["pole"].append_array([points[chain.size() / 2], pole.global_position])

	if "goals" in ik:
		for goal in ik.get("goals"):
			if goal == null:
				continue
			var goal_target := _node3d_at(ik, goal.get("target"))
			if goal_target != null:
				_add_cross(out["goals"], Transform3D(Basis(), goal_target.global_position), cross)
	return out


## All categories in one list (for a single-material drawing).
static func all_segments(lines: Dictionary) -> PackedVector3Array:
	var all := PackedVector3Array()
	for c in CATEGORIES:
		all.append_array(lines[c])
	return all


static func _skeleton_of(ik: Node) -> Skeleton3D:
	if ik.has_method("get_skeleton"):
		var s = ik.get_skeleton()
		if s is Skeleton3D:
			return s
	return ik.get_parent() as Skeleton3D


static func _effector(ik: Node, skel: Skeleton3D, chain: PackedInt32Array,
		joint_globals: Array[Transform3D], problems: PackedStringArray) -> Vector3:
	var extend: bool = "extend_tip_bone" in ik and ik.get("extend_tip_bone")
	if extend:
		var axis := int(ik.get("tip_extension_axis")) if "tip_extension_axis" in ik else 2
		var length := float(ik.get("tip_extension_length")) if "tip_extension_length" in ik else 0.0
		var tip_global := joint_globals.back() as Transform3D  # with extend_tip_bone the tip is a joint
		return tip_global * (AXIS_VECTORS[clampi(axis, 0, 5)] * length)
	var tip := skel.find_bone(str(ik.get("tip_bone"))) if "tip_bone" in ik else -1
	if tip < 0:
		problems.append("tip_bone \"%s\" is not a bone of the skeleton" % str(ik.get("tip_bone")))
		return (joint_globals.back() as Transform3D).origin
	return (skel.global_transform * skel.get_bone_global_pose(tip)).origin


static func _target_transform(ik: Node):
	var node := _node3d_at(ik, ik.get("target") if "target" in ik else NodePath())
	if node != null:
		return node.global_transform
	if "target_transform" in ik and (not ("target" in ik) or (ik.get("target") as NodePath).is_empty()):
		return ik.get("target_transform")
	return null


static func _node3d_at(ik: Node, path) -> Node3D:
	if not (path is NodePath) or (path as NodePath).is_empty() or not ik.is_inside_tree():
		return null
	return ik.get_node_or_null(path) as Node3D


static func _add_joint_limits(lines: PackedVector3Array, joint: Object, rest: Transform3D,
		dir_at_rest: Vector3, radius: float) -> void:
	var o := rest.origin
	if int(joint.get("type")) == JOINT_HINGE:
		var axis := _direction(rest.basis * (joint.get("hinge_axis") as Vector3), Vector3.RIGHT)
		var u := _perpendicular(dir_at_rest, axis, rest.basis)
		if joint.get("hinge_limit_enabled"):
			var a0 := float(joint.get("hinge_min"))
			var a1 := float(joint.get("hinge_max"))
			_add_arc(lines, o, axis, u, radius, a0, a1)
			lines.append_array([o, o + _rotated(u, axis, a0) * radius, o, o + _rotated(u, axis, a1) * radius])
		else:
			_add_arc(lines, o, axis, u, radius, 0.0, TAU, CIRCLE_SEGMENTS)
		return
	var twist_axis := _direction(rest.basis * (joint.get("twist_axis") as Vector3), Vector3.UP)
	var ref := _perpendicular(rest.basis.x, twist_axis, rest.basis)
	if joint.get("cone_limit_enabled"):
		var angle := float(joint.get("cone_angle"))
		var center := o + twist_axis * (radius * cos(angle))
		var base_radius := radius * sin(angle)
		_add_arc(lines, center, twist_axis, ref, base_radius, 0.0, TAU, CIRCLE_SEGMENTS)
		for i in CONE_GENERATORS:
			lines.append_array([o, center + _rotated(ref, twist_axis, TAU * i / CONE_GENERATORS) * base_radius])
	if joint.get("twist_limit_enabled"):
		var t0 := float(joint.get("twist_min"))
		var t1 := float(joint.get("twist_max"))
		var c := o + twist_axis * (radius * 0.5)
		_add_arc(lines, c, twist_axis, ref, radius * 0.5, t0, t1)
		lines.append_array([c, c + _rotated(ref, twist_axis, t0) * radius * 0.5,
				c, c + _rotated(ref, twist_axis, t1) * radius * 0.5])


## Points u*cos(a) + (axis x u)*sin(a) for a from a0 to a1 (right-handed about axis), as segments.
static func _add_arc(lines: PackedVector3Array, center: Vector3, axis: Vector3, u: Vector3,
		radius: float, a0: float, a1: float, segments := -1) -> void:
	if segments < 0:
		segments = arc_segments(a0, a1)
	var prev := center + _rotated(u, axis, a0) * radius
	for i in range(1, segments + 1):
		var p := center + _rotated(u, axis, lerpf(a0, a1, float(i) / segments)) * radius
		lines.append_array([prev, p])
		prev = p


## How many segments an arc from a0 to a1 gets.
static func arc_segments(a0: float, a1: float) -> int:
	return maxi(1, ceili(absf(a1 - a0) / ARC_STEP - 1e-9))


static func _rotated(u: Vector3, axis: Vector3, angle: float) -> Vector3:
	return u * cos(angle) + axis.cross(u) * sin(angle)


static func _direction(v: Vector3, fallback: Vector3) -> Vector3:
	return v.normalized() if v.length() > EPSILON else fallback


## v made perpendicular to axis and unit length; when v is along axis, the basis axis most
## perpendicular to it instead.
static func _perpendicular(v: Vector3, axis: Vector3, basis: Basis) -> Vector3:
	var p := v - axis * v.dot(axis)
	if p.length() > EPSILON * maxf(1.0, v.length()):
		return p.normalized()
	for candidate in [basis.x, basis.z, basis.y, Vector3.RIGHT, Vector3.BACK]:
		p = candidate - axis * candidate.dot(axis)
		if p.length() > 1e-3:
			return p.normalized()
	return Vector3.RIGHT


static func _add_cross(lines: PackedVector3Array, at: Transform3D, half_size: float) -> void:
	var o := at.origin
	for axis in [at.basis.x, at.basis.y, at.basis.z]:
		var d := _direction(axis, Vector3.ZERO) * half_size
		lines.append_array([o - d, o + d])
