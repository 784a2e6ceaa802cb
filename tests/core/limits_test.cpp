// Ball joints' cone and twist limits in the limit-aware active set (jacobian::limit_aware_step,
// BFGS's frozen directions; ball_blocked in kinematics_internal.hpp): the outward normals are the limits'
// gradients, a ball resting on its cone or twist boundary slides along it instead of stalling, no
// returned pose violates a limit, and the solve allocates nothing.
#include <cmath>
#include <random>
#include <vector>

#include "ball_arm.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

// The bench's human-like arm (bench/ball_arm.hpp, "ball3"): shoulder ball (cone 45 deg, twist
// +-30 deg), elbow hinge across the bone ([0, 2.6] rad), wrist ball (cone 50 deg, twist free).
Chain ball_arm() {
  Chain c;
  EXPECT_TRUE(bench::ball_arm_builder().build(c).ok());
  return c;
}

// A random in-limit pose, or with `on_boundary` every joint on a limit (bench/ball_arm.hpp).
Eigen::VectorXd limited_pose(const Chain& chain, bool on_boundary, std::mt19937& rng) {
  Eigen::VectorXd params(chain.dof_count());
  bench::limited_pose(chain, on_boundary, rng, params.data());
  return params;
}

// Swing and twist angle of a ball rotation vector, by the projection's own definition
// (so3::swing_twist), independent of ball_blocked's closed-form gradients.
void swing_and_twist(const glm::dvec3& r, const glm::dvec3& axis, double& swing_angle, double& twist_angle) {
  glm::dquat swing;
  so3::swing_twist(so3::exp(r), axis, swing, twist_angle);
  swing_angle = glm::length(so3::log(swing));
}

SolverOptions arm_options(const Chain& c) {
  SolverOptions o = test::arm_options(c);
  o.max_iterations = 100;
  return o;
}

// Full pose (tip position + orientation weighted by L^2) of the FK of `truth`.
std::vector<Goal> full_pose_of(const Chain& c, const Eigen::VectorXd& truth) {
  Workspace fk(c, 1);
  forward_kinematics(c, truth.data(), fk);
  const double L = c.total_length();
  return {Goal::position(fk.tip), Goal::orientation(effector_orientation(c, fk, 0), 0, L * L)};
}

// Our FK of `pose` meets every goal within the options' tolerances.
bool meets_goals(const Chain& c, const std::vector<Goal>& goals, const Eigen::VectorXd& pose, const SolverOptions& o) {
  Workspace fk(c, static_cast<int>(goals.size()));
  forward_kinematics(c, pose.data(), fk);
  return measure_goals(c, goals, fk).within(o);
}

