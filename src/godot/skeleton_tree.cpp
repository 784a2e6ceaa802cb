#include "skeleton_tree.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ikchain/kinematics.hpp"
#include "ikchain/so3.hpp"

namespace ikchain::godot {

namespace {

bool finite(const glm::dmat3& m) {
  for (int c = 0; c < 3; ++c)
    if (!so3::finite(m[c])) return false;
  return true;
}

bool is_uniform(const glm::dvec3& s) {
  const double m = std::max({std::abs(s.x), std::abs(s.y), std::abs(s.z)});
  return std::abs(s.x - s.y) <= 1e-6 * m && std::abs(s.x - s.z) <= 1e-6 * m;
}

}  // namespace

void supporting_bones(Span<const int> parents, int root_bone, Span<const int> effector_bones, std::vector<int>& bones,
                      int& outside) {
  bones.clear();
  outside = -1;
  const int n = parents.size;
  if (root_bone < 0 || root_bone >= n) {
    outside = effector_bones.size > 0 ? effector_bones[0] : -1;
    return;
  }
  std::vector<char> keep(size_t(n), 0);
  keep[size_t(root_bone)] = 1;
  for (int e : effector_bones) {
    // Walk up to root_bone, marking the path; bounded by the bone count (a cycle cannot hang it).
    int bone = e, steps = 0;
    bool found = false;
    std::vector<int> path;
    while (bone >= 0 && bone < n && steps++ <= n) {
      path.push_back(bone);
      if (bone == root_bone) {
        found = true;
        break;
      }
      bone = parents[bone];
    }
    if (!found) {
      outside = e;
      return;
    }
    for (int b : path) keep[size_t(b)] = 1;
  }
  // Depth-first from root_bone over the kept bones, children in index order.
  std::vector<int> stack{root_bone};
  while (!stack.empty()) {
    const int b = stack.back();
    stack.pop_back();
    bones.push_back(b);
    for (int c = n - 1; c >= 0; --c)
      if (keep[size_t(c)] && c != root_bone && parents[c] == b) stack.push_back(c);
  }
}

Message SkeletonTree::build(const SkeletonTreeDesc& desc) {
  valid_ = false;
  desc_ = desc;
  bones_.clear();
  poses_.clear();
  for (const TreeBoneDesc& b : desc.bones) {
    bones_.push_back({b.name, b.skeleton_bone});
    poses_.push_back(b.pose);
  }
  const Message error = build_tree();
  if (!error.empty()) {
    // Nothing half-built survives: every per-frame function sees an empty tree and does nothing.
    bones_.clear();
    poses_.clear();
    desc_ = SkeletonTreeDesc();
    tree_ = Tree();
    return error;
  }
  built_root_position_ = poses_[0].position;
  root_shift_ = glm::dvec3(0.0);
  valid_ = true;
  return Message();
}

Message SkeletonTree::build_tree() {
  const int m = int(desc_.bones.size());
  if (m == 0) return Message::format("no bones: set root_bone and add an effector under it");
  if (desc_.effector_bones.empty()) return Message::format("no effectors: add an enabled effector under root_bone");
  if (!(desc_.root_translation_cost > 0.0) || !std::isfinite(desc_.root_translation_cost))
    return Message::format("root translation cost (%g) must be finite and > 0", desc_.root_translation_cost);
  TreeBuilder builder;
  std::vector<glm::dvec3> scale_of(size_t(m), glm::dvec3(1.0));  // product of the scales down to bone i, inclusive
  non_uniform_bone_ = -1;
  for (int i = 0; i < m; ++i) {
    const TreeBoneDesc& b = desc_.bones[size_t(i)];
    const char* name = b.name.c_str();
    if (i == 0 ? b.parent != -1 : (b.parent < 0 || b.parent >= i))
      return Message::format("bone '%s': parent index %d must be %s (bones depth-first, root first)", name, b.parent,
                             i == 0 ? "-1 for the root" : "an earlier bone's");
    if (!so3::finite(b.pose.position))
      return Message::format("bone '%s': pose position (%g, %g, %g) is not finite; give it a finite position", name,
                             b.pose.position.x, b.pose.position.y, b.pose.position.z);
    if (!so3::finite(b.pose.scale))
      return Message::format("bone '%s': pose scale (%g, %g, %g) is not finite; give it a finite scale", name,
                             b.pose.scale.x, b.pose.scale.y, b.pose.scale.z);
    if (!finite(b.rest_basis_in_parent) || std::abs(glm::determinant(b.rest_basis_in_parent)) < 1e-18)
      return Message::format("bone '%s': rest basis is not finite or has zero scale; fix the bone's rest", name);
    if (b.joint.type != JointType::kBall && b.joint.type != JointType::kHinge)
      return Message::format("joint '%s': type (%d) must be JOINT_BALL (0) or JOINT_HINGE (1)", name,
                             int(b.joint.type));
    if (desc_.floating_root && i == 0 && b.joint.type != JointType::kBall)
      return Message::format("joint '%s': a floating root must be a ball joint; remove its hinge IKChainJoint or turn "
                             "off floating_root",
                             name);
    if (!(b.joint.motion_cost > 0.0) || !std::isfinite(b.joint.motion_cost))
      return Message::format("joint '%s': motion_cost (%g) must be finite and > 0; fix it in the bone's IKChainJoint",
                             name, b.joint.motion_cost);
    if (!(b.joint.posture_stiffness >= 0.0 && b.joint.posture_stiffness <= 1.0))
      return Message::format("joint '%s': posture_stiffness (%g) must be within [0, 1]; fix it in the bone's IKChainJoint",
                             name, b.joint.posture_stiffness);
    const glm::dvec3 parent_scale = i == 0 ? glm::dvec3(1.0) : scale_of[size_t(b.parent)];
    scale_of[size_t(i)] = parent_scale * b.pose.scale;
    if (non_uniform_bone_ < 0 && !is_uniform(b.pose.scale)) non_uniform_bone_ = i;
    const JointDesc core = core_joint_of(b.joint);
    TreeJointDesc j;
    j.parent = b.parent;
    j.type = core.type;
    // The root's offset is where the tree was built (see point_in_tree()).
    j.offset_in_parent = i == 0 ? (valid_ ? built_root_position_ : b.pose.position) : parent_scale * b.pose.position;
    j.rest_rotation = rotation_of_basis(b.rest_basis_in_parent);
    j.axis = core.axis;
    j.limits = core.limits;
    j.motion_cost = b.joint.motion_cost;
    builder.add_joint(j);
  }
  for (int e : desc_.effector_bones) {
    if (e < 0 || e >= m) return Message::format("effector bone index %d is not a bone of the tree (0..%d)", e, m - 1);
    builder.add_effector({e, glm::dvec3(0.0), glm::dquat(1.0, 0.0, 0.0, 0.0)});
  }
  builder.set_floating_root(desc_.floating_root, desc_.root_translation_cost);
  const TreeBuildError error = builder.build(tree_, "hinge_axis");  // the users' name for it
  if (!error.ok()) {
    // The builder names a joint by its index; the user knows it by its bone, and sets its limits
    // in that bone's IKChainJoint.
    if (error.joint >= 0 && error.joint < m)
      return Message::format("joint '%s' (%s): %s", bones_[size_t(error.joint)].name.c_str(), error.field,
                             error.reason.c_str());
    return Message::format("cannot build the tree: %s", error.message.c_str());
  }
  return Message();
}

int SkeletonTree::bone_of(int skeleton_bone) const {
  for (int i = 0; i < bone_count(); ++i)
    if (bones_[size_t(i)].skeleton_bone == skeleton_bone) return i;
  return -1;
}

PoseUpdate SkeletonTree::update_pose(Span<const BonePose> bone_poses) {
  PoseUpdate u;
  if (!valid_) {
    u.error = Message::format("update_pose: the tree is not built");
    return u;
  }
  if (bone_poses.size != bone_count()) {
    u.error = Message::format("update_pose: %d bone poses given for a tree of %d bones", bone_poses.size, bone_count());
    return u;
  }
  bool shape_changed = false;
  for (int i = 0; i < bone_poses.size; ++i) {
    const BonePose& p = bone_poses[i];
    const char* name = bones_[size_t(i)].name.c_str();
    if (!so3::finite(p.position)) {
      u.error = Message::format("bone '%s': pose position (%g, %g, %g) is not finite; give it a finite position", name,
                                p.position.x, p.position.y, p.position.z);
      return u;
    }
    if (!so3::finite(p.scale)) {
      u.error = Message::format("bone '%s': pose scale (%g, %g, %g) is not finite; give it a finite scale", name,
                                p.scale.x, p.scale.y, p.scale.z);
      return u;
    }
    const BonePose& old = poses_[size_t(i)];
    if (p.scale != old.scale || (i > 0 && p.position != old.position)) shape_changed = true;
  }
  if (shape_changed) {
    for (int i = 0; i < bone_poses.size; ++i) desc_.bones[size_t(i)].pose = bone_poses[i];
    Tree previous = tree_;
    if (Message e = build_tree(); !e.empty()) {
      tree_ = previous;
      u.error = e;
      return u;
    }
    u.shape_changed = true;
  }
  for (int i = 0; i < bone_poses.size; ++i) poses_[size_t(i)] = bone_poses[i];
  root_shift_ = desc_.floating_root ? glm::dvec3(0.0) : poses_[0].position - built_root_position_;
  return u;
}

void SkeletonTree::params_from_pose(double* params) const {
  if (!valid_) return;
  for (int i = 0; i < bone_count(); ++i)
    joint_params_from_rotation(tree_.joint_type(i), tree_.rest_rotation(i), tree_.axis(i), tree_.limits(i),
                               poses_[size_t(i)].rotation, params + tree_.dof_offset(i));
  if (tree_.floating_root()) {
    const glm::dvec3 t = poses_[0].position - built_root_position_;
    params[0] = t.x;
    params[1] = t.y;
    params[2] = t.z;
  }
}

bool SkeletonTree::pose_from_params(const double* params, Span<glm::dquat> local_rotations,
                                    glm::dvec3& root_position) const {
  if (!valid_ || local_rotations.size < bone_count()) return false;
  bool ok = true;
  for (int i = 0; i < bone_count(); ++i) {
    const double* p = params + tree_.dof_offset(i);
    const glm::dquat motion = tree_.joint_type(i) == JointType::kHinge ? glm::angleAxis(p[0], tree_.axis(i))
                                                                       : so3::exp(glm::dvec3(p[0], p[1], p[2]));
    const glm::dquat q = glm::normalize(tree_.rest_rotation(i) * motion);
    ok = ok && so3::finite(q);
    local_rotations[i] = q;
  }
  root_position = tree_.floating_root() ? built_root_position_ + glm::dvec3(params[0], params[1], params[2])
                                        : poses_.empty() ? glm::dvec3(0.0) : poses_[0].position;
  return ok && so3::finite(root_position);
}

int SkeletonTree::pole_upper_bone(int end) const {
  if (!valid_ || end <= 0 || end >= bone_count()) return -1;
  const int mid = tree_.parent(end);
  const int upper = mid >= 0 ? tree_.parent(mid) : -1;
  return upper >= 0 && tree_.joint_type(upper) == JointType::kBall ? upper : -1;
}

bool SkeletonTree::swivel_toward_pole(int end, const glm::dvec3& pole_in_tree, double* params,
                                      TreeWorkspace& ws) const {
  const int upper = pole_upper_bone(end);
  if (upper < 0 || !so3::finite(pole_in_tree)) return false;
  const int mid = tree_.parent(end);
  tree_forward_kinematics(tree_, params, ws);
  const glm::dvec3 a = ws.joint_origins[size_t(upper)];
  const glm::dvec3 k = ws.joint_origins[size_t(mid)];
  const glm::dvec3 b = ws.joint_origins[size_t(end)];
  glm::dvec3 axis = b - a;
  const double length = glm::length(axis);
  if (!(length > 1e-9)) return false;
  axis /= length;
  glm::dvec3 knee = (k - a) - axis * glm::dot(k - a, axis);
  glm::dvec3 pole = (pole_in_tree - a) - axis * glm::dot(pole_in_tree - a, axis);
  const double knee_off = glm::length(knee), pole_off = glm::length(pole);
  // A straight limb (the middle joint within 1 mm per metre of the line) has no bend plane to turn.
  if (!(knee_off > 1e-3 * length) || !(pole_off > 1e-9 * length) || !std::isfinite(pole_off)) return false;
  knee /= knee_off;
  pole /= pole_off;
  const double angle = std::atan2(glm::dot(glm::cross(knee, pole), axis), glm::dot(knee, pole));
  // The upper bone's frame turned about the line in base space: Q' = G Q, so its motion becomes
  // R' = conj(pre) G Q (Q = pre R).
  const glm::dquat turned = glm::normalize(glm::conjugate(ws.joint_pre_rotations[size_t(upper)]) *
                                           glm::angleAxis(angle, axis) * ws.joint_orientations[size_t(upper)]);
  double* p = params + tree_.dof_offset(upper);
  const glm::dvec3 r = so3::log(turned);
  p[0] = r.x;
  p[1] = r.y;
  p[2] = r.z;
  if (tree_.has_limits(upper)) project_joint_params(JointType::kBall, tree_.limits(upper), p);
  return true;
}

void SkeletonTree::posture_stiffness(double* per_dof) const {
  if (!valid_) return;
  const int n = bone_count();
  for (int i = 0; i < n; ++i) {
    // Bone 0's params start at 0: a floating root's translation comes before its rotation.
    const int begin = i == 0 ? 0 : tree_.dof_offset(i);
    const int end = i + 1 < n ? tree_.dof_offset(i + 1) : tree_.dof_count();
    for (int d = begin; d < end; ++d) per_dof[d] = desc_.bones[size_t(i)].joint.posture_stiffness;
  }
}

bool SkeletonTree::spread_look(Span<const int> bones, Span<const double> shares, const glm::dvec3& aim_axis,
                               const glm::dvec3& target_in_tree, double* params, TreeWorkspace& ws) const {
  const int count = bones.size;
  if (!valid_ || count == 0 || shares.size != count || !so3::finite(target_in_tree)) return false;
  const double axis_length = glm::length(aim_axis);
  if (!(axis_length > 1e-12) || !std::isfinite(axis_length)) return false;
  for (int k = 0; k < count; ++k)
    if (bones[k] < 0 || bones[k] >= bone_count()) return false;
  const glm::dvec3 axis_local = aim_axis / axis_length;
  const int end = bones[count - 1];
  const double on_point = kAimAtOnPoint * (tree_.total_length() + glm::length(target_in_tree));
  double shares_left = 0.0;
  for (int k = 0; k < count; ++k) shares_left += std::max(shares[k], 0.0);
  for (int k = 0; k < count; ++k) {
    const double share = std::max(shares[k], 0.0);
    const double fraction = k == count - 1 ? 1.0 : (shares_left > 0.0 ? share / shares_left : 0.0);
    shares_left -= share;
    if (!(fraction > 0.0)) continue;
    tree_forward_kinematics(tree_, params, ws);
    const glm::dvec3 facing = ws.joint_orientations[size_t(end)] * axis_local;
    glm::dvec3 wanted = target_in_tree - ws.joint_origins[size_t(end)];
    const double distance = glm::length(wanted);
    // On the point (as the core's aim goal measures it): no direction to look along, only rounding.
    if (!(distance > on_point)) return k > 0;
    wanted /= distance;
    glm::dvec3 about = glm::cross(facing, wanted);
    const double sine = glm::length(about);
    const double angle = std::atan2(sine, glm::dot(facing, wanted));
    if (!(angle > 1e-12)) return true;
    if (sine > 1e-12) {
      about /= sine;
    } else {  // looking straight away: any axis across the facing one
      about = glm::cross(facing, std::abs(facing.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 1.0, 0.0));
      about = glm::normalize(about);
    }
    // Bone j's frame turned about `about` in base space: Q' = G Q, so its motion becomes
    // R' = conj(pre) G Q (Q = pre R), as in swivel_toward_pole.
    const int j = bones[k];
    const glm::dquat turned = glm::normalize(glm::conjugate(ws.joint_pre_rotations[size_t(j)]) *
                                             glm::angleAxis(fraction * angle, about) *
                                             ws.joint_orientations[size_t(j)]);
    double* p = params + tree_.dof_offset(j);
    if (tree_.joint_type(j) == JointType::kHinge) {
      // The hinge keeps the part of the turn about its axis (swing-twist decomposition).
      const glm::dvec3 h = tree_.axis(j);
      p[0] = 2.0 * std::atan2(glm::dot(glm::dvec3(turned.x, turned.y, turned.z), h), turned.w);
      if (p[0] > so3::kPi) p[0] -= 2.0 * so3::kPi;
      if (p[0] < -so3::kPi) p[0] += 2.0 * so3::kPi;
      if (tree_.has_limits(j)) project_joint_params(JointType::kHinge, tree_.limits(j), p);
    } else {
      const glm::dvec3 r = so3::log(turned);
      p[0] = r.x;
      p[1] = r.y;
      p[2] = r.z;
      if (tree_.has_limits(j)) project_joint_params(JointType::kBall, tree_.limits(j), p);
    }
  }
  return true;
}

Message SkeletonTree::scale_warning() const {
  if (!valid_ || non_uniform_bone_ < 0) return Message();
  const glm::dvec3& s = poses_[size_t(non_uniform_bone_)].scale;
  return Message::format("bone '%s' has a non-uniform scale (%g, %g, %g): IK treats the body as rigid, so effectors "
                         "may miss their targets; scale it uniformly",
                         bones_[size_t(non_uniform_bone_)].name.c_str(), s.x, s.y, s.z);
}

}  // namespace ikchain::godot
