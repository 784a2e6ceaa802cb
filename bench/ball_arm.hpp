// The human-like ball-jointed arm and its in-limit pose sampling, shared by the core bench's limits
// stage (core_bench.cpp, "ball3") and the core's limits tests (tests/core/limits_test.cpp), so both
// measure the same arm the same way. Engine-free; plain builder code.
#pragma once

#include <cmath>
#include <random>

#include "ikchain/ikchain.hpp"
#include "ikchain/so3.hpp"
#include "joint_desc.hpp"

namespace ikchain {
namespace bench {

// Shoulder ball (cone 45 deg, twist +-30 deg), elbow hinge across the bone ([0, 2.6] rad), wrist
// ball (cone 50 deg, twist free); bones along +Y, the twist axis; 0.30 + 0.27 + 0.08 m.
inline ChainBuilder ball_arm_builder() {
  constexpr double kPi = 3.14159265358979323846;
  ChainBuilder b;
  JointDesc shoulder;
  shoulder.type = JointType::kBall;
  shoulder.limits.has_cone_limit = true;
  shoulder.limits.cone_angle = kPi / 4.0;
  shoulder.limits.has_twist_limit = true;
  shoulder.limits.twist_min = -kPi / 6.0;
  shoulder.limits.twist_max = kPi / 6.0;
  b.add_joint(shoulder);
  b.add_joint(hinge_joint(glm::dvec3(0, 0, 1), glm::dvec3(0, 0.30, 0), 0.0, 2.6));  // the elbow
  JointDesc wrist;
  wrist.type = JointType::kBall;
  wrist.offset_translation = glm::dvec3(0, 0.27, 0);
  wrist.limits.has_cone_limit = true;
  wrist.limits.cone_angle = 50.0 * kPi / 180.0;
  b.add_joint(wrist);
  b.set_tip_offset(glm::dvec3(0, 0.08, 0));
  return b;
}

// Every joint of `chain` at a random in-limit pose: hinges uniform in their range, balls a swing
// about a random axis across the bone (+Y; uniform over the cone's cap) times a twist uniform in its
// range. `on_boundary`: every limited joint on a limit instead - hinges on a random bound, balls
// with the swing at the cone angle and the twist on a random bound.
inline void limited_pose(const Chain& chain, bool on_boundary, std::mt19937& rng, double* params) {
  constexpr double kPi = 3.14159265358979323846;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < chain.joint_count(); ++i) {
    const JointLimits& l = chain.limits(i);
    const int o = chain.dof_offset(i);
    if (chain.joint_type(i) != JointType::kBall) {
      params[o] = on_boundary ? (u(rng) < 0.5 ? l.hinge_min : l.hinge_max)
                              : l.hinge_min + (l.hinge_max - l.hinge_min) * u(rng);
      continue;
    }
    const double heading = 2.0 * kPi * u(rng);
    const glm::dvec3 swing_axis(std::cos(heading), 0.0, std::sin(heading));
    const double cone = l.has_cone_limit ? l.cone_angle : kPi;
    const double swing = on_boundary ? cone : cone * std::sqrt(u(rng));
    const double lo = l.has_twist_limit ? l.twist_min : -kPi, hi = l.has_twist_limit ? l.twist_max : kPi;
    const double twist = on_boundary && l.has_twist_limit ? (u(rng) < 0.5 ? lo : hi) : lo + (hi - lo) * u(rng);
    const glm::dvec3 r = so3::log(glm::angleAxis(swing, swing_axis) * glm::angleAxis(twist, l.twist_axis));
    params[o] = r.x;
    params[o + 1] = r.y;
    params[o + 2] = r.z;
  }
}

}  // namespace bench
}  // namespace ikchain