// On the boundary, ball_blocked's normals are the unit gradients (w.r.t. the rotation vector) of
// the swing angle (cone) and of +-twist angle, checked against central finite differences of the
// swing-twist decomposition; a step pushing out of both gets an orthonormal basis of both; a step
// pointing inward, or any step at an interior pose, is not blocked.
TEST(BallLimits, BlockedNormalsAreTheLimitGradients) {
  const Chain c = ball_arm();
  const JointLimits& l = c.limits(0);
  std::mt19937 rng(3);
  constexpr double h = 1e-6;
  int cone_only = 0, twist_only = 0;  // trials where those single-limit directions exist
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::VectorXd edge = limited_pose(c, true, rng);
    const glm::dvec3 r(edge[0], edge[1], edge[2]);
    glm::dvec3 swing_gradient, twist_gradient;
    for (int d = 0; d < 3; ++d) {
      glm::dvec3 plus = r, minus = r;
      plus[d] += h;
      minus[d] -= h;
      double sp, tp, sm, tm;
      swing_and_twist(plus, l.twist_axis, sp, tp);
      swing_and_twist(minus, l.twist_axis, sm, tm);
      swing_gradient[d] = (sp - sm) / (2 * h);
      twist_gradient[d] = (tp - tm) / (2 * h);
    }
    double swing, twist;
    swing_and_twist(r, l.twist_axis, swing, twist);
    ASSERT_NEAR(swing, l.cone_angle, 1e-12);
    const glm::dvec3 twist_out = twist > 0.0 ? twist_gradient : -twist_gradient;  // outward
    const glm::dvec3 cone_n = glm::normalize(swing_gradient), twist_n = glm::normalize(twist_out);
    glm::dvec3 normals[2];

    // Pushing out of both: both limits' directions are removed, an orthonormal basis of
    // span {cone_n, twist_n}; the step left after removing them pushes out of neither.
    glm::dvec3 d = cone_n + twist_n;
    ASSERT_EQ(ball_blocked(c, 0, edge.data(), &d.x, normals), 2);
    EXPECT_NEAR(glm::dot(normals[0], normals[1]), 0.0, 1e-12);
    for (const glm::dvec3& n : {cone_n, twist_n})
      EXPECT_NEAR(std::pow(glm::dot(n, normals[0]), 2) + std::pow(glm::dot(n, normals[1]), 2), 1.0, 1e-6);
    glm::dvec3 tangent = d - glm::dot(d, normals[0]) * normals[0] - glm::dot(d, normals[1]) * normals[1];
    tangent += glm::dvec3(0.3, -0.2, 0.1) - glm::dot(glm::dvec3(0.3, -0.2, 0.1), normals[0]) * normals[0] -
               glm::dot(glm::dvec3(0.3, -0.2, 0.1), normals[1]) * normals[1];
    EXPECT_EQ(ball_blocked(c, 0, edge.data(), &tangent.x, normals), 0);

    // Pushing out of one limit and into the other: only that limit's normal.
    const glm::dvec3 twist_across = glm::normalize(twist_n - glm::dot(twist_n, cone_n) * cone_n);
    const glm::dvec3 cone_across = glm::normalize(cone_n - glm::dot(cone_n, twist_n) * twist_n);
    d = cone_n - 2.0 * twist_across;
    if (glm::dot(d, twist_n) < -0.1) {
      ++cone_only;
      ASSERT_EQ(ball_blocked(c, 0, edge.data(), &d.x, normals), 1);
      EXPECT_NEAR(glm::dot(normals[0], cone_n), 1.0, 1e-7);
    }
    d = twist_n - 2.0 * cone_across;
    if (glm::dot(d, cone_n) < -0.1) {
      ++twist_only;
      ASSERT_EQ(ball_blocked(c, 0, edge.data(), &d.x, normals), 1);
      EXPECT_NEAR(glm::dot(normals[0], twist_n), 1.0, 1e-7);
    }

    // Inward: free.
    d = -(cone_n + twist_n);
    EXPECT_EQ(ball_blocked(c, 0, edge.data(), &d.x, normals), 0);

    // An interior pose: free whatever the direction.
    Eigen::VectorXd inside = edge;
    inside.head(3) *= 0.5;
    d = cone_n + twist_n;
    EXPECT_EQ(ball_blocked(c, 0, inside.data(), &d.x, normals), 0);
  }
  EXPECT_GE(cone_only, 25);
  EXPECT_GE(twist_only, 25);
}

// Full poses the projection-only steps (cone and twist clipped after the step, before this active
// set) left short: DLS, the pseudo-inverse and BFGS all stopped early on these three (measured with
// the core at 8c538a4), each starting from the middle of the limits (balls at rest, elbow half
// bent) - the path runs along the shoulder's cone. Now every solver reaches every one, in limits.
TEST(BallLimits, ConvergesWhereProjectionStalled) {
  const Chain c = ball_arm();
  const SolverOptions o = arm_options(c);
  std::mt19937 rng(124);
  std::vector<std::vector<Goal>> cases;
  for (int trial = 0; trial <= 6; ++trial) {
    const std::vector<Goal> goals = full_pose_of(c, limited_pose(c, false, rng));
    if (trial == 1 || trial == 2 || trial == 6) cases.push_back(goals);
  }
  Eigen::VectorXd middle = Eigen::VectorXd::Zero(c.dof_count());
  middle[3] = 1.3;
  Workspace ws(c, 2);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS}) {
    for (size_t k = 0; k < cases.size(); ++k) {
      Eigen::VectorXd p = middle;
      const SolveResult r = test::run(kind, c, cases[k], o, ws, p);
      EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind) << " case " << k;
      EXPECT_TRUE(meets_goals(c, cases[k], p, o)) << to_string(kind) << " case " << k;
      EXPECT_TRUE(within_limits(c, p.data(), 1e-9)) << to_string(kind) << " case " << k;
    }
  }
}

