// Skeleton <-> chain mapping: Godot bones (rests, poses, per-joint settings) -> a core Chain, and
// back (params -> bone pose rotations), plus the spaces the node's goals live in. Engine-free: it
// depends only on the core and GLM, so it is unit-tested without Godot
// (tests/godot_unit/skeleton_chain_test.cpp).
//
// Godot's bones. A bone's local transform is T(position) R(rotation) S(scale) and its global
// transform is parent_global * local, so a bone's scale applies to its whole subtree.
//
// The chain. bones[0] = root_bone ... bones[m-1] = tip_bone. The joints are bones[0..m-2] (the
// effector is tip_bone's origin), or bones[0..m-1] with extend_tip_bone (the effector is tip_bone's
// origin + tip_extension_length along tip_extension_axis, in tip_bone's scaled frame, as a child
// bone at that position would be). The chain's base space is root_bone's parent bone (skeleton
// space when it has none): joint i of the core chain is bone i, and
//   offset_translation[i] = (s_0 * ... * s_{i-1}) * position_i   (componentwise scale product)
//   rest_rotation[i]      = the rotation of bone i's rest basis
//   pose rotation of bone i = rest_rotation[i] * R_i(params)      (params = 0: the bone's rest rotation)
// so the core frame Q_i is bone i's global rotation in base space. This is exact when every joint
// bone's scale is uniform; a non-uniform scale shears the subtree, which a rigid chain cannot model:
// has_non_uniform_scale() says so (a configuration warning) and measure_pose() evaluates the exact
// T R S composition, so the node reports the true error of what it writes.
//
// Joint settings are in the bone's own frame (hinge_axis, twist_axis), angles relative to the
// bone's rest rotation. At rest the bone frame is the core's joint space (parent frame * rest), and a
// hinge turns about its own axis, so the axes map unchanged.
//
// Per frame (allocates nothing): update_pose() with the bones' current poses (an animation may move
// a bone's position or scale), params_from_rotations() (warm start), the solve (core),
// rotations_from_params(), blend_rotations() (influence, as Skeleton3D blends), measure_pose().
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/message.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain::godot {

// A bone's local pose as Skeleton3D stores it: local = T(position) R(rotation) S(scale), in the
// parent bone's space.
struct BonePose {
  glm::dvec3 position{0.0};
  glm::dquat rotation{1.0, 0.0, 0.0, 0.0};
  glm::dvec3 scale{1.0};
};

// Values match IKChain's AXIS_* constants (static_asserts in ik_chain.cpp).
enum class TipAxis : int {
  kPlusX = 0,
  kMinusX = 1,
  kPlusY = 2,
  kMinusY = 3,
  kPlusZ = 4,
  kMinusZ = 5,
};

// One joint's settings (IKChainJoint's properties). Axes in the bone's own frame; angles in
// radians relative to the bone's rest rotation. A disabled limit is not checked.
struct JointSettings {
  JointType type = JointType::kBall;
  glm::dvec3 hinge_axis_in_bone{1.0, 0.0, 0.0};
  bool hinge_limit_enabled = false;
  double hinge_min = -3.14159265358979323846;
  double hinge_max = 3.14159265358979323846;
  bool cone_limit_enabled = false;
  double cone_angle = 3.14159265358979323846;  // [0, pi]: swing of twist_axis away from its rest direction
  bool twist_limit_enabled = false;
  double twist_min = -3.14159265358979323846;  // within [-pi, pi]
  double twist_max = 3.14159265358979323846;
  glm::dvec3 twist_axis_in_bone{0.0, 1.0, 0.0};
  // How reluctantly a tree solve moves this joint relative to others (TreeJointDesc::motion_cost;
  // > 0, 1 = as any joint). Chains ignore it.
  double motion_cost = 1.0;
  // IKBody: the share ([0, 1]) of the way back to the incoming pose that one posture step (one a
  // frame: IKBody::kPostureIterations) takes for this joint, in the freedom the effectors leave
  // (TreeProblem::posture_stiffness). 1 holds the joint's pose firmly (a torso that should not
  // drift and swing back), 0 lets it rest wherever the effectors left it. Chains ignore it.
  // 0.1: 0.35 (what four steps of 0.1 took before a frame's posture rode on one step) yanked the
  // replayed boxer's torso back between punches, its head 5+ cm a frame on 16 % of the frames.
  double posture_stiffness = 0.1;
};

struct ChainBoneDesc {
  std::string name;        // for messages ("joint 'knee': ...")
  int skeleton_bone = -1;  // passed through (the node's bone index); not used here
  glm::dmat3 rest_basis_in_parent{1.0};  // the bone rest's basis (its rotation part is used)
  BonePose pose;                         // the current pose (position and scale shape the chain)
  JointSettings joint;                   // ignored for tip_bone unless extend_tip_bone
};

struct SkeletonChainDesc {
  std::vector<ChainBoneDesc> bones;  // root_bone first, tip_bone last
  bool extend_tip_bone = false;
  TipAxis tip_extension_axis = TipAxis::kPlusY;
  double tip_extension_length = 0.0;  // >= 0, in tip_bone's (scaled) local units
};

// The rotation of a basis as Godot's Basis::get_rotation_quaternion() takes it: Gram-Schmidt
// orthonormalization (x, then y, then z), a reflection (det < 0) removed by negating the basis.
// Identity for a degenerate or non-finite basis.
glm::dquat rotation_of_basis(const glm::dmat3& basis);
// False when rotation_of_basis() would fall back to identity: the basis is degenerate (a zero
// scale on some axis) or not finite, so it has no rotation to pursue.
bool has_rotation(const glm::dmat3& basis);
// Both at once (one orthonormalization): false as has_rotation(), else `out` = rotation_of_basis().
bool rotation_of_basis(const glm::dmat3& basis, glm::dquat& out);

// The core joint of one bone's settings (IKChainJoint's properties), offset and rest rotation
// left for the caller. A disabled limit is not passed on (nor checked), and neither is the twist
// axis when no limit of the ball joint uses it. Chains and trees (skeleton_tree.hpp) share it.
JointDesc core_joint_of(const JointSettings& settings);

// Warm start of one joint: its params (1 for a hinge, 3 for a ball) from the bone's local pose
// rotation. Ball: log(conj(rest) * pose); hinge: the twist about `axis` (swing-twist
// decomposition); both then projected onto the limits (a hinge to the nearer limit on the circle).
// A zero or non-finite rotation counts as the rest rotation. Chains and trees share it.
void joint_params_from_rotation(JointType type, const glm::dquat& rest_rotation, const glm::dvec3& axis,
                                const JointLimits& limits, const glm::dquat& local_rotation, double* p);

// Godot's Quaternion::slerp (shortest path; linear when the two are within 1e-5 of parallel),
// normalized, as Transform3D::interpolate_with applies it.
glm::dquat godot_slerp(const glm::dquat& from, const glm::dquat& to, double weight);

// The influence blend Skeleton3D::_process_modifiers applies after a modifier with influence < 1
// (Godot 4.6 scene/3d/skeleton_3d.cpp): each bone whose pose the modifier changed gets
// old.interpolate_with(new, influence), i.e. rotation slerp(old, new, influence); influence >= 1
// keeps the new poses. `blended` may alias `new_rotations`. Sizes must match (the smallest is used).
void blend_rotations(Span<const glm::dquat> old_rotations, Span<const glm::dquat> new_rotations, double influence,
                     Span<glm::dquat> blended);

// The chain's base space in the scene: base_to_global = skeleton_global * base_bone_global_pose
// (the base bone's pose in skeleton space; identity when root_bone has no parent).
struct BaseFrame {
  glm::dmat4 base_to_global{1.0};
  glm::dmat4 global_to_base{1.0};
  glm::dquat rotation_global_from_base{1.0, 0.0, 0.0, 0.0};

  // False (and `out` untouched) when the transform is not finite or not invertible (a zero scale).
  static bool make(const glm::dmat4& skeleton_global, const glm::dmat4& base_bone_in_skeleton, BaseFrame& out);

  glm::dvec3 point_in_base(const glm::dvec3& point_global) const;
  // The rotation part of a global transform, in base space.
  glm::dquat rotation_in_base(const glm::dmat4& transform_global) const;
  // The same from that transform's rotation (rotation_of_basis() of its basis).
  glm::dquat rotation_in_base(const glm::dquat& rotation_global) const;
};

// What update_pose() found.
struct PoseUpdate {
  bool shape_changed = false;  // a bone's position or scale differed: the chain was updated in place
  Message error;               // non-empty: the new shape is invalid, the chain keeps the previous one
};

class SkeletonChain {
 public:
  // Validates `desc` and builds the chain; allocates (call it when the configuration changes).
  // On failure valid() is false and the message names the bone and the field:
  // "joint 'knee': hinge_min (1.5) > hinge_max (0.5)".
  Message build(const SkeletonChainDesc& desc);
  bool valid() const { return valid_; }

  const Chain& chain() const { return chain_; }
  int joint_count() const { return joint_count_; }
  int bone_count() const { return int(bones_.size()); }  // joints + tip_bone unless extended
  const std::string& bone_name(int i) const { return bones_[size_t(i)].name; }
  int skeleton_bone(int i) const { return bones_[size_t(i)].skeleton_bone; }
  bool extends_tip_bone() const { return extend_tip_bone_; }

  // ---- per frame (no allocation) ----

  // True when a bone's pose position or scale differs from the ones the chain was built from.
  bool shape_differs(Span<const BonePose> bone_poses) const;
  // Records the bones' current poses (bone_count() of them, root first; the tip bone's rotation
  // is the tip frame) and, when positions or scales changed, updates the chain's offsets in place.
  PoseUpdate update_pose(Span<const BonePose> bone_poses);
  // The current poses (as given to build() or the last update_pose()).
  const BonePose& bone_pose(int i) const { return poses_[size_t(i)]; }

  // A joint bone's scale is not uniform (relative spread > 1e-6): the rigid chain only
  // approximates it. non_uniform_scale_bone() is the first such bone (-1 when none);
  // scale_warning() is a configuration-warning text naming it (empty when none).
  bool has_non_uniform_scale() const { return non_uniform_bone_ >= 0; }
  int non_uniform_scale_bone() const { return non_uniform_bone_; }
  Message scale_warning() const;

  // Warm start: joint params from local bone pose rotations (joint_count() of them). Ball:
  // log(conj(rest) * pose); hinge: the twist about the hinge axis (swing-twist decomposition);
  // both then projected onto the joint's limits (a hinge to the nearer limit on the circle). A
  // zero or non-finite rotation counts as the rest rotation. `params` has chain().dof_count() entries.
  void params_from_rotations(Span<const glm::dquat> local_rotations, double* params) const;
  // Local bone pose rotations rest * R(params) for every joint. False when a rotation is not
  // finite (then write nothing to the skeleton).
  bool rotations_from_params(const double* params, Span<glm::dquat> local_rotations) const;

  // ---- goals, in base space ----

  // The tip bone's local rotation when it is not a joint (its current pose rotation), identity
  // with extend_tip_bone: tip bone rotation in base = effector orientation (core) * this.
  const glm::dquat& tip_rotation_in_effector() const { return tip_rotation_in_effector_; }
  // The core effector orientation that gives the tip BONE the rotation `tip_bone_rotation_in_base`
  // (use_target_rotation: pass base.rotation_in_base(target_global)).
  glm::dquat effector_orientation_for_tip_bone(const glm::dquat& tip_bone_rotation_in_base) const;
  // An axis of the tip bone, in the core effector's frame (Goal::aim's aim_axis).
  glm::dvec3 aim_axis_in_effector(const glm::dvec3& aim_axis_in_tip_bone) const;
  // Unit direction from `from_in_base` to `target_in_base`; false when they (nearly) coincide or
  // are not finite.
  static bool aim_direction_in_base(const glm::dvec3& target_in_base, const glm::dvec3& from_in_base,
                                    glm::dvec3& direction_in_base);
  // The core effector index of a chain bone (its position in the bone list): effector k is bone
  // k's origin. -1 for bone 0 (the root's origin never moves) or an out-of-range index.
  int effector_of_bone(int bone) const;
  // The chain bone (index in the bone list) of a skeleton bone index, -1 when not in the chain.
  int chain_bone_of(int skeleton_bone) const;

  // ---- the exact pose (T R S composition, any scale) ----

  // Forward kinematics of the chain bones as Godot composes them, for the joints' local rotations
  // (joint_count()) and the recorded positions, scales and tip rotation. Afterwards
  // bone_in_base(i) is bone i's transform in base space and effector_in_base() the effector.
  void forward_kinematics_affine(Span<const glm::dquat> joint_rotations);
  const glm::dmat4& bone_in_base(int i) const { return bones_in_base_[size_t(i)]; }
  const glm::dvec3& effector_in_base() const { return effector_in_base_; }
  // The goals' errors (core semantics: measure_goals) on the exact pose of these rotations:
  // effector k's position is bone k's origin (the effector for k = joint_count()), its orientation
  // the rotation of bone k-1's global basis.
  GoalErrors measure_pose(Span<const glm::dquat> joint_rotations, Span<const Goal> goals);
  // The same for the pose Skeleton3D actually ends with: blend_rotations(old, new, influence) into
  // `blended` (joint_count()), then measure_pose(blended).
  GoalErrors measure_blended_pose(Span<const glm::dquat> old_rotations, Span<const glm::dquat> new_rotations,
                                  double influence, Span<const Goal> goals, Span<glm::dquat> blended);

 private:
  struct BoneRecord {
    std::string name;
    int skeleton_bone = -1;
  };
  Message build_from(const SkeletonChainDesc& desc);
  Message check_pose(Span<const BonePose> bone_poses) const;

  bool valid_ = false;
  bool extend_tip_bone_ = false;
  glm::dvec3 tip_extension_{0.0};  // axis * length, tip bone frame
  int joint_count_ = 0;
  int non_uniform_bone_ = -1;
  std::vector<BoneRecord> bones_;
  std::vector<BonePose> poses_;
  std::vector<glm::dvec3> offsets_;
  glm::dvec3 tip_offset_{0.0};
  glm::dquat tip_rotation_in_effector_{1.0, 0.0, 0.0, 0.0};
  Chain chain_;
  // measure_pose(): the exact frames, written where core measure_goals() reads them.
  std::vector<glm::dmat4> bones_in_base_;
  glm::dvec3 effector_in_base_{0.0};
  Workspace frames_;
};

}  // namespace ikchain::godot
