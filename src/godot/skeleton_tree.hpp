// Skeleton <-> tree mapping for IKBody: the bones under a root bone that support some effector ->
// a core Tree (ikchain/tree.hpp), and back (params -> bone pose rotations and, with a floating
// root, the root bone's position). Engine-free: it depends only on the core, GLM and the chain
// mapping's per-joint conversions (skeleton_chain.hpp), so it is unit-tested without Godot
// (tests/godot_unit/skeleton_tree_test.cpp).
//
// The tree. Bone i of the mapping is joint i of the core tree; bones are depth-first (a parent
// precedes its children), bone 0 is root_bone. The tree's base space is root_bone's parent bone
// (skeleton space when it has none), as for chains. With s(i) the product of the pose scales of
// bone i's ancestors up to (and excluding) the base:
//   offset_in_parent[i] = s(i) * position_i   (componentwise; exact for uniform scales)
//   rest_rotation[i]    = the rotation of bone i's rest basis
//   pose rotation of bone i = rest_rotation[i] * R_i(params)      (params = 0: the rest rotation)
// so the core frame Q_i is bone i's global rotation in base space and o_i its global origin.
// Effector e sits at its bone's origin with the bone's orientation (offset 0, rotation identity).
//
// The root bone's position. Floating root: params [0, 3) are the root bone's translation from the
// position it had at build(); pose position = built position + t. Fixed root: an animation may
// still move the root bone; the tree is built at the position it had at build(), so every goal
// point is shifted by the difference (point_in_tree()), which is exact for a rigid shift.
//
// Per frame (allocates nothing unless a bone other than the root changed its position or scale,
// which rebuilds the tree): update_pose() with the bones' current poses, params_from_pose() (the
// warm start: the animated pose), the solve (core), pose_from_params().
#pragma once

#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/message.hpp"
#include "ikchain/span.hpp"
#include "ikchain/tree.hpp"
#include "ikchain/tree_solve.hpp"
#include "skeleton_chain.hpp"

namespace ikchain::godot {

struct TreeBoneDesc {
  std::string name;        // for messages ("joint 'LeftLowerLeg': ...")
  int skeleton_bone = -1;  // passed through (the node's bone index); not used here
  int parent = -1;         // index of the parent in the desc's bone list (< own index); -1 for bone 0 only
  glm::dmat3 rest_basis_in_parent{1.0};  // the bone rest's basis (its rotation part is used)
  BonePose pose;                         // the current pose (position and scale shape the tree)
  JointSettings joint;                   // a free ball unless an IKChainJoint names the bone (its motion_cost too)
};

struct SkeletonTreeDesc {
  std::vector<TreeBoneDesc> bones;  // root first, depth-first
  std::vector<int> effector_bones;  // per core effector: its bone (index in `bones`)
  bool floating_root = false;
  double root_translation_cost = 1.0;  // the floating root translation's motion cost (tree.hpp)
};

// Which skeleton bones a tree needs: every bone on the path from `root_bone` down to each of
// `effector_bones` (skeleton indices), depth-first from root_bone (a parent before its children,
// siblings in index order). `parents` is the skeleton's parent array. On a bone not under
// root_bone (or not a bone), `bones` is left empty and `outside` is set to the first such
// effector bone. A parent cycle ends the walk (bounded by the bone count).
void supporting_bones(Span<const int> parents, int root_bone, Span<const int> effector_bones, std::vector<int>& bones,
                      int& outside);

class SkeletonTree {
 public:
  // Validates `desc` and builds the tree; allocates. On failure valid() is false and the message
  // names the bone and the field: "joint 'LeftLowerLeg': hinge_min (1.5) > hinge_max (0.5)".
  Message build(const SkeletonTreeDesc& desc);
  bool valid() const { return valid_; }

  const Tree& tree() const { return tree_; }
  int bone_count() const { return int(bones_.size()); }
  const std::string& bone_name(int i) const { return bones_[size_t(i)].name; }
  int skeleton_bone(int i) const { return bones_[size_t(i)].skeleton_bone; }
  // The mapping bone of a skeleton bone index, -1 when the tree does not hold it.
  int bone_of(int skeleton_bone) const;
  bool floating_root() const { return desc_.floating_root; }

