#include "ikchain/tree.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "ikchain/so3.hpp"

namespace ikchain {

namespace {

// The message is made from the data: "joint 3: " or "effector 2: " (when one is named) + reason.
TreeBuildError build_error(int joint, int effector, const char* field, const Message& reason) {
  TreeBuildError e;
  e.joint = joint;
  e.effector = effector;
  e.field = field;
  e.reason = reason;
  if (joint >= 0)
    e.message = Message::format("joint %d: %s", joint, reason.c_str());
  else if (effector >= 0)
    e.message = Message::format("effector %d: %s", effector, reason.c_str());
  else
    e.message = reason;
  return e;
}
TreeBuildError joint_error(int joint, const char* field, const Message& reason) {
  return build_error(joint, -1, field, reason);
}
TreeBuildError effector_error(int effector, const char* field, const Message& reason) {
  return build_error(-1, effector, field, reason);
}

}  // namespace

int TreeBuilder::add_joint(const TreeJointDesc& joint) {
  joints_.push_back(joint);
  return static_cast<int>(joints_.size()) - 1;
}

int TreeBuilder::add_effector(const TreeEffectorDesc& effector) {
  effectors_.push_back(effector);
  return static_cast<int>(effectors_.size()) - 1;
}

TreeBuilder& TreeBuilder::set_floating_root(bool enabled, double translation_motion_cost) {
  floating_root_ = enabled;
  translation_motion_cost_ = translation_motion_cost;
  return *this;
}

void TreeBuilder::clear() {
  joints_.clear();
  effectors_.clear();
  floating_root_ = false;
  translation_motion_cost_ = 1.0;
}

TreeBuildError TreeBuilder::build(Tree& out, const char* axis_name) const {
  out = Tree();
  const int n = static_cast<int>(joints_.size());
  if (n == 0) return joint_error(-1, "joints", Message::format("tree has 0 joints: add at least one joint"));
  Tree t;
  t.joints_.resize(n);
  int dofs = 0;
  if (floating_root_) {
    if (joints_[0].type != JointType::kBall || joints_[0].parent != -1)
      return joint_error(0, "type", Message::format("a floating root must be a ball joint with parent -1"));
    if (!(translation_motion_cost_ > 0.0 && translation_motion_cost_ <= kMaxWeight))
      return joint_error(0, "translation_motion_cost",
                         Message::format("the floating root's translation_motion_cost must be in (0, %g], got %g",
                                         kMaxWeight, translation_motion_cost_));
    dofs = 3;
  }
  for (int i = 0; i < n; ++i) {
    const TreeJointDesc& d = joints_[i];
    if (d.parent < -1 || d.parent >= i)
      return joint_error(i, "parent",
                         Message::format("parent (%d) must be -1 or an earlier joint (< %d): parents "
                                         "precede their children", d.parent, i));
    JointDesc as_joint;
    as_joint.type = d.type;
    as_joint.offset_translation = d.offset_in_parent;
    as_joint.rest_rotation = d.rest_rotation;
    as_joint.axis = d.axis;
    as_joint.limits = d.limits;
    JointDesc normal;
    const BuildError error = normalize_joint(i, as_joint, normal, "offset_in_parent", axis_name);
    if (!error.ok()) return joint_error(i, error.field, error.reason);
    if (!(d.motion_cost > 0.0 && d.motion_cost <= kMaxWeight))
      return joint_error(i, "motion_cost",
                         Message::format("motion_cost must be in (0, %g], got %g", kMaxWeight, d.motion_cost));
    Tree::JointRecord& r = t.joints_[i];
    r.parent = d.parent;
    r.type = normal.type;
    r.offset_in_parent = normal.offset_translation;
    r.rest_rotation = normal.rest_rotation;
    r.axis = normal.axis;
    r.limits = normal.limits;
    r.motion_cost = d.motion_cost;
    r.has_limits = has_joint_limits(d.type, r.limits);
    r.dof_offset = dofs;
    dofs += joint_dof_count(d.type);
  }
  t.dof_count_ = dofs;
  t.floating_root_ = floating_root_;
  t.translation_motion_cost_ = translation_motion_cost_;

  const int m = static_cast<int>(effectors_.size());
  t.effectors_.resize(m);
  t.support_.assign(static_cast<size_t>(m) * n, 0);
  t.support_begin_.assign(m + 1, 0);
  t.reach_from_root_.assign(m, 0.0);
  for (int e = 0; e < m; ++e) {
    const TreeEffectorDesc& d = effectors_[e];
    if (d.joint < 0 || d.joint >= n)
      return effector_error(e, "joint",
                            Message::format("joint (%d) must be in [0, %d)", d.joint, n));
    if (!within_magnitude(d.offset))
      return effector_error(e, "offset",
                            Message::format("offset (%g, %g, %g) must be finite, each component "
                                            "within +-%g m", d.offset.x, d.offset.y, d.offset.z, kMaxMagnitude));
    const double len = so3::scaled_length(d.rotation);
    if (!std::isfinite(len) || len < 1e-9)
      return effector_error(e, "rotation",
                            Message::format("rotation must be a finite non-zero quaternion"));
    TreeEffectorDesc& stored = t.effectors_[e];
    stored = d;
    stored.rotation = glm::normalize(d.rotation / len);
    // Supports: the joint and its ancestors, root first; the reach: the bones on that path.
    t.support_begin_[e] = static_cast<int>(t.support_lists_.size());
    double reach = glm::length(d.offset) + longest_slide(t.joints_[d.joint].type, t.joints_[d.joint].limits);
    for (int j = d.joint; j >= 0; j = t.joints_[j].parent) {
      t.support_[static_cast<size_t>(e) * n + j] = 1;
      t.support_lists_.push_back(j);
      const int p = t.joints_[j].parent;
      if (p >= 0) reach += glm::length(t.joints_[j].offset_in_parent) + longest_slide(t.joints_[p].type, t.joints_[p].limits);
    }
    std::reverse(t.support_lists_.begin() + t.support_begin_[e], t.support_lists_.end());
    t.support_begin_[e + 1] = static_cast<int>(t.support_lists_.size());
    t.reach_from_root_[e] = reach;
  }
  t.lever_ = t.reach_from_root_;
  for (int e = 0; e < m; ++e)
    for (int f = 0; f < m; ++f)
      if (f != e && t.supports(f, effectors_[e].joint))
        t.lever_[e] = std::max(t.lever_[e], t.reach_from_root_[f] - t.reach_from_root_[e]);
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    if (t.joints_[i].parent >= 0) total += glm::length(t.joints_[i].offset_in_parent);
    total += longest_slide(t.joints_[i].type, t.joints_[i].limits);
  }
  for (const TreeEffectorDesc& e : t.effectors_) total += glm::length(e.offset);
  if (!(total > 1e-9))
    return joint_error(-1, "offset_in_parent", Message::format("zero-length tree: every bone has length 0"));
  t.total_length_ = total;
  static std::atomic<uint64_t> next_serial{1};
  t.serial_ = next_serial.fetch_add(1, std::memory_order_relaxed);
  out = std::move(t);
  return TreeBuildError();
}

TreeBuildError tree_from_chain(const Chain& chain, Tree& out) {
  TreeBuilder b;
  const int n = chain.joint_count();
  for (int i = 0; i < n; ++i) {
    TreeJointDesc d;
    d.parent = i - 1;
    d.type = chain.joint_type(i);
    d.offset_in_parent = chain.offset_translation(i);
    d.rest_rotation = chain.rest_rotation(i);
    d.axis = chain.axis(i);
    d.limits = chain.limits(i);
    b.add_joint(d);
  }
  // Chain effector k < n is o_k = o_{k-1} + Q_{k-1} offset_k with the orientation Q_{k-1}: joint
  // k - 1's frame carried to offset_k. The tip: the last joint's frame at tip_offset, turned by
  // tip_rotation.
  for (int k = 1; k < n; ++k) b.add_effector({k - 1, chain.offset_translation(k), glm::dquat(1.0, 0.0, 0.0, 0.0)});
  b.add_effector({n - 1, chain.tip_offset(), chain.tip_rotation()});
  return b.build(out);
}

}  // namespace ikchain
