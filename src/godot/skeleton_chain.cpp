#include "skeleton_chain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "ikchain/so3.hpp"

namespace ikchain::godot {

namespace {

constexpr double kTwoPi = 2.0 * so3::kPi;

bool finite(const glm::dmat3& m) {
  for (int c = 0; c < 3; ++c)
    if (!so3::finite(m[c])) return false;
  return true;
}
bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// A rotation given by the caller (a bone pose): unit length, or the identity when it is zero or
// not finite (Skeleton3D accepts any quaternion; the mapping never propagates a NaN).
glm::dquat unit_or_identity(const glm::dquat& q) {
  const double len = glm::length(q);
  if (!(len > 1e-12) || !std::isfinite(len)) return glm::dquat(1.0, 0.0, 0.0, 0.0);
  return q / len;
}

glm::dvec3 axis_vector(TipAxis axis) {
  switch (axis) {
    case TipAxis::kPlusX: return glm::dvec3(1, 0, 0);
    case TipAxis::kMinusX: return glm::dvec3(-1, 0, 0);
    case TipAxis::kPlusY: return glm::dvec3(0, 1, 0);
    case TipAxis::kMinusY: return glm::dvec3(0, -1, 0);
    case TipAxis::kPlusZ: return glm::dvec3(0, 0, 1);
    case TipAxis::kMinusZ: return glm::dvec3(0, 0, -1);
  }
  return glm::dvec3(0.0);
}

bool is_uniform(const glm::dvec3& s) {
  const double m = std::max({std::abs(s.x), std::abs(s.y), std::abs(s.z)});
  return std::abs(s.x - s.y) <= 1e-6 * m && std::abs(s.x - s.z) <= 1e-6 * m;
}

// x wrapped into [-pi, pi].
double wrap_angle(double x) { return std::remainder(x, kTwoPi); }

// A hinge angle (in (-pi, pi]) projected onto [lo, hi] on the circle: the angle itself or one of
// its 2 pi turns when inside (limits may span more than (-pi, pi]), else the nearer limit.
double clamp_hinge(double angle, double lo, double hi) {
  for (double turn : {0.0, kTwoPi, -kTwoPi})
    if (angle + turn >= lo && angle + turn <= hi) return angle + turn;
  return std::abs(wrap_angle(angle - lo)) <= std::abs(wrap_angle(angle - hi)) ? lo : hi;
}

// T(position) R(rotation) S(scale) as an affine 4x4 (column-major).
glm::dmat4 local_transform(const glm::dvec3& position, const glm::dquat& rotation, const glm::dvec3& scale) {
  const glm::dmat3 r = glm::mat3_cast(rotation);
  glm::dmat4 m(1.0);
  for (int c = 0; c < 3; ++c) m[c] = glm::dvec4(r[c] * scale[c], 0.0);
  m[3] = glm::dvec4(position, 1.0);
  return m;
}

// The core offsets of a chain shape: offset_i = (s_0 * ... * s_{i-1}) * position_i, the tip from
// the tip bone's position (or the extension, scaled by the tip bone too). Returns the first joint
// bone with a non-uniform scale, -1 when none.
int shape_offsets(Span<const BonePose> poses, int joints, bool extend, const glm::dvec3& extension,
                  glm::dvec3* offsets, glm::dvec3& tip_offset) {
  glm::dvec3 inherited_scale(1.0);
  int non_uniform = -1;
  for (int i = 0; i < joints; ++i) {
    offsets[i] = inherited_scale * poses[i].position;
    inherited_scale *= poses[i].scale;
    if (non_uniform < 0 && !is_uniform(poses[i].scale)) non_uniform = i;
  }
  tip_offset = inherited_scale * (extend ? extension : poses[joints].position);
  return non_uniform;
}

// True when a core build error's field (BuildError::field) is set in an IKChainJoint
// (JointSettings), not one that comes from the bones' poses (offset_translation, rest_rotation).
bool is_joint_setting(const char* field) {
  for (const char* setting : {"hinge_axis", "limits.hinge_min", "limits.hinge_max", "limits.cone_angle",
                              "limits.twist_axis", "limits.twist_min", "limits.twist_max"})
    if (std::strcmp(field, setting) == 0) return true;
  return false;
}

double shape_length(const glm::dvec3* offsets, int joints, const glm::dvec3& tip_offset) {
  double total = glm::length(tip_offset);
  for (int i = 1; i < joints; ++i) total += glm::length(offsets[i]);
  return total;
}

}  // namespace

namespace {
// Gram-Schmidt on the basis' columns; false when one of them vanishes (a zero or degenerate
// scale) or the basis is not finite.
bool orthonormal_rotation(const glm::dmat3& basis, glm::dquat& out) {
  if (!finite(basis)) return false;
  glm::dvec3 x = basis[0], y = basis[1], z = basis[2];
  const double lx = glm::length(x);
  if (!(lx > 1e-12)) return false;
  x /= lx;
  y -= x * glm::dot(x, y);
  const double ly = glm::length(y);
  if (!(ly > 1e-12)) return false;
  y /= ly;
  z -= x * glm::dot(x, z) + y * glm::dot(y, z);
  const double lz = glm::length(z);
  if (!(lz > 1e-12)) return false;
  z /= lz;
  glm::dmat3 m(x, y, z);
  if (glm::determinant(m) < 0.0) m = -m;
  out = glm::normalize(glm::quat_cast(m));
  return true;
}
}  // namespace

glm::dquat rotation_of_basis(const glm::dmat3& basis) {
  glm::dquat q(1.0, 0.0, 0.0, 0.0);
  return orthonormal_rotation(basis, q) ? q : glm::dquat(1.0, 0.0, 0.0, 0.0);
}

bool has_rotation(const glm::dmat3& basis) {
  glm::dquat ignored;
  return orthonormal_rotation(basis, ignored);
}

bool rotation_of_basis(const glm::dmat3& basis, glm::dquat& out) { return orthonormal_rotation(basis, out); }

// The core joint of one bone's settings. A disabled limit is not passed on (nor checked), and
// neither is the twist axis when no limit of the ball joint uses it.
JointDesc core_joint_of(const JointSettings& s) {
  JointDesc j;
  j.type = s.type;
  if (s.type == JointType::kHinge) {
    j.axis = s.hinge_axis_in_bone;
    if (s.hinge_limit_enabled) {
      j.limits.has_hinge_limit = true;
      j.limits.hinge_min = s.hinge_min;
      j.limits.hinge_max = s.hinge_max;
    }
    return j;
  }
  if (s.cone_limit_enabled || s.twist_limit_enabled) j.limits.twist_axis = s.twist_axis_in_bone;
  if (s.cone_limit_enabled) {
    j.limits.has_cone_limit = true;
    j.limits.cone_angle = s.cone_angle;
  }
  if (s.twist_limit_enabled) {
    j.limits.has_twist_limit = true;
    j.limits.twist_min = s.twist_min;
    j.limits.twist_max = s.twist_max;
  }
  return j;
}

void joint_params_from_rotation(JointType type, const glm::dquat& rest_rotation, const glm::dvec3& axis,
                                const JointLimits& limits, const glm::dquat& local_rotation, double* p) {
  const double len = glm::length(local_rotation);
  // A zero or non-finite pose rotation: start from the rest rotation.
  const glm::dquat joint_motion = (len > 1e-12 && std::isfinite(len))
                                      ? glm::conjugate(rest_rotation) * (local_rotation / len)
                                      : glm::dquat(1.0, 0.0, 0.0, 0.0);
  if (type == JointType::kHinge) {
    glm::dquat swing;
    double angle = 0.0;
    so3::swing_twist(joint_motion, axis, swing, angle);
    p[0] = limits.has_hinge_limit ? clamp_hinge(angle, limits.hinge_min, limits.hinge_max) : angle;
    return;
  }
  const glm::dvec3 r = so3::log(joint_motion);
  p[0] = r.x;
  p[1] = r.y;
  p[2] = r.z;
  if (limits.has_hinge_limit || limits.has_cone_limit || limits.has_twist_limit) project_joint_params(type, limits, p);
}

glm::dquat godot_slerp(const glm::dquat& from, const glm::dquat& to, double weight) {
  double cosom = glm::dot(from, to);
  glm::dquat to1 = to;
  if (cosom < 0.0) {
    cosom = -cosom;
    to1 = -to;
  }
  double scale0 = 1.0 - weight, scale1 = weight;
  if (1.0 - cosom > 1e-5) {  // Godot's CMP_EPSILON
    const double omega = std::acos(cosom);
    const double sinom = std::sin(omega);
    scale0 = std::sin((1.0 - weight) * omega) / sinom;
    scale1 = std::sin(weight * omega) / sinom;
  }
  return unit_or_identity(glm::dquat(scale0 * from.w + scale1 * to1.w, scale0 * from.x + scale1 * to1.x,
                                     scale0 * from.y + scale1 * to1.y, scale0 * from.z + scale1 * to1.z));
}

void blend_rotations(Span<const glm::dquat> old_rotations, Span<const glm::dquat> new_rotations, double influence,
                     Span<glm::dquat> blended) {
  const int n = std::min({old_rotations.size, new_rotations.size, blended.size});
  if (!(influence < 1.0)) {  // Skeleton3D blends only below 1 (a NaN influence blends nothing either)
    for (int i = 0; i < n; ++i) blended[i] = new_rotations[i];
    return;
  }
  influence = std::max(influence, 0.0);
  for (int i = 0; i < n; ++i) {
    const glm::dquat from = old_rotations[i];
    const glm::dquat to = new_rotations[i];
    // Skeleton3D skips bones the modifier left unchanged.
    blended[i] = (from == to) ? from : godot_slerp(unit_or_identity(from), unit_or_identity(to), influence);
  }
}

// ---------------------------------------------------------------- BaseFrame

bool BaseFrame::make(const glm::dmat4& skeleton_global, const glm::dmat4& base_bone_in_skeleton, BaseFrame& out) {
  const glm::dmat4 base_to_global = skeleton_global * base_bone_in_skeleton;
  if (!finite(base_to_global)) return false;
  const double det = glm::determinant(glm::dmat3(base_to_global));
  if (!(std::abs(det) > 1e-18)) return false;
  const glm::dmat4 global_to_base = glm::inverse(base_to_global);
  if (!finite(global_to_base)) return false;
  out.base_to_global = base_to_global;
  out.global_to_base = global_to_base;
  out.rotation_global_from_base = rotation_of_basis(glm::dmat3(base_to_global));
  return true;
}

glm::dvec3 BaseFrame::point_in_base(const glm::dvec3& point_global) const {
  return glm::dvec3(global_to_base * glm::dvec4(point_global, 1.0));
}

glm::dquat BaseFrame::rotation_in_base(const glm::dmat4& transform_global) const {
  return rotation_in_base(rotation_of_basis(glm::dmat3(transform_global)));
}

glm::dquat BaseFrame::rotation_in_base(const glm::dquat& rotation_global) const {
  return glm::normalize(glm::conjugate(rotation_global_from_base) * rotation_global);
}

// ---------------------------------------------------------------- build

Message SkeletonChain::check_pose(Span<const BonePose> poses) const {
  for (int i = 0; i < poses.size; ++i) {
    const char* name = bones_[size_t(i)].name.c_str();
    const glm::dvec3& p = poses[i].position;
    if (!so3::finite(p))
      return Message::format("bone '%s': pose position (%g, %g, %g) is not finite; give it a finite position",
                             name, p.x, p.y, p.z);
    const glm::dvec3& s = poses[i].scale;
    if (!so3::finite(s))
      return Message::format("bone '%s': pose scale (%g, %g, %g) is not finite; give it a finite scale", name,
                             s.x, s.y, s.z);
  }
  return Message();
}

Message SkeletonChain::build(const SkeletonChainDesc& desc) {
  const Message error = build_from(desc);
  if (!error.empty()) {
    // Nothing half-built survives: every per-frame function sees an empty chain and does nothing.
    valid_ = false;
    joint_count_ = 0;
    non_uniform_bone_ = -1;
    bones_.clear();
    poses_.clear();
    chain_ = Chain();
  }
  return error;
}

Message SkeletonChain::build_from(const SkeletonChainDesc& desc) {
  valid_ = false;
  chain_ = Chain();
  const int m = int(desc.bones.size());
  if (m == 0) return Message::format("no bones: set root_bone and tip_bone");
  if (m == 1 && !desc.extend_tip_bone)
    return Message::format("root_bone and tip_bone are the same bone '%s': pick a tip_bone below root_bone, or "
                           "turn on extend_tip_bone for a one-joint chain",
                           desc.bones[0].name.c_str());
  const int tip_axis = int(desc.tip_extension_axis);
  if (desc.extend_tip_bone) {
    if (tip_axis < 0 || tip_axis > 5)
      return Message::format("tip_extension_axis (%d) must be one of AXIS_PLUS_X (0) .. AXIS_MINUS_Z (5)", tip_axis);
    if (!(desc.tip_extension_length >= 0.0) || !std::isfinite(desc.tip_extension_length))
      return Message::format("tip_extension_length (%g) must be finite and >= 0; pick a minus tip_extension_axis "
                             "to extend the other way",
                             desc.tip_extension_length);
  }

  bones_.clear();
  poses_.clear();
  for (const ChainBoneDesc& b : desc.bones) {
    bones_.push_back({b.name, b.skeleton_bone});
    poses_.push_back(b.pose);
  }
  extend_tip_bone_ = desc.extend_tip_bone;
  tip_extension_ = desc.extend_tip_bone ? axis_vector(desc.tip_extension_axis) * desc.tip_extension_length
                                        : glm::dvec3(0.0);
  const int n = desc.extend_tip_bone ? m : m - 1;
  joint_count_ = n;

  if (Message e = check_pose(Span<const BonePose>(poses_)); !e.empty()) return e;

  // The limits themselves are validated by the core builder (its messages are mapped to bone
  // names below); here only what the core cannot know: the rest basis and the joint types the
  // Godot layer maps (ball and hinge).
  std::vector<JointDesc> joints;
  joints.reserve(size_t(n));
  for (int i = 0; i < n; ++i) {
    const ChainBoneDesc& b = desc.bones[size_t(i)];
    const char* name = b.name.c_str();
    if (!finite(b.rest_basis_in_parent) || std::abs(glm::determinant(b.rest_basis_in_parent)) < 1e-18)
      return Message::format("bone '%s': rest basis is not finite or has zero scale; fix the bone's rest", name);
    if (b.joint.type != JointType::kBall && b.joint.type != JointType::kHinge)
      return Message::format("joint '%s': type (%d) must be JOINT_BALL (0) or JOINT_HINGE (1)", name,
                             int(b.joint.type));
    JointDesc j = core_joint_of(b.joint);
    j.rest_rotation = rotation_of_basis(b.rest_basis_in_parent);
    joints.push_back(j);
  }

  offsets_.assign(size_t(n), glm::dvec3(0.0));
  non_uniform_bone_ =
      shape_offsets(Span<const BonePose>(poses_), n, extend_tip_bone_, tip_extension_, offsets_.data(), tip_offset_);
  if (!(shape_length(offsets_.data(), n, tip_offset_) > 1e-9))
    return Message::format("zero-length chain: the bones from '%s' to '%s' are all at one point (pose positions "
                           "zero or scaled to zero); pick bones that are apart%s",
                           bones_.front().name.c_str(), bones_.back().name.c_str(),
                           extend_tip_bone_ ? " or set tip_extension_length" : "");
  ChainBuilder builder;
  for (int i = 0; i < n; ++i) {
    joints[size_t(i)].offset_translation = offsets_[size_t(i)];
    builder.add_joint(joints[size_t(i)]);
  }
  builder.set_tip_offset(tip_offset_);
  // The core's JointDesc::axis is IKChainJoint.hinge_axis to the user: errors name the property.
  if (const BuildError e = builder.build(chain_, "hinge_axis"); !e.ok()) {
    // The builder names a joint by its index (joint 1, "hinge_min (1.5) > hinge_max (0.5)"); the
    // user knows it by its bone, and sets its limits in that bone's IKChainJoint.
    if (e.joint >= 0 && e.joint < n)
      return Message::format("joint '%s': %s%s", bones_[size_t(e.joint)].name.c_str(), e.reason.c_str(),
                             is_joint_setting(e.field) ? "; fix it in the bone's IKChainJoint" : "");
    return Message::format("cannot build the chain from '%s' to '%s': %s", bones_.front().name.c_str(),
                           bones_.back().name.c_str(), e.message.c_str());
  }

  tip_rotation_in_effector_ =
      extend_tip_bone_ ? glm::dquat(1.0, 0.0, 0.0, 0.0) : unit_or_identity(poses_[size_t(n)].rotation);
  bones_in_base_.assign(size_t(m), glm::dmat4(1.0));
  // measure_pose() only needs the frames measure_goals() reads.
  frames_ = Workspace();
  frames_.joints = n;
  frames_.joint_origins.assign(size_t(n), glm::dvec3(0.0));
  frames_.joint_orientations.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
  valid_ = true;
  return Message();
}

// ---------------------------------------------------------------- per frame

bool SkeletonChain::shape_differs(Span<const BonePose> bone_poses) const {
  if (bone_poses.size != int(poses_.size())) return true;
  for (int i = 0; i < bone_poses.size; ++i) {
    const BonePose& a = bone_poses[i];
    const BonePose& b = poses_[size_t(i)];
    // != on purpose: a NaN never compares equal, so a bad value is always re-checked.
    if (a.position != b.position || a.scale != b.scale) return true;
  }
  return false;
}

PoseUpdate SkeletonChain::update_pose(Span<const BonePose> bone_poses) {
  PoseUpdate u;
  if (!valid_) {
    u.error = Message::format("update_pose: the chain is not built");
    return u;
  }
  if (bone_poses.size != bone_count()) {
    u.error = Message::format("update_pose: %d bone poses given for a chain of %d bones", bone_poses.size,
                              bone_count());
    return u;
  }
  const int n = joint_count_;
  if (shape_differs(bone_poses)) {
    if (Message e = check_pose(bone_poses); !e.empty()) {
      u.error = e;
      return u;
    }
    // Offsets from the new shape, into the chain in place; on failure everything stays as it was.
    // offsets_ is only a staging buffer (the chain keeps its own copy), so it may be overwritten.
    glm::dvec3 tip_offset(0.0);
    const int non_uniform =
        shape_offsets(bone_poses, n, extend_tip_bone_, tip_extension_, offsets_.data(), tip_offset);
    if (!(shape_length(offsets_.data(), n, tip_offset) > 1e-9)) {
      u.error = Message::format("zero-length chain: the bones from '%s' to '%s' are all at one point (pose "
                                "positions zero or scaled to zero); pick bones that are apart",
                                bones_.front().name.c_str(), bones_.back().name.c_str());
      return u;
    }
    if (Message e = chain_.set_offsets(offsets_.data(), n, tip_offset); !e.empty()) {
      u.error = Message::format("cannot update the chain: %s", e.c_str());
      return u;
    }
    tip_offset_ = tip_offset;
    non_uniform_bone_ = non_uniform;
    u.shape_changed = true;
  }
  for (int i = 0; i < bone_poses.size; ++i) poses_[size_t(i)] = bone_poses[i];
  if (!extend_tip_bone_) tip_rotation_in_effector_ = unit_or_identity(poses_[size_t(n)].rotation);
  return u;
}

Message SkeletonChain::scale_warning() const {
  if (non_uniform_bone_ < 0) return Message();
  const glm::dvec3& s = poses_[size_t(non_uniform_bone_)].scale;
  return Message::format("bone '%s' has a non-uniform scale (%g, %g, %g): IK treats the chain as rigid, so the "
                         "tip may miss the target (the result reports the real error); scale it uniformly",
                         bones_[size_t(non_uniform_bone_)].name.c_str(), s.x, s.y, s.z);
}

void SkeletonChain::params_from_rotations(Span<const glm::dquat> local_rotations, double* params) const {
  const int n = std::min(joint_count_, local_rotations.size);
  for (int i = 0; i < n; ++i)
    joint_params_from_rotation(chain_.joint_type(i), chain_.rest_rotation(i), chain_.axis(i), chain_.limits(i),
                               local_rotations[i], params + chain_.dof_offset(i));
}

bool SkeletonChain::rotations_from_params(const double* params, Span<glm::dquat> local_rotations) const {
  const int n = std::min(joint_count_, local_rotations.size);
  bool ok = true;
  for (int i = 0; i < n; ++i) {
    const glm::dquat q = glm::normalize(chain_.rest_rotation(i) * joint_motion(chain_, i, params));
    ok = ok && so3::finite(q);
    local_rotations[i] = q;
  }
  return ok;
}

// ---------------------------------------------------------------- goals

glm::dquat SkeletonChain::effector_orientation_for_tip_bone(const glm::dquat& tip_bone_rotation_in_base) const {
  return glm::normalize(tip_bone_rotation_in_base * glm::conjugate(tip_rotation_in_effector_));
}

glm::dvec3 SkeletonChain::aim_axis_in_effector(const glm::dvec3& aim_axis_in_tip_bone) const {
  return tip_rotation_in_effector_ * aim_axis_in_tip_bone;
}

bool SkeletonChain::aim_direction_in_base(const glm::dvec3& target_in_base, const glm::dvec3& from_in_base,
                                          glm::dvec3& direction_in_base) {
  const glm::dvec3 d = target_in_base - from_in_base;
  const double len = glm::length(d);
  if (!std::isfinite(len) || !(len > 1e-9)) return false;
  direction_in_base = d / len;
  return true;
}

int SkeletonChain::effector_of_bone(int bone) const {
  if (bone < 1 || bone >= bone_count()) return -1;
  return bone;
}

int SkeletonChain::chain_bone_of(int skeleton_bone) const {
  for (int i = 0; i < bone_count(); ++i)
    if (bones_[size_t(i)].skeleton_bone == skeleton_bone) return i;
  return -1;
}

// ---------------------------------------------------------------- exact pose

void SkeletonChain::forward_kinematics_affine(Span<const glm::dquat> joint_rotations) {
  if (!valid_) return;
  const int m = bone_count();
  glm::dmat4 global(1.0);
  for (int i = 0; i < m; ++i) {
    const BonePose& p = poses_[size_t(i)];
    const glm::dquat rotation = unit_or_identity(i < joint_count_ && i < joint_rotations.size ? joint_rotations[i]
                                                                                               : p.rotation);
    global = global * local_transform(p.position, rotation, p.scale);
    bones_in_base_[size_t(i)] = global;
  }
  effector_in_base_ = extend_tip_bone_ ? glm::dvec3(global * glm::dvec4(tip_extension_, 1.0)) : glm::dvec3(global[3]);
}

GoalErrors SkeletonChain::measure_pose(Span<const glm::dquat> joint_rotations, Span<const Goal> goals) {
  bool measurable = valid_;
  for (const Goal& g : goals) measurable = measurable && g.effector <= joint_count_;
  if (!measurable) {  // no chain, or a goal on no effector of it: no error can be claimed
    GoalErrors bad;
    bad.cost = bad.combined = bad.max_position = bad.max_orientation = HUGE_VAL;
    return bad;
  }
  forward_kinematics_affine(joint_rotations);
  for (int i = 0; i < joint_count_; ++i) {
    frames_.joint_origins[size_t(i)] = glm::dvec3(bones_in_base_[size_t(i)][3]);
    frames_.joint_orientations[size_t(i)] = rotation_of_basis(glm::dmat3(bones_in_base_[size_t(i)]));
  }
  frames_.tip = effector_in_base_;
  return measure_goals(chain_, goals, frames_);
}

GoalErrors SkeletonChain::measure_blended_pose(Span<const glm::dquat> old_rotations,
                                               Span<const glm::dquat> new_rotations, double influence,
                                               Span<const Goal> goals, Span<glm::dquat> blended) {
  blend_rotations(old_rotations, new_rotations, influence, blended);
  return measure_pose(Span<const glm::dquat>(blended), goals);
}

}  // namespace ikchain::godot