  // ---- per frame ----

  // Records the bones' current poses (bone_count() of them, in the mapping's order). When a bone
  // other than the root changed its position or scale, the tree is rebuilt (allocates; the result
  // says so: a caller sizing memory to the tree must size it again). On an invalid pose (not
  // finite) nothing changes and the error names the bone.
  PoseUpdate update_pose(Span<const BonePose> bone_poses);
  const BonePose& bone_pose(int i) const { return poses_[size_t(i)]; }

  // Warm start: the params of the recorded poses (tree().dof_count() entries), each joint projected
  // onto its limits; a floating root's translation from its recorded position.
  void params_from_pose(double* params) const;
  // Local bone pose rotations rest * R(params) for every bone (bone_count()) and the root bone's
  // position (its recorded one unless the root floats). False when a value is not finite (then
  // write nothing to the skeleton).
  bool pose_from_params(const double* params, Span<glm::dquat> local_rotations, glm::dvec3& root_position) const;

  // A point in base space (a goal's target) in the tree's frame: shifted by how far a fixed root
  // bone has moved from where the tree was built (identity for a floating root).
  glm::dvec3 point_in_tree(const glm::dvec3& point_in_base) const { return point_in_base - root_shift_; }
  glm::dvec3 point_in_base(const glm::dvec3& point_in_tree) const { return point_in_tree + root_shift_; }

  // ---- pole (bend hint) ----

  // The upper bone of the limb that ends at bone `end` (mapping indices): end's grandparent, when it
  // is a ball joint (it turns the limb about the line to `end`); -1 when the limb cannot take a pole.
  int pole_upper_bone(int end) const;
  // Turns the limb ending at bone `end` about the line from its upper bone's origin to end's origin
  // so that its middle joint (end's parent) points toward `pole_in_tree`: end's position is kept,
  // the bend plane faces the pole (the upper joint's limits still hold). Nothing changes (false) for
  // a limb that cannot take a pole, a straight limb (no bend plane to turn), or a pole on the line.
  // `ws` is scratch for the forward kinematics (sized for the tree). Allocates nothing.
  bool swivel_toward_pole(int end, const glm::dvec3& pole_in_tree, double* params, TreeWorkspace& ws) const;

  // Per DOF (tree().dof_count() entries): its bone's JointSettings::posture_stiffness, the
  // TreeProblem::posture_stiffness of a body whose joints carry their own (a floating root's
  // translation takes the root bone's). Allocates nothing.
  void posture_stiffness(double* per_dof) const;

  // ---- look-at spread ----

  // Turns `bones` (mapping indices, root-most first, each an ancestor of the next; the last is the
  // bone whose `aim_axis` (its own frame) should point at `target_in_tree`) so that the turn is
  // shared: when its turn comes, bone k takes shares[k] / (shares[k] + ... + shares[last]) of the
  // angle still left between the axis and the target, about the axis that turns one onto the other
  // (the shortest turn, in base space). Each joint's limits hold; what a limit withholds passes on
  // to the bones after it, and the last bone takes what is left, so the look is exact unless the
  // last joint's limits stop it. Shares need not sum to 1; a share <= 0 keeps its bone. False (and
  // params untouched) when the target sits on the bone's origin (within the core's kAimAtOnPoint
  // radius: the direction would be rounding) or the inputs are not finite.
  // `ws` is scratch for the forward kinematics (sized for the tree). Allocates nothing.
  bool spread_look(Span<const int> bones, Span<const double> shares, const glm::dvec3& aim_axis,
                   const glm::dvec3& target_in_tree, double* params, TreeWorkspace& ws) const;

  // A bone's non-uniform scale: the rigid tree only approximates it (a configuration warning).
  Message scale_warning() const;

 private:
  struct BoneRecord {
    std::string name;
    int skeleton_bone = -1;
  };
  Message build_tree();

  bool valid_ = false;
  SkeletonTreeDesc desc_;  // kept for rebuilds when the shape changes
  std::vector<BoneRecord> bones_;
  std::vector<BonePose> poses_;
  glm::dvec3 built_root_position_{0.0};
  glm::dvec3 root_shift_{0.0};
  int non_uniform_bone_ = -1;
  Tree tree_;
};

}  // namespace ikchain::godot
