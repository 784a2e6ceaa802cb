// Joint descriptions and small chains from plain numbers, shared by the benchmarks and the core
// tests (tests/core has bench/ on its include path), so a hinge, a slide or a leg is written once
// and a bench measures the chain a test checks. Engine-free; plain builder code.
#pragma once

#include <vector>

#include "ikchain/ikchain.hpp"

namespace ikchain {
namespace bench {

// A hinge about `axis` (joint frame), `offset` from the previous joint's frame; no limits.
inline JointDesc hinge_joint(const glm::dvec3& axis, const glm::dvec3& offset) {
  JointDesc j;
  j.type = JointType::kHinge;
  j.axis = axis;
  j.offset_translation = offset;
  return j;
}

// The same hinge turning only within [min_angle, max_angle] (rad).
inline JointDesc hinge_joint(const glm::dvec3& axis, const glm::dvec3& offset, double min_angle, double max_angle) {
  JointDesc j = hinge_joint(axis, offset);
  j.limits.has_hinge_limit = true;
  j.limits.hinge_min = min_angle;
  j.limits.hinge_max = max_angle;
  return j;
}

// A prismatic joint sliding along `axis` within [min, max] (m).
inline JointDesc slide_joint(const glm::dvec3& axis, const glm::dvec3& offset, double min, double max) {
  JointDesc j;
  j.type = JointType::kPrismatic;
  j.axis = axis;
  j.offset_translation = offset;
  j.limits.has_slide_limit = true;
  j.limits.slide_min = min;
  j.limits.slide_max = max;
  return j;
}

// A leg standing straight: a ball hip at the base origin (a cone of `hip_cone` rad about the bone
// when > 0), a `thigh` down -Y, a knee hinge about +X in [0, 2.6] rad (on its limit at 0, the leg
// straight), a `shin` to the foot (the tip).
inline ChainBuilder straight_leg_builder(double thigh, double shin, double hip_cone = 0.0) {
  ChainBuilder b;
  JointDesc hip;
  hip.limits.has_cone_limit = hip_cone > 0.0;
  if (hip_cone > 0.0) hip.limits.cone_angle = hip_cone;
  b.add_joint(hip);
  b.add_joint(hinge_joint(glm::dvec3(1, 0, 0), glm::dvec3(0, -thigh, 0), 0.0, 2.6));
  b.set_tip_offset(glm::dvec3(0, -shin, 0));
  return b;
}

// A limited hinge as a URDF joint states it (as tools/urdf_chain.py folds one).
struct UrdfHinge {
  double x, y, z;         // origin, in the parent joint's frame (m)
  double qw, qx, qy, qz;  // origin rotation
  double ax, ay, az;      // hinge axis in the joint frame
  double lower, upper;    // rad
};

// A chain of those hinges, the tip at `tool` in the last joint's frame.
inline ChainBuilder urdf_hinge_builder(const std::vector<UrdfHinge>& joints, const glm::dvec3& tool) {
  ChainBuilder b;
  for (const UrdfHinge& j : joints) {
    JointDesc d = hinge_joint(glm::dvec3(j.ax, j.ay, j.az), glm::dvec3(j.x, j.y, j.z), j.lower, j.upper);
    d.rest_rotation = glm::dquat(j.qw, j.qx, j.qy, j.qz);
    b.add_joint(d);
  }
  b.set_tip_offset(tool);
  return b;
}

}  // namespace bench
}  // namespace ikchain
