// Analytic two-bone IK (src/core/solvers/two_bone.cpp): exact round trips, pole alignment, out of
// reach, too close, zero-length bone, hinge elbow limits, input rules, no allocation.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "core/kinematics.hpp"
#include "core/so3.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kTwoBone;

// A shoulder (ball, with a rest rotation and an offset from the base) and an elbow (ball or a
// hinge about its local x), upper arm l1 and forearm l2 along +Y.
Chain arm(bool hinge_elbow, double l1 = 1.2, double l2 = 0.9, bool limit_elbow = false) {
  ChainBuilder b;
  JointDesc shoulder;
  shoulder.offset_translation = glm::dvec3(0.3, 1.5, -0.2);
  shoulder.rest_rotation = glm::angleAxis(0.4, glm::normalize(glm::dvec3(1, 0, 1)));
  b.add_joint(shoulder);
  JointDesc elbow;
  elbow.type = hinge_elbow ? JointType::kHinge : JointType::kBall;
  elbow.offset_translation = glm::dvec3(0, l1, 0);
  elbow.hinge_axis = glm::dvec3(1, 0, 0);
  elbow.limits.has_hinge_limit = limit_elbow;
  elbow.limits.hinge_min = 0.0;
  elbow.limits.hinge_max = 1.5;
  b.add_joint(elbow);
  b.set_tip_offset(glm::dvec3(0, l2, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).empty());
  return c;
}

SolverOptions exact_options(const Chain& c) {
  SolverOptions o;
  o.position_tolerance = 1e-10 * c.total_length();
  return o;
}

TEST(TwoBone, ExactOnRandomReachableTargets) {
  std::mt19937 rng(1);
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    const SolverOptions o = exact_options(c);
    for (int t = 0; t < 1000; ++t) {
      const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
      // Alternate rest and random starts.
      Eigen::VectorXd p = (t % 2) ? test::random_params(c, rng) : Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
      EXPECT_LE(glm::length(test::tip_of(c, p) - g.target_position), 1e-12 * c.total_length());
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
      EXPECT_LE(r.iterations, 1);
    }
  }
}

// The elbow lies in the plane root-target-pole, on the pole's side.
TEST(TwoBone, PoleTargetAlignment) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    SolverOptions o = exact_options(c);
    o.use_pole = true;
    for (int t = 0; t < 300; ++t) {
      const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
      const glm::dvec3 root = c.root_in_base();
      const glm::dvec3 pole = root + 3.0 * glm::dvec3(u(rng), u(rng), u(rng));
      o.pole_in_base = pole;
      Eigen::VectorXd p = test::random_params(c, rng);
      const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
      forward_kinematics(c, p.data(), ws);
      const glm::dvec3 dir = glm::normalize(g.target_position - root);
      const glm::dvec3 elbow = ws.joint_origins[1] - root;
      const glm::dvec3 pole_perp = (pole - root) - dir * glm::dot(pole - root, dir);
      if (glm::length(pole_perp) < 1e-3) continue;  // pole on the line: no plane to align with
      const glm::dvec3 normal = glm::normalize(glm::cross(dir, pole_perp));
      EXPECT_NEAR(glm::dot(elbow, normal), 0.0, 1e-9);
      const double elbow_off_line = glm::length(elbow - dir * glm::dot(elbow, dir));
      if (elbow_off_line > 1e-6) {
        EXPECT_GT(glm::dot(elbow, glm::normalize(pole_perp)), 0.0);
      }
    }
  }
}

TEST(TwoBone, OutOfReachEndsStraightTowardTheTarget) {
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    const double L = c.total_length();
    const glm::dvec3 dir = glm::normalize(glm::dvec3(0.3, -0.5, 0.81));
    Eigen::VectorXd p = Eigen::VectorXd::Constant(c.dof_count(), 0.4);  // bent start
    // Analytic: exact to 1e-12 L, where the iterative solvers are held to 1e-6 L.
    test::expect_ends_two_beyond_reach(kKind, c, dir, exact_options(c), ws, p, 1e-12);
    forward_kinematics(c, p.data(), ws);
    EXPECT_NEAR(glm::length(ws.joint_origins[1] - c.root_in_base()) + glm::length(ws.tip - ws.joint_origins[1]),
                glm::length(ws.tip - c.root_in_base()), 1e-12 * L);  // straight
  }
}

// |target - root| < |l1 - l2|: folded as far as possible, |l1 - l2| from the root toward the target.
TEST(TwoBone, TooCloseFoldsTowardTheTarget) {
  for (double l2 : {0.4, 1.7}) {
    const Chain c = arm(false, 1.0, l2);
    Workspace ws(c, 1);
    const glm::dvec3 dir = glm::normalize(glm::dvec3(1, 2, -0.5));
    const Goal g = Goal::position(c.root_in_base() + 0.3 * dir);
    Eigen::VectorXd p = Eigen::VectorXd::Constant(c.dof_count(), 0.2);
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    const glm::dvec3 tip = test::tip_of(c, p);
    EXPECT_NEAR(glm::length(tip - g.target_position), std::abs(1.0 - l2) - 0.3, 1e-12);
    EXPECT_NEAR(glm::dot(glm::normalize(tip - c.root_in_base()), dir), 1.0, 1e-12);
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable);
  }
}

