// Joint types as traits (issue 14, item 5): what each JointType is - how many params, what they
// measure, whether it turns its frame, which axis and which limits it uses - in one table, and the
// per-type operations (its motion, its 1-DOF range, whether it has limits, the longest it slides)
// dispatched from it, so chains, trees and solvers ask a question ("does it turn?", "its range?")
// instead of repeating `if ball ... else` branches. Projection onto limits and the within-limits,
// at-limit and blocked tests take the type too (kinematics.hpp) and dispatch the same way. A new
// joint type is a row here, its case in joint_rotation(), and its limits' projection and tests.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/so3.hpp"

namespace ikchain {

enum class JointType : uint8_t {
  kBall = 0,   // 3 rotational DOF, params: rotation vector (radians)
  kHinge = 1,  // 1 rotational DOF about JointDesc::axis, param: angle (radians)
  // 1 translational DOF: the joint slides along JointDesc::axis (joint space) by its param (m), moving
  // every later joint and the tip; its frame does not turn. Needs a slide range: has_slide_limit
  // with slide_min / slide_max in metres (the reach bounds need it). Pursued by the Jacobian
  // solvers and BFGS; CCD, FABRIK and two-bone turn joints only and reject such chains.
  kPrismatic = 2,
};

// Limits are expressed in joint space, relative to the joint's rest orientation.
struct JointLimits {
  // Hinge: angle range in radians. Ignored for other joints.
  bool has_hinge_limit = false;
  double hinge_min = -3.14159265358979323846;
  double hinge_max = 3.14159265358979323846;
  // Prismatic: slide range in metres (required: has_slide_limit, slide_min <= slide_max). Ignored
  // for other joints.
  bool has_slide_limit = false;
  double slide_min = 0.0;
  double slide_max = 0.0;
  // Ball: swing of twist_axis away from its rest direction is at most cone_angle (radians, [0, pi]).
  bool has_cone_limit = false;
  double cone_angle = 3.14159265358979323846;
  // Ball: rotation about twist_axis in [twist_min, twist_max] (radians, within [-pi, pi]).
  bool has_twist_limit = false;
  double twist_min = -3.14159265358979323846;
  double twist_max = 3.14159265358979323846;
  // Ball: the bone's own axis in joint space (Godot bones point along +Y). Unit length after build.
  glm::dvec3 twist_axis{0.0, 1.0, 0.0};
};

struct JointTraits {
  const char* name;       // "ball", "hinge", "prismatic"
  int dof_count;          // params per joint: 3 (a rotation vector) or 1 (an angle or a slide)
  bool turns;             // moves its frame's orientation (ball, hinge); a prismatic joint slides instead
  bool uses_axis;         // reads JointDesc::axis (hinge: rotation axis, prismatic: slide direction)
  bool cone_twist_limits; // limited by cone_angle / twist range (ball), else by a range on its one param
  const char* param_unit; // of its params: "rad" or "m"
};

// Indexed by JointType (kBall = 0, kHinge = 1, kPrismatic = 2).
constexpr JointTraits kJointTraits[] = {
    {"ball", 3, true, false, true, "rad"},
    {"hinge", 1, true, true, false, "rad"},
    {"prismatic", 1, false, true, false, "m"},
};
constexpr int kJointTypeCount = static_cast<int>(sizeof(kJointTraits) / sizeof(kJointTraits[0]));
static_assert(kJointTypeCount == 3 && kJointTraits[static_cast<int>(JointType::kBall)].dof_count == 3 &&
                  !kJointTraits[static_cast<int>(JointType::kPrismatic)].turns &&
                  kJointTraits[static_cast<int>(JointType::kHinge)].uses_axis,
              "kJointTraits rows are in JointType order");

constexpr bool is_known_joint_type(JointType type) { return static_cast<int>(type) < kJointTypeCount; }
constexpr const JointTraits& joint_traits(JointType type) { return kJointTraits[static_cast<int>(type)]; }
constexpr int joint_dof_count(JointType type) { return joint_traits(type).dof_count; }
// One param (a hinge's angle or a slide): limited by a range, blocked by one_dof_blocked().
constexpr bool is_one_dof(JointType type) { return joint_traits(type).dof_count == 1; }
constexpr bool turns(JointType type) { return joint_traits(type).turns; }

// A 1-DOF joint's range: a hinge's angle (rad) or a slide (m). `limited` false: no range (a free
// hinge; a slide always has one).
struct ParamRange {
  bool limited = false;
  double min = 0.0;
  double max = 0.0;
};
inline ParamRange param_range(JointType type, const JointLimits& l) {
  if (type == JointType::kPrismatic) return {l.has_slide_limit, l.slide_min, l.slide_max};
  return {l.has_hinge_limit, l.hinge_min, l.hinge_max};
}

// True when the joint has any limit its type uses (a range; a cone or a twist range).
inline bool has_joint_limits(JointType type, const JointLimits& l) {
  return joint_traits(type).cone_twist_limits ? (l.has_cone_limit || l.has_twist_limit)
                                              : param_range(type, l).limited;
}

// The longest a joint's slide can add to the distance to its children (m; 0 for turning joints).
inline double longest_slide(JointType type, const JointLimits& l) {
  if (turns(type)) return 0.0;
  const ParamRange r = param_range(type, l);
  return std::max(std::abs(r.min), std::abs(r.max));
}

// The joint's motion R(params) as a rotation (its rest rotation excluded): exp of a ball's rotation
// vector, a hinge's angle about its unit `axis`, the identity for a slide (which moves its
// children along `axis` instead). `p`: the joint's own params.
inline glm::dquat joint_rotation(JointType type, const glm::dvec3& axis, const double* p) {
  switch (type) {
    case JointType::kBall: return so3::exp(glm::dvec3(p[0], p[1], p[2]));
    case JointType::kHinge: return glm::angleAxis(p[0], axis);
    case JointType::kPrismatic: break;
  }
  return glm::dquat(1.0, 0.0, 0.0, 0.0);
}

}  // namespace ikchain
