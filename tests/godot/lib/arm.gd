extends RefCounted
## Test arms: a Skeleton3D built in code plus forward kinematics computed without Skeleton3D, used
## as the oracle (targets are placed by FK from random joint rotations, so they are reachable).
##
## Bones (index: name, parent, rest offset along the parent's +Y):
##   0 base  (-1)        (0, BASE_HEIGHT, 0), posed with BASE_ROTATION (so the chain's parent frame
##                       is not the skeleton frame)
##   1 j0    (base)      (0, J0_OFFSET, 0)
##   2 side  (base)      (SIDE_OFFSET) a bone outside the chain, added between chain bones so the
##                       chain's bone indices are not consecutive
##   3 j1    (j0)        (0, lengths[0], 0)
##   ...     j<i> (j<i-1>), then "tip" (j<n-1>) at (0, lengths[n-1], 0)
## The chain root_bone = "j0", tip_bone = "tip" has n moving joints j0..j<n-1>.
## The skeleton node itself gets SKELETON_TRANSFORM, so world and skeleton space differ.

const BASE_HEIGHT := 0.1
const J0_OFFSET := 0.25
const SIDE_OFFSET := Vector3(0.2, 0.1, 0.0)
const LENGTHS := {2: [0.7, 0.45], 3: [0.6, 0.45, 0.3], 4: [0.5, 0.4, 0.3, 0.2]}

static var BASE_ROTATION := Quaternion(Vector3(1, 0, 0.5).normalized(), 0.4)
static var SKELETON_TRANSFORM := Transform3D(
		Basis(Vector3(0, 1, 0), deg_to_rad(30)) * Basis(Vector3(1, 0, 0), deg_to_rad(10)),
		Vector3(1.0, 0.5, -2.0))


static func lengths(n_joints: int) -> Array:
	return LENGTHS[n_joints]


static func chain_length(n_joints: int) -> float:
	var s := 0.0
	for l in lengths(n_joints):
		s += l
	return s


## The skeleton (not in the tree), bone poses = rest except base (BASE_ROTATION).
static func make_skeleton(n_joints: int) -> Skeleton3D:
	var skel := Skeleton3D.new()
	skel.name = "Skeleton"
	skel.transform = SKELETON_TRANSFORM
	var ls := lengths(n_joints)
	_add(skel, "base", -1, Vector3(0, BASE_HEIGHT, 0))
	_add(skel, "j0", skel.find_bone("base"), Vector3(0, J0_OFFSET, 0))
	_add(skel, "side", skel.find_bone("base"), SIDE_OFFSET)
	for i in range(1, n_joints):
		_add(skel, "j%d" % i, skel.find_bone("j%d" % (i - 1)), Vector3(0, ls[i - 1], 0))
	_add(skel, "tip", skel.find_bone("j%d" % (n_joints - 1)), Vector3(0, ls[n_joints - 1], 0))
	skel.reset_bone_poses()
	skel.set_bone_pose_rotation(skel.find_bone("base"), BASE_ROTATION)
	return skel


static func _add(skel: Skeleton3D, bone_name: String, parent: int, offset: Vector3) -> void:
	var i := skel.add_bone(bone_name)
	skel.set_bone_parent(i, parent)
	skel.set_bone_rest(i, Transform3D(Basis(), offset))


## Sets the joints' pose rotations (one Quaternion per joint j0..).
static func pose_joints(skel: Skeleton3D, rotations: Array) -> void:
	for i in rotations.size():
		skel.set_bone_pose_rotation(skel.find_bone("j%d" % i), rotations[i])


## `count` random ball-joint rotations: uniform axis, angle in [min_angle, max_angle] radians.
static func random_rotations(rng: RandomNumberGenerator, count: int, min_angle := 0.3,
		max_angle := 1.1) -> Array:
	var out := []
	for i in count:
		var axis := Vector3(rng.randfn(), rng.randfn(), rng.randfn())
		while axis.length() < 1e-3:
			axis = Vector3(rng.randfn(), rng.randfn(), rng.randfn())
		out.append(Quaternion(axis.normalized(), rng.randf_range(min_angle, max_angle)))
	return out


## Skeleton-space transforms of [base, j0, j1, ..., tip] for the given joint rotations,
## composed here rather than read from Skeleton3D.
static func fk_chain(n_joints: int, rotations: Array) -> Array:
	var ls := lengths(n_joints)
	var out := []
	var t := Transform3D(Basis(BASE_ROTATION), Vector3(0, BASE_HEIGHT, 0))
	out.append(t)
	t = t * Transform3D(Basis(rotations[0]), Vector3(0, J0_OFFSET, 0))
	out.append(t)
	for i in range(1, n_joints):
		t = t * Transform3D(Basis(rotations[i]), Vector3(0, ls[i - 1], 0))
		out.append(t)
	t = t * Transform3D(Basis(), Vector3(0, ls[n_joints - 1], 0))
	out.append(t)
	return out


## World position of the tip for the given joint rotations.
static func fk_tip_world(n_joints: int, rotations: Array) -> Vector3:
	return SKELETON_TRANSFORM * (fk_chain(n_joints, rotations).back() as Transform3D).origin


## World position of the chain's root joint (j0); it does not depend on the joint rotations.
static func root_joint_world() -> Vector3:
	var base := Transform3D(Basis(BASE_ROTATION), Vector3(0, BASE_HEIGHT, 0))
	return SKELETON_TRANSFORM * (base * Vector3(0, J0_OFFSET, 0))


## Skeleton-space global poses of all bones, composed from the skeleton's current local poses
## (parents come before children in these skeletons).
static func compose_globals(skel: Skeleton3D) -> Array:
	var out := []
	for i in skel.get_bone_count():
		var local := skel.get_bone_pose(i)
		var p := skel.get_bone_parent(i)
		out.append(local if p < 0 else (out[p] as Transform3D) * local)
	return out


static func tip_world(skel: Skeleton3D) -> Vector3:
	return skel.global_transform * skel.get_bone_global_pose(skel.find_bone("tip")).origin