// A target exactly on the root with l1 == l2: the tip folds onto the root; no NaN.
TEST(TwoBone, TargetOnRootAndStraightStart) {
  const Chain c = arm(false, 1.0, 1.0);
  Workspace ws(c, 1);
  const Goal g = Goal::position(c.root_in_base());
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());  // straight
  const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
  EXPECT_TRUE(p.allFinite());
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  // Straight chain, target straight ahead but closer: bends and reaches it.
  forward_kinematics(c, Eigen::VectorXd::Zero(c.dof_count()).eval().data(), ws);
  const Goal ahead = Goal::position(c.root_in_base() + 0.5 * (ws.tip - c.root_in_base()));
  p.setZero();
  EXPECT_EQ(solve(kKind, c, Span<const Goal>(&ahead, 1), exact_options(c), ws, p).reason,
            TerminationReason::kConverged);
}

TEST(TwoBone, ZeroLengthBoneChain) {
  ChainBuilder b;
  JointDesc j;
  b.add_joint(j).add_joint(j);  // elbow at the shoulder: l1 = 0
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  ASSERT_TRUE(b.build(c).empty());
  Workspace ws(c, 1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 50; ++t) {
    const glm::dvec3 target(u(rng), u(rng), u(rng));
    const Goal g = Goal::position(target);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    EXPECT_TRUE(p.allFinite());
    // The tip can only be on the unit sphere: the closest point toward the target.
    EXPECT_NEAR(glm::length(test::tip_of(c, p) - target), std::abs(glm::length(target) - 1.0), 1e-12);
  }
}

// A hinge elbow limited to [0, 1.5]: never violated; targets made from feasible angles reached.
TEST(TwoBone, HingeElbowLimitsRespected) {
  const Chain c = arm(true, 1.2, 0.9, true);
  Workspace ws(c, 1);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 300; ++t) {
    const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
    Eigen::VectorXd p = test::random_params(c, rng);
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    EXPECT_TRUE(within_limits(c, p.data()));
    EXPECT_EQ(r.reason, TerminationReason::kConverged);
    // Anywhere, including targets needing a bend beyond the limit: within limits, honest reason.
    const Goal any = Goal::position(c.root_in_base() + 2.0 * glm::dvec3(u(rng), u(rng), u(rng)));
    const SolveResult ra = solve(kKind, c, Span<const Goal>(&any, 1), exact_options(c), ws, p);
    EXPECT_TRUE(within_limits(c, p.data()));
    EXPECT_NEAR(ra.final_position_error, glm::length(test::tip_of(c, p) - any.target_position), 1e-12);
    if (ra.reason == TerminationReason::kConverged) {
      EXPECT_LE(ra.final_position_error, 1e-10 * c.total_length());
    }
  }
}

TEST(TwoBone, RejectsWrongJointCountAndGoals) {
  Workspace ws;
  const Chain three = test::make_ball_chain(3);
  ws.reset(three, 2);
  Eigen::VectorXd p = Eigen::VectorXd::Constant(three.dof_count(), 0.1);
  const Eigen::VectorXd before = p;
  const Goal g = Goal::position(glm::dvec3(0, 1, 1));
  SolveResult r = solve(kKind, three, Span<const Goal>(&g, 1), SolverOptions(), ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("exactly 2 joints"), std::string::npos);
  EXPECT_EQ(p, before);

  const Chain c = arm(false);
  ws.reset(c, 2);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(c.dof_count(), 0.1);
  const Eigen::VectorXd q0 = q;
  const std::vector<std::vector<Goal>> bad = {
      {Goal::position(glm::dvec3(0, 1, 1)), Goal::position(glm::dvec3(0, 2, 1))},
      {Goal::orientation(glm::angleAxis(0.3, glm::dvec3(0, 0, 1)))},
      {Goal::position(glm::dvec3(0, 1, 1), 1)}};  // the elbow
  for (const std::vector<Goal>& goals : bad) {
    r = solve(kKind, c, goals, SolverOptions(), ws, q);
    EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
    EXPECT_NE(std::string(r.message.c_str()).find("position goal on the tip"), std::string::npos);
    EXPECT_EQ(q, q0);
  }
}

TEST(TwoBone, DeterministicAndAllocatesNothing) {
  const Chain c = arm(true);
  Workspace ws(c, 1);
  SolverOptions o = exact_options(c);
  o.warm_start = false;
  const Goal g = Goal::position(c.root_in_base() + glm::dvec3(0.5, 0.8, 0.9));
  std::mt19937 rng(5);
  Eigen::VectorXd a = test::random_params(c, rng), b = test::random_params(c, rng);
  solve(kKind, c, Span<const Goal>(&g, 1), o, ws, a);
  const std::size_t before = test::allocation_count();
  solve(kKind, c, Span<const Goal>(&g, 1), o, ws, b);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace ikchain
