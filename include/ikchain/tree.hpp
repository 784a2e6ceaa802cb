// A branched skeleton: built once by TreeBuilder, then immutable and read by every tree solve.
//
// Joints are stored depth-first: a parent always precedes its children (parents[i] < i, -1 for a
// joint hanging from the base), like ozz-animation's runtime skeleton, so forward kinematics is one
// loop from 0 to n. A chain is the tree with parents[i] = i - 1.
//
// Frames (base space: for Godot, the skeleton's space). With p = parent(i) (o_p = 0, Q_p = identity
// for p = -1):
//   o_i   = o_p + Q_p * offset_in_parent[i]       (+ t for a floating root, see below)
//   pre_i = Q_p * rest_rotation[i]                 the frame the joint's motion is expressed in
//   Q_i   = pre_i * R_i(params)
// R_i as for chains (chain.hpp): ball = exp(rotation vector), hinge = angle about `axis`, prismatic =
// identity with the children shifted by pre_i * axis * slide.
//
// Floating root (TreeBuilder::set_floating_root): joint 0 (a ball, the hips) also translates. Its
// params are then 6: the translation t of o_0 in base space (m) first, then its rotation vector.
// The translation is free (no limits); its motion_cost says how reluctantly the solver uses it.
//
// Effectors are (joint, local frame) pairs: effector e sits at o_j + Q_j * offset with the
// orientation Q_j * rotation, so it is moved by joint j itself and every ancestor of j (its
// "supports", as Pinocchio calls them) and by nothing else.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/chain.hpp"
#include "ikchain/message.hpp"

namespace ikchain {

struct TreeJointDesc {
  int parent = -1;                               // an earlier joint's index, or -1 (the base)
  JointType type = JointType::kBall;
  glm::dvec3 offset_in_parent{0.0};              // from the parent's frame (or the base), m
  glm::dquat rest_rotation{1.0, 0.0, 0.0, 0.0};  // from the parent's frame, before the joint's motion
  glm::dvec3 axis{0.0, 0.0, 1.0};                // hinge: rotation axis; prismatic: slide axis (joint space)
  JointLimits limits;
  // How reluctantly the solvers move this joint, relative to others (dimensionless, > 0; 1 = as
  // any joint). The coupled solvers minimise sum_j motion_cost_j |dq_j|^2 among the steps that
  // serve the goals equally well, so a costly joint moves only when cheaper ones cannot do it.
  double motion_cost = 1.0;
};

struct TreeEffectorDesc {
  int joint = 0;                             // the joint whose frame carries it
  glm::dvec3 offset{0.0};                    // in that joint's frame, m
  glm::dquat rotation{1.0, 0.0, 0.0, 0.0};   // orientation relative to that frame
};

// A build error as data: which joint or effector, which field, and why (as chain.hpp's BuildError),
// so a caller that knows a joint by another name (a bone) maps `joint` and shows `reason`.
struct TreeBuildError {
  int joint = -1;            // the offending joint, or -1
  int effector = -1;         // the offending effector, or -1
  const char* field = "";    // "parent", "offset_in_parent", "limits.cone_angle", ...
  Message message;           // "joint 3: parent (5) must be -1 or an earlier joint (< 3): ..."
  Message reason;            // the same without the joint or effector: "parent (5) must be -1 or ..."
  bool ok() const { return message.empty(); }
};

class Tree;

class TreeBuilder {
 public:
  // Returns the new joint's index.
  int add_joint(const TreeJointDesc& joint);
  // Returns the new effector's index (what TreeGoal::goal.effector names).
  int add_effector(const TreeEffectorDesc& effector);
  // Joint 0 (must be a ball with parent -1) also translates: 3 more params, motion_cost for them
  // relative to a radian of any joint's rotation per metre (> 0).
  TreeBuilder& set_floating_root(bool enabled, double translation_motion_cost = 1.0);
  void clear();
  int joint_count() const { return static_cast<int>(joints_.size()); }

  // Validates every field and fills `out`; on failure `out` is left invalid. `axis_name` is what
  // the error calls TreeJointDesc::axis, as for ChainBuilder::build (Godot's IKChainJoint.hinge_axis).
  TreeBuildError build(Tree& out, const char* axis_name = "axis") const;

