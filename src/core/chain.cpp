#include "ikchain/chain.hpp"

#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/quat_ops.hpp"
#include "ikchain/so3.hpp"

namespace ikchain {

namespace {

using so3::scaled_length;

// Bone i's reach, the farthest joint i+1 (or the tip) can be from joint i's origin: the length of
// the offset to it, plus a prismatic joint's longest slide. build() and set_offsets() both use this
// one definition, so reach bounds (unreachable verdicts, skipped restarts) cannot disagree.
double bone_reach(JointType type, const JointLimits& limits, const glm::dvec3& offset_to_next) {
  return glm::length(offset_to_next) + longest_slide(type, limits);
}

}  // namespace

BuildError normalize_joint(int i, const JointDesc& j, JointDesc& out, const char* offset_name, const char* axis_name) {
  auto fail = [&](const char* field, const Message& reason) {
    BuildError e;
    e.joint = i;
    e.field = field;
    e.reason = reason;
    e.message = Message::format("joint %d: %s", i, reason.c_str());
    return e;
  };
  if (!within_magnitude(j.offset_translation))
    return fail(offset_name,
                Message::format("%s (%g, %g, %g) must be finite, each component within "
                                "+-%g m", offset_name, j.offset_translation.x, j.offset_translation.y, j.offset_translation.z,
                                kMaxMagnitude));
  const double rest_len = scaled_length(j.rest_rotation);
  if (!std::isfinite(rest_len) || rest_len < 1e-9)
    return fail("rest_rotation", Message::format("rest_rotation must be a finite non-zero quaternion"));
  if (!is_known_joint_type(j.type)) return fail("type", Message::format("unknown joint type"));
  const JointTraits& traits = joint_traits(j.type);
  JointLimits l = j.limits;
  // The axis a joint type does not use is stored as its default, so the chain holds no NaN.
  glm::dvec3 axis(0.0, 0.0, 1.0);
  if (traits.uses_axis) {
    axis = j.axis;
    const double len = scaled_length(axis);
    if (!std::isfinite(len) || len < 1e-9)
      return fail(axis_name, traits.turns ? Message::format("%s must be a finite non-zero vector", axis_name)
                                          : Message::format("%s (the slide axis) must be a finite non-zero vector",
                                                            axis_name));
    axis /= len;
  }
  if (traits.cone_twist_limits) {
    const double len = scaled_length(l.twist_axis);
    if (!std::isfinite(len) || len < 1e-9)
      return fail("limits.twist_axis",
                  Message::format("limits.twist_axis must be a finite non-zero vector"));
    l.twist_axis /= len;
    if (l.has_cone_limit && !(l.cone_angle >= 0.0 && l.cone_angle <= so3::kPi))
      return fail("limits.cone_angle",
                  Message::format("cone_angle must be in [0, pi], got %g", l.cone_angle));
    if (l.has_twist_limit) {
      if (!(l.twist_min >= -so3::kPi && l.twist_max <= so3::kPi))
        return fail("limits.twist_min",
                    Message::format("twist_min/twist_max must be within [-pi, pi]"));
      if (l.twist_min > l.twist_max)
        return fail("limits.twist_min",
                    Message::format("twist_min (%g) > twist_max (%g)", l.twist_min, l.twist_max));
    }
  } else if (!traits.turns) {  // a slide: its range is required (the reach bounds need it)
    l.twist_axis = glm::dvec3(0.0, 1.0, 0.0);
    if (!l.has_slide_limit || !within_magnitude(glm::dvec3(l.slide_min, l.slide_max, 0.0)) || l.slide_min > l.slide_max)
      return fail("limits.slide_min",
                  Message::format("a prismatic joint needs has_slide_limit with finite slide_min <= "
                                  "slide_max (its slide range, m)"));
  } else {
    l.twist_axis = glm::dvec3(0.0, 1.0, 0.0);
    if (l.has_hinge_limit) {
      if (!std::isfinite(l.hinge_min) || !std::isfinite(l.hinge_max))
        return fail("limits.hinge_min", Message::format("hinge_min/hinge_max must be finite"));
      if (l.hinge_min > l.hinge_max)
        return fail("limits.hinge_min",
                    Message::format("hinge_min (%g) > hinge_max (%g)", l.hinge_min, l.hinge_max));
    }
  }
  out = j;
  out.rest_rotation = glm::normalize(j.rest_rotation / rest_len);
  out.axis = axis;
  out.limits = l;
  return BuildError();
}

ChainBuilder& ChainBuilder::add_joint(const JointDesc& joint) {
  joints_.push_back(joint);
  return *this;
}

ChainBuilder& ChainBuilder::set_tip_offset(const glm::dvec3& tip_offset) {
  tip_offset_ = tip_offset;
  return *this;
}

ChainBuilder& ChainBuilder::set_tip_rotation(const glm::dquat& tip_rotation) {
  tip_rotation_ = tip_rotation;
  return *this;
}

ChainBuilder& ChainBuilder::set_tip_frame(const glm::dvec3& tip_offset, const glm::dquat& tip_rotation) {
  tip_offset_ = tip_offset;
  tip_rotation_ = tip_rotation;
  return *this;
}

void ChainBuilder::clear() {
  joints_.clear();
  tip_offset_ = glm::dvec3(0.0);
  tip_rotation_ = glm::dquat(1.0, 0.0, 0.0, 0.0);
}

bool Chain::has_limits(int i) const { return has_joint_limits(joint_type(i), limits_[i]); }

BuildError ChainBuilder::build(Chain& out, const char* axis_name) const {
  out = Chain();
  // A problem of the whole chain, not of one joint.
  auto chain_error = [](const char* field, const Message& reason) {
    BuildError e;
    e.field = field;
    e.message = reason;
    e.reason = reason;
    return e;
  };
  const int n = static_cast<int>(joints_.size());
  if (n == 0) return chain_error("joints", Message::format("chain has 0 joints: add at least one joint"));
  if (!within_magnitude(tip_offset_))
    return chain_error("tip_offset",
                       Message::format("tip_offset (%g, %g, %g) must be finite, each component within +-%g m",
                                       tip_offset_.x, tip_offset_.y, tip_offset_.z, kMaxMagnitude));
  if (!so3::finite(tip_rotation_) || !(scaled_length(tip_rotation_) >= 1e-9))
    return chain_error("tip_rotation", Message::format("tip_rotation must be a finite non-zero quaternion"));

  Chain c;
  c.joint_count_ = n;
  c.joints_.resize(n);
  c.rest_rotations_.resize(n);
  c.limits_.resize(n);
  c.bone_lengths_.resize(n);

  int dofs = 0;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    const BuildError error = normalize_joint(i, joints_[i], j, "offset_translation", axis_name);
    if (!error.ok()) return error;
    const JointLimits& l = j.limits;
    const glm::dvec3& axis = j.axis;
    Chain::JointRecord& rec = c.joints_[i];
    rec.type = static_cast<uint8_t>(j.type);
    rec.dof_offset = dofs;
    dofs += joint_dof_count(j.type);
    rec.offset_translation = j.offset_translation;
    c.rest_rotations_[i] = j.rest_rotation;
    const glm::dquat& r = c.rest_rotations_[i];
    rec.rest_identity = (r.w == 1.0 && r.x == 0.0 && r.y == 0.0 && r.z == 0.0) ? 1 : 0;
    rec.axis = axis;
    rec.offset_direction = quat_ops::direction_code(j.offset_translation);
    rec.axis_direction = quat_ops::direction_code(axis);
    c.limits_[i] = l;
  }
  c.dof_count_ = dofs;
  c.tip_offset_ = tip_offset_;
  c.tip_rotation_ = so3::normalized(tip_rotation_);
  c.tip_direction_ = quat_ops::direction_code(tip_offset_);
  c.all_hinges_ = true;
  for (int i = 0; i < n; ++i) c.all_hinges_ = c.all_hinges_ && c.joint_type(i) == JointType::kHinge;
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    const glm::dvec3& next = (i + 1 < n) ? c.joints_[i + 1].offset_translation : tip_offset_;
    c.bone_lengths_[i] = bone_reach(c.joint_type(i), c.limits_[i], next);
    if (!turns(c.joint_type(i)) && c.first_prismatic_ < 0) c.first_prismatic_ = i;
    total += c.bone_lengths_[i];
  }
  if (!(total > 1e-9))
    return chain_error("offset_translation", Message::format("zero-length chain: every bone has length 0"));
  c.total_length_ = total;
  for (int i = 0; i < n; ++i) c.any_limits_ = c.any_limits_ || c.has_limits(i);
  {
    Workspace ws(c, 1);
    const std::vector<double> rest(static_cast<size_t>(dofs), 0.0);
    forward_kinematics(c, rest.data(), ws);
    compute_dof_axes(c, rest.data(), ws);
    c.rest_joint_origins_ = ws.joint_origins;
    c.rest_dof_axes_ = ws.dof_axes;
    c.rest_tip_ = ws.tip;
  }
  out = std::move(c);
  return BuildError();
}