// BFGS from starts with every joint on a limit, position goals, no restarts: where the shoulder
// and the wrist rest on their cone (and twist) boundary, every step is projected, so each is a
// fresh Gauss-Newton step over the reduced Jacobian that zig-zags along the curved boundary with
// ever smaller gains (a creep). Counting a ball on its boundary as a minimum the limits hold lets
// the creep escape; before, some of these solves ran to max_iterations (docs/limits-bench.md).
TEST(BallLimits, BfgsCreepAlongTheConeEscapes) {
  const Chain c = ball_arm();
  const SolverOptions o = arm_options(c);
  ASSERT_EQ(o.max_restarts, 0);
  std::mt19937 rng(31);
  Workspace ws(c, 1);
  for (int trial = 0; trial < 130; ++trial) {
    const std::vector<Goal> goals{full_pose_of(c, limited_pose(c, false, rng))[0]};
    Eigen::VectorXd p = limited_pose(c, true, rng);
    const SolveResult r = test::run(SolverKind::kBFGS, c, goals, o, ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kConverged) << "trial " << trial;
    EXPECT_TRUE(meets_goals(c, goals, p, o)) << "trial " << trial;
    EXPECT_TRUE(within_limits(c, p.data(), 1e-9)) << "trial " << trial;
  }
}

// Goals made by FK of random in-limit poses, solved from a pose with every joint on a limit
// (and from the middle): no returned pose violates a limit, and a converged pose meets its
// goals by our own FK.
TEST(BallLimits, ReturnedPosesWithinLimitsAndConvergedOnesMeetTheGoals) {
  const Chain c = ball_arm();
  const SolverOptions o = arm_options(c);
  Workspace ws(c, 2);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS, SolverKind::kCCD,
                          SolverKind::kFABRIK}) {
    std::mt19937 rng(17);
    int converged = 0;
    for (int trial = 0; trial < 60; ++trial) {
      const std::vector<Goal> pose = full_pose_of(c, limited_pose(c, false, rng));
      const bool full = trial % 2 == 0;
      const std::vector<Goal> goals = full ? pose : std::vector<Goal>{pose[0]};
      Eigen::VectorXd p = limited_pose(c, trial % 3 != 0, rng);
      if (trial % 3 == 0) p.setZero();
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      ASSERT_TRUE(r.usable()) << to_string(kind) << " " << r.message.c_str();
      ASSERT_TRUE(p.allFinite());
      EXPECT_TRUE(within_limits(c, p.data(), 1e-9)) << to_string(kind) << " trial " << trial;
      if (r.reason == TerminationReason::kConverged) {
        ++converged;
        EXPECT_TRUE(meets_goals(c, goals, p, o)) << to_string(kind) << " trial " << trial;
      }
    }
    EXPECT_GT(converged, 0) << to_string(kind);
  }
}

// The allocation-free solve covers the ball constraint path: every solver on a full pose from a
// start with both balls on their cone (and the shoulder on its twist bound).
TEST(BallLimits, SolveAllocatesNothing) {
  const Chain c = ball_arm();
  const SolverOptions o = arm_options(c);
  std::mt19937 rng(5);
  const std::vector<Goal> goals = full_pose_of(c, limited_pose(c, false, rng));
  const Eigen::VectorXd start = limited_pose(c, true, rng);
  Workspace ws(c, 2);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS}) {
    Eigen::VectorXd p = start;
    test::run(kind, c, goals, o, ws, p);  // warm-up
    p = start;
    const std::size_t before = test::allocation_count();
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_EQ(test::allocation_count(), before) << to_string(kind);
    EXPECT_TRUE(r.usable());
  }
}

}  // namespace
}  // namespace ikchain