 private:
  std::vector<TreeJointDesc> joints_;
  std::vector<TreeEffectorDesc> effectors_;
  bool floating_root_ = false;
  double translation_motion_cost_ = 1.0;
};

// The tree with parents[i] = i - 1 and one effector per chain effector 1..n, in the same order
// (effector k - 1 of the tree is effector k of the chain): the same kinematics as `chain`.
TreeBuildError tree_from_chain(const Chain& chain, Tree& out);

class Tree {
 public:
  bool valid() const { return !joints_.empty(); }
  int joint_count() const { return static_cast<int>(joints_.size()); }
  int dof_count() const { return dof_count_; }
  int effector_count() const { return static_cast<int>(effectors_.size()); }

  int parent(int i) const { return joints_[i].parent; }
  JointType joint_type(int i) const { return joints_[i].type; }
  int dof_offset(int i) const { return joints_[i].dof_offset; }
  // Rotation (or slide) params of joint i: 3 for a ball, 1 for a hinge or slide.
  int dof_count_of(int i) const { return joint_dof_count(joints_[i].type); }
  const glm::dvec3& offset_in_parent(int i) const { return joints_[i].offset_in_parent; }
  const glm::dquat& rest_rotation(int i) const { return joints_[i].rest_rotation; }
  const glm::dvec3& axis(int i) const { return joints_[i].axis; }
  const JointLimits& limits(int i) const { return joints_[i].limits; }
  bool has_limits(int i) const { return joints_[i].has_limits; }
  double motion_cost(int i) const { return joints_[i].motion_cost; }

  // Floating root: params [0, 3) are o_0's translation (m); joint 0's rotation follows at
  // dof_offset(0) = 3.
  bool floating_root() const { return floating_root_; }
  double translation_motion_cost() const { return translation_motion_cost_; }

  const TreeEffectorDesc& effector(int e) const { return effectors_[e]; }
  // True when joint j moves effector e (j is e's joint or one of its ancestors).
  bool supports(int e, int j) const { return support_[static_cast<size_t>(e) * joints_.size() + j] != 0; }
  // The joints that move effector e, root first (its supports), and their count.
  const int* support_list(int e) const { return support_lists_.data() + support_begin_[e]; }
  int support_count(int e) const { return support_begin_[e + 1] - support_begin_[e]; }
  // Longest distance effector e can be from o_0 (the sum of the bone lengths on its path plus its
  // offset; slides at their longest), and from the base origin when the root does not float.
  double reach_from_root(int e) const { return reach_from_root_[e]; }
  // The longest lever a turn of effector e's frame swings (m): its reach from o_0, or the farthest
  // an effector below it reaches past it (the root's effector turns the whole body). What a
  // radian of e's orientation error is worth in metres.
  double lever(int e) const { return lever_[e]; }
  // Sum of every bone length (m): the scale for relative thresholds.
  double total_length() const { return total_length_; }
  // Which build this tree is (unique per successful TreeBuilder::build, kept by copies; 0: none):
  // a tree changes only by a new build, so what was derived from one serial still holds for it
  // (the tree DLS's set-up in TreeWorkspace).
  uint64_t serial() const { return serial_; }

 private:
  friend class TreeBuilder;
  struct JointRecord {
    glm::dvec3 offset_in_parent{0.0};
    glm::dquat rest_rotation{1.0, 0.0, 0.0, 0.0};
    glm::dvec3 axis{0.0, 0.0, 1.0};
    JointLimits limits;
    double motion_cost = 1.0;
    int parent = -1;
    int dof_offset = 0;
    JointType type = JointType::kBall;
    bool has_limits = false;
  };
  std::vector<JointRecord> joints_;
  std::vector<TreeEffectorDesc> effectors_;
  std::vector<uint8_t> support_;       // effector_count x joint_count
  std::vector<int> support_lists_;     // concatenated, root first
  std::vector<int> support_begin_;     // effector_count + 1
  std::vector<double> reach_from_root_;
  std::vector<double> lever_;
  int dof_count_ = 0;
  bool floating_root_ = false;
  double translation_motion_cost_ = 1.0;
  double total_length_ = 0.0;
  uint64_t serial_ = 0;
};

}  // namespace ikchain