Message Chain::set_offsets(const glm::dvec3* offset_translations, int count, const glm::dvec3& tip_offset) {
  if (count != joint_count_)
    return Message::format("set_offsets: %d offsets given for a chain of %d joints", count, joint_count_);
  // The bounds build() checks: beyond +-kMaxMagnitude, squared lengths and errors overflow to inf.
  for (int i = 0; i < count; ++i) {
    const glm::dvec3& t = offset_translations[i];
    if (!within_magnitude(t))
      return Message::format("joint %d: offset_translation (%g, %g, %g) must be finite, each component within "
                             "+-%g m", i, t.x, t.y, t.z, kMaxMagnitude);
  }
  if (!within_magnitude(tip_offset))
    return Message::format("tip_offset (%g, %g, %g) must be finite, each component within +-%g m", tip_offset.x,
                           tip_offset.y, tip_offset.z, kMaxMagnitude);
  auto reach = [&](int i) {
    return bone_reach(joint_type(i), limits_[i], i + 1 < count ? offset_translations[i + 1] : tip_offset);
  };
  double total = 0.0;
  for (int i = 0; i < count; ++i) total += reach(i);
  if (!(total > 1e-9)) return Message::format("zero-length chain: every bone has length 0");

  for (int i = 0; i < count; ++i) {
    joints_[i].offset_translation = offset_translations[i];
    joints_[i].offset_direction = quat_ops::direction_code(offset_translations[i]);
    bone_lengths_[i] = reach(i);
  }
  tip_offset_ = tip_offset;
  tip_direction_ = quat_ops::direction_code(tip_offset);
  total_length_ = total;
  // The rest pose's frames (params = 0): rotations do not depend on the offsets, so only the
  // origins and the tip move; the rest DOF axes stay valid.
  // The same arithmetic as forward_kinematics() at params = 0, so the two agree to the last bit.
  using namespace quat_ops;
  Quat orientation{1.0, 0.0, 0.0, 0.0};
  glm::dvec3 origin(0.0);
  for (int i = 0; i < count; ++i) {
    origin += rotate_coded(orientation, joints_[i].offset_translation, Direction(joints_[i].offset_direction));
    rest_joint_origins_[i] = origin;
    if (joints_[i].rest_identity == 0) orientation = multiply(orientation, from_glm(rest_rotations_[i]));
  }
  rest_tip_ = origin + rotate_coded(orientation, tip_offset_, Direction(tip_direction_));
  return Message();
}

}  // namespace ikchain
