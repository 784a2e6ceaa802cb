// Trees for the tree tests: a small humanoid, random poses within the limits, and an independent
// forward kinematics with 4x4 matrices (the oracle).
#pragma once
#include <initializer_list>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <glm/gtc/matrix_transform.hpp>

#include "ikchain/tree.hpp"
#include "ikchain/tree_solve.hpp"

namespace ikchain {
namespace test {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Joints and effectors of make_humanoid(), by name.
struct Humanoid {
  enum Joint { kHips, kSpine, kChest, kNeck, kHead, kLShoulder, kLElbow, kLWrist, kRShoulder, kRElbow, kRWrist,
               kLHip, kLKnee, kLAnkle, kRHip, kRKnee, kRAnkle, kJointCount };
  enum Effector { kHipsEffector, kHeadEffector, kLHand, kRHand, kLFoot, kRFoot, kEffectorCount };
};

inline TreeJointDesc ball(int parent, glm::dvec3 offset, double cone_deg, double twist_deg = 0.0,
                          glm::dvec3 twist_axis = glm::dvec3(0, 1, 0)) {
  TreeJointDesc d;
  d.parent = parent;
  d.type = JointType::kBall;
  d.offset_in_parent = offset;
  d.limits.twist_axis = twist_axis;
  if (cone_deg > 0.0) {
    d.limits.has_cone_limit = true;
    d.limits.cone_angle = cone_deg * kDeg;
  }
  if (twist_deg > 0.0) {
    d.limits.has_twist_limit = true;
    d.limits.twist_min = -twist_deg * kDeg;
    d.limits.twist_max = twist_deg * kDeg;
  }
  return d;
}

inline TreeJointDesc hinge(int parent, glm::dvec3 offset, glm::dvec3 axis, double min_deg, double max_deg) {
  TreeJointDesc d;
  d.parent = parent;
  d.type = JointType::kHinge;
  d.offset_in_parent = offset;
  d.axis = axis;
  d.limits.has_hinge_limit = true;
  d.limits.hinge_min = min_deg * kDeg;
  d.limits.hinge_max = max_deg * kDeg;
  return d;
}

// A 1.7 m humanoid in a T-pose facing +Z (its left on +X), hips at y = 1: 17 joints (balls with
// cones, hinge knees and elbows), 6 effectors (hips, head, hands, feet). With `floating_root`
// the hips translate too.
inline TreeBuilder humanoid_builder(bool floating_root, bool limits = true) {
  using H = Humanoid;
  TreeBuilder b;
  auto c = [&](double deg) { return limits ? deg : 0.0; };
  b.add_joint(ball(-1, {0, 1.0, 0}, c(60)));                     // hips
  b.add_joint(ball(H::kHips, {0, 0.1, 0}, c(30), c(30)));        // spine
  b.add_joint(ball(H::kSpine, {0, 0.2, 0}, c(30), c(30)));       // chest
  b.add_joint(ball(H::kChest, {0, 0.25, 0}, c(40), c(60)));      // neck
  b.add_joint(ball(H::kNeck, {0, 0.1, 0}, c(40), c(60)));        // head
  b.add_joint(ball(H::kChest, {0.18, 0.2, 0}, c(100), c(90), {1, 0, 0}));  // left shoulder
  TreeJointDesc le = hinge(H::kLShoulder, {0.28, 0, 0}, {0, -1, 0}, 0, 150);
  if (!limits) le.limits.has_hinge_limit = false;
  b.add_joint(le);                                                // left elbow
  b.add_joint(ball(H::kLElbow, {0.25, 0, 0}, c(70), c(80), {1, 0, 0}));    // left wrist
  b.add_joint(ball(H::kChest, {-0.18, 0.2, 0}, c(100), c(90), {-1, 0, 0}));  // right shoulder
  TreeJointDesc re = hinge(H::kRShoulder, {-0.28, 0, 0}, {0, 1, 0}, 0, 150);
  if (!limits) re.limits.has_hinge_limit = false;
  b.add_joint(re);                                                // right elbow
  b.add_joint(ball(H::kRElbow, {-0.25, 0, 0}, c(70), c(80), {-1, 0, 0}));  // right wrist
  b.add_joint(ball(H::kHips, {0.1, -0.05, 0}, c(90), c(40), {0, -1, 0}));  // left hip
  TreeJointDesc lk = hinge(H::kLHip, {0, -0.42, 0}, {1, 0, 0}, 0, 150);
  if (!limits) lk.limits.has_hinge_limit = false;
  b.add_joint(lk);                                                // left knee
  b.add_joint(ball(H::kLKnee, {0, -0.4, 0}, c(40), c(30), {0, -1, 0}));    // left ankle
  b.add_joint(ball(H::kHips, {-0.1, -0.05, 0}, c(90), c(40), {0, -1, 0}));  // right hip
  TreeJointDesc rk = hinge(H::kRHip, {0, -0.42, 0}, {1, 0, 0}, 0, 150);
  if (!limits) rk.limits.has_hinge_limit = false;
  b.add_joint(rk);                                                // right knee
  b.add_joint(ball(H::kRKnee, {0, -0.4, 0}, c(40), c(30), {0, -1, 0}));    // right ankle
  b.add_effector({H::kHips, {0, 0, 0}, {1, 0, 0, 0}});
  b.add_effector({H::kHead, {0, 0.1, 0}, {1, 0, 0, 0}});
  b.add_effector({H::kLWrist, {0.08, 0, 0}, {1, 0, 0, 0}});
  b.add_effector({H::kRWrist, {-0.08, 0, 0}, {1, 0, 0, 0}});
  b.add_effector({H::kLAnkle, {0, -0.06, 0.1}, {1, 0, 0, 0}});
  b.add_effector({H::kRAnkle, {0, -0.06, 0.1}, {1, 0, 0, 0}});
  b.set_floating_root(floating_root);
  return b;
}

inline Tree make_humanoid(bool floating_root, bool limits = true) {
  Tree t;
  humanoid_builder(floating_root, limits).build(t);
  return t;
}

// A pose within the limits: each joint turned by up to max_angle, the root moved by up to
// max_translation, then projected onto the limits.
inline Eigen::VectorXd random_tree_params(const Tree& tree, std::mt19937& rng, double max_angle,
                                          double max_translation = 0.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd q(tree.dof_count());
  for (int i = 0; i < q.size(); ++i) q[i] = max_angle * u(rng) / std::sqrt(3.0);
  if (tree.floating_root())
    for (int i = 0; i < 3; ++i) q[i] = max_translation * u(rng);
  project_tree_to_limits(tree, q.data());
  return q;
}

// 6-D goals for `effectors` at the pose `q` of `tree` (position, and orientation weighted by 1 m^2).
inline std::vector<TreeGoal> pose_goals_at(const Tree& tree, const Eigen::VectorXd& q,
                                           std::initializer_list<int> effectors, int level, bool orientation = true) {
  TreeWorkspace ws(tree, 1);
  tree_forward_kinematics(tree, q.data(), ws);
  std::vector<TreeGoal> goals;
  for (int e : effectors) {
    goals.push_back({Goal::position(tree_effector_position(tree, ws, e), e), level});
    if (orientation) goals.push_back({Goal::orientation(tree_effector_orientation(tree, ws, e), e), level});
  }
  return goals;
}

// Joint frames by 4x4 matrices, written apart from tree_forward_kinematics (the oracle).
inline std::vector<glm::dmat4> frames_by_matrices(const Tree& tree, const Eigen::VectorXd& q) {
  std::vector<glm::dmat4> frames(tree.joint_count());
  for (int i = 0; i < tree.joint_count(); ++i) {
    glm::dmat4 m = tree.parent(i) < 0 ? glm::dmat4(1.0) : frames[tree.parent(i)];
    if (i == 0 && tree.floating_root()) m = glm::translate(glm::dmat4(1.0), glm::dvec3(q[0], q[1], q[2])) * m;
    m = glm::translate(m, tree.offset_in_parent(i)) * glm::mat4_cast(tree.rest_rotation(i));
    const double* p = q.data() + tree.dof_offset(i);
    if (tree.joint_type(i) == JointType::kHinge) {
      m = glm::rotate(m, p[0], tree.axis(i));
    } else if (tree.joint_type(i) == JointType::kPrismatic) {
      m = glm::translate(m, tree.axis(i) * p[0]);
    } else {
      const glm::dvec3 r(p[0], p[1], p[2]);
      const double angle = glm::length(r);
      if (angle > 0.0) m = glm::rotate(m, angle, r / angle);
    }
    frames[i] = m;
  }
  return frames;
}

inline glm::dvec3 effector_by_matrices(const Tree& tree, const Eigen::VectorXd& q, int e) {
  const std::vector<glm::dmat4> f = frames_by_matrices(tree, q);
  return glm::dvec3(f[tree.effector(e).joint] * glm::dvec4(tree.effector(e).offset, 1.0));
}

}  // namespace test
}  // namespace ikchain
