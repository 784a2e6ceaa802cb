// Shared helpers for the core tests: chain generators and reachable targets made by forward
// kinematics (the round-trip oracle, as in KDL's solvertest.cpp).
#pragma once
#include <cstddef>
#include <random>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "ikchain/ikchain.hpp"

namespace ikchain {
namespace test {

// The chain `b` holds with its tip `link` along +Y of the last joint; a build error fails the test.
inline Chain build_chain(ChainBuilder& b, double link) {
  b.set_tip_offset(glm::dvec3(0, link, 0));
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_TRUE(m.empty()) << m.c_str();
  return c;
}

// n hinges alternating about z and y, unit links along +Y: the benchmark chain (as measured with KDL).
inline Chain make_hinge_chain(int n, double link = 1.0) {
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = (i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, link, 0);
    b.add_joint(j);
  }
  return build_chain(b, link);
}

// A hinge limited to [min, max] rad.
inline JointLimits hinge_range(double min, double max) {
  JointLimits l;
  l.has_hinge_limit = true;
  l.hinge_min = min;
  l.hinge_max = max;
  return l;
}

// A planar limb: one hinge about z per entry of `limits` (JointLimits(): free), unit links along +Y,
// the tip 1 beyond the last joint.
inline Chain make_planar_limb(const std::vector<JointLimits>& limits) {
  ChainBuilder b;
  for (std::size_t i = 0; i < limits.size(); ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = glm::dvec3(0, 0, 1);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    j.limits = limits[i];
    b.add_joint(j);
  }
  return build_chain(b, 1.0);
}

// n hinges about z (a planar limb). With bend_max > 0 every hinge but the first bends one way only,
// [0, bend_max] rad: straight, each sits on its limit.
inline Chain make_planar_limb(int n, double bend_max = 0.0) {
  std::vector<JointLimits> limits(n);
  for (int i = 1; i < n && bend_max > 0.0; ++i) limits[i] = hinge_range(0.0, bend_max);
  return make_planar_limb(limits);
}

// n ball joints, bones along +Y of the given length (a Godot-style bone chain).
inline Chain make_ball_chain(int n, double link = 1.0) {
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    j.type = JointType::kBall;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, link, 0);
    b.add_joint(j);
  }
  return build_chain(b, link);
}

// Random joint parameters: hinges in [-pi, pi], ball rotation vectors with angle <= max_angle.
inline Eigen::VectorXd random_params(const Chain& chain, std::mt19937& rng, double max_angle = 3.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd p(chain.dof_count());
  for (int i = 0; i < chain.joint_count(); ++i) {
    const int o = chain.dof_offset(i);
    if (chain.joint_type(i) == JointType::kHinge) {
      p[o] = u(rng) * max_angle;
    } else {
      glm::dvec3 axis(u(rng), u(rng), u(rng));
      if (glm::length(axis) < 1e-3) axis = glm::dvec3(1, 0, 0);
      axis = glm::normalize(axis) * (0.5 * (u(rng) + 1.0) * max_angle);
      p[o] = axis.x;
      p[o + 1] = axis.y;
      p[o + 2] = axis.z;
    }
  }
  project_to_limits(chain, p.data());
  return p;
}

// The tool frame of a chain of hinges at joint angles q by 4x4 matrices, written out here rather
// than through forward_kinematics(): translate(offset_j) rotate(rest_j) rotate(axis_j, q_j) per
// hinge, then the tool frame (tip offset, tip rotation). The tests' independent FK for hinge arms.
inline glm::dmat4 hinge_tool_frame_by_matrices(const Chain& chain, const double* q) {
  glm::dmat4 m(1.0);
  for (int j = 0; j < chain.joint_count(); ++j)
    m = m * glm::translate(glm::dmat4(1.0), chain.offset_translation(j)) * glm::mat4_cast(chain.rest_rotation(j)) *
        glm::rotate(glm::dmat4(1.0), q[chain.dof_offset(j)], chain.axis(j));
  return m * glm::translate(glm::dmat4(1.0), chain.tip_offset()) * glm::mat4_cast(chain.tip_rotation());
}

inline glm::dvec3 tip_of(const Chain& chain, const Eigen::VectorXd& params) {
  Workspace ws(chain, 1);
  forward_kinematics(chain, params.data(), ws);
  return ws.tip;
}

}  // namespace test
}  // namespace ikchain
