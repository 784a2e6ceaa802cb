// BFGS solver (src/core/solvers/bfgs.cpp): forward-kinematics round trips, the lecture's precision
// case, singular starts, limits, orientation/aim and multi-goal solves, determinism, no allocation.
#include <cmath>
#include <random>
#include <vector>

#include "core/solvers/stuck.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kBFGS;

SolveResult solve_bfgs_goals(const Chain& c, const std::vector<Goal>& goals, const SolverOptions& o,
                             Workspace& ws, Eigen::VectorXd& p) {
  return test::run(kKind, c, goals, o, ws, p);
}

SolverOptions tight_options(const Chain& c) {
  SolverOptions o = test::tolerance_options(c);
  o.max_iterations = 100;
  return o;
}

// Reachable targets (FK of random params), solved alternately from the rest pose and from another
// random pose; the fraction within 1e-5 L of the target (and kConverged) is >= 99.9% on every
// benchmark chain.
TEST(Bfgs, RoundTripHingeChains) {
  test::expect_benchmark_round_trips(kKind, tight_options, test::alternating_start_checks(), JointType::kHinge, 100,
                                     200, 0.999);
}

TEST(Bfgs, RoundTripBallChains) {
  test::expect_benchmark_round_trips(kKind, tight_options, test::alternating_start_checks(), JointType::kBall, 200,
                                     200, 0.999);
}

// The lecture's table (JI 5.85, CCD 3.37, BFGS 2.53, optimal 2): a target 2 units beyond full
// reach, from a bent start. The optimum is the straight chain pointing at the target.
TEST(Bfgs, UnreachableTargetEndsAtTheTrueOptimum) {
  for (int kind = 0; kind < 2; ++kind) {
    const Chain c = kind == 0 ? test::make_hinge_chain(7) : test::make_ball_chain(5);
    // The hinge chain's first bone turns about z only, so its straight poses lie in the xy plane:
    // a generic direction there; the ball chain can point anywhere.
    const glm::dvec3 dir = kind == 0 ? glm::normalize(glm::dvec3(0.6, -0.8, 0.0))
                                     : glm::normalize(glm::dvec3(0.3, 0.8, -0.5));
    std::mt19937 rng(5);
    Workspace ws(c, 1);
    SolverOptions o = tight_options(c);
    for (int t = 0; t < 20; ++t) {
      SCOPED_TRACE("kind " + std::to_string(kind) + " trial " + std::to_string(t));
      Eigen::VectorXd p = test::random_params(c, rng, 1.5);  // bent start
      test::expect_ends_two_beyond_reach(kKind, c, dir, o, ws, p);
    }
  }
}

// |grad f| at params: to show that a singular-start test really starts where the gradient vanishes.
double gradient_norm(const Chain& c, const std::vector<Goal>& goals, const Eigen::VectorXd& p) {
  Workspace ws(c, static_cast<int>(goals.size()));
  forward_kinematics(c, p.data(), ws);
  compute_dof_axes(c, p.data(), ws);
  const int rows = 3 * static_cast<int>(goals.size());
  Eigen::VectorXd r(rows);
  Eigen::MatrixXd J(rows, c.dof_count());
  evaluate_goals(c, goals, ws, r);
  compute_jacobian(c, goals, ws, J);
  return (J.transpose() * r).norm();
}

// Straight chain at rest, target on its axis: grad f = 0 exactly (a saddle), yet the chain must bend.
TEST(Bfgs, StraightChainBendsForTargetsOnItsAxis) {
  for (int kind = 0; kind < 2; ++kind) {
    const Chain c = kind == 0 ? test::make_hinge_chain(6) : test::make_ball_chain(4);
    const double L = c.total_length();
    Workspace ws(c, 1);
    const SolverOptions o = tight_options(c);
    // Ahead but closer (within one bone of the tip: single-joint bends curve upward there, only
    // null-space bends go down), well inside, and behind the root.
    for (double along : {0.9 * L, 0.5 * L, -0.5 * L}) {
      const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.0, along, 0.0))};
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      ASSERT_EQ(gradient_norm(c, goals, p), 0.0);
      const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
      EXPECT_EQ(r.reason, TerminationReason::kConverged) << "kind " << kind << " along " << along;
      EXPECT_LE(glm::length(test::tip_of(c, p) - goals[0].target_position), o.position_tolerance);
    }
  }
}

// Target exactly on the root: no NaN, and a chain that can fold onto its root does (the ball chain
// of 4 equal bones can close a loop; we assert a finite pose and that it got there).
TEST(Bfgs, TargetOnTheRootGivesAFinitePose) {
  const Chain c = test::make_ball_chain(4);
  Workspace ws(c, 1);
  const SolverOptions o = tight_options(c);
  const std::vector<Goal> goals = {Goal::position(c.root_in_base())};
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
  ASSERT_TRUE(p.allFinite());
  EXPECT_TRUE(std::isfinite(r.final_error));
  EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(r.reason);
  EXPECT_LE(r.final_position_error, o.position_tolerance);
}

// All-hinge or all-ball chains: hinges in [-(0.2 + 1.5 u), 0.2 + 1.5 u'], cones 0.3 + 1.5 u, twists
// [-(0.2 + u), 0.2 + u'].
Chain random_limited_chain(int n, bool ball, std::mt19937& rng) {
  const test::LimitRanges ranges = {0.2, 1.5, 0.3, 1.5, 0.2, 1.0};
  return test::limited_chain(n, ball ? test::LimitedJoints::kAllBalls : test::LimitedJoints::kAllHinges, ranges,
                             test::LimitDraws::kOwnFieldsOnly, rng);
}

// Projected gradient of f at p (hinge DOFs on a bound with the gradient pushing outward removed),
// relative to L * error: ~0 at a constrained stationary (KKT) point.
double projected_gradient_rel(const Chain& c, const Goal& g, const Eigen::VectorXd& p) {
  Workspace ws(c, 1);
  forward_kinematics(c, p.data(), ws);
  compute_dof_axes(c, p.data(), ws);
  Eigen::VectorXd r(3);
  Eigen::MatrixXd J(3, c.dof_count());
  const GoalErrors err = evaluate_goals(c, Span<const Goal>(&g, 1), ws, r);
  compute_jacobian(c, Span<const Goal>(&g, 1), ws, J);
  Eigen::VectorXd grad = -J.transpose() * r;
  for (int i = 0; i < c.joint_count(); ++i) {
    const JointLimits& l = c.limits(i);
    if ((p[i] <= l.hinge_min + 1e-12 && grad[i] > 0) || (p[i] >= l.hinge_max - 1e-12 && grad[i] < 0))
      grad[i] = 0.0;
  }
  return grad.norm() / (c.total_length() * err.combined);
}

// Limits are never violated, and feasible targets (FK of feasible params) are still reached from
// the rest pose. Every hinge failure checked is at (or, when the creep rule left a crawl along a
// bound for an escape that found nothing lower, near) a constrained local minimum with 3-4 joints
// pinned on a limit: a property of the problem from that start, not a solver stall -- asserted
// below for the hinge chains.
TEST(Bfgs, LimitsRespectedAndFeasibleTargetsReached) {
  for (int ball = 0; ball < 2; ++ball) {
    std::mt19937 rng(77 + ball);
    int ok = 0, trials = 0;
    for (int chain_i = 0; chain_i < 20; ++chain_i) {
      const Chain c = random_limited_chain(6, ball == 1, rng);
      Workspace ws(c, 1);
      SolverOptions o = tight_options(c);
      o.max_iterations = 200;
      for (int t = 0; t < 25; ++t, ++trials) {
        const Eigen::VectorXd truth = test::random_params(c, rng);  // projected: feasible
        ASSERT_TRUE(within_limits(c, truth.data()));
        const std::vector<Goal> goals = {Goal::position(test::tip_of(c, truth))};
        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
        const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
        EXPECT_TRUE(within_limits(c, p.data(), 1e-9)) << "chain " << chain_i << " trial " << t;
        if (r.reason == TerminationReason::kConverged) {
          EXPECT_LE(glm::length(test::tip_of(c, p) - goals[0].target_position), o.position_tolerance);
          ++ok;
        } else if (ball == 0) {
          // Stalled once the escapes are spent - or, a query with far escapes left (beyond
          // stuck::kMaxEscapes: up to stuck::kFarEscapes more), cut off by max_iterations between
          // them, at the best pose seen (two of these 500 with 16 far escapes: the same minima
          // as with 3, where they stalled after 8 escapes; issue 16, item 20).
          EXPECT_TRUE(r.reason == TerminationReason::kStalled ||
                      (r.reason == TerminationReason::kMaxIterations && r.escapes > stuck::kMaxEscapes))
              << to_string(r.reason) << " after " << r.escapes << " escapes, chain " << chain_i << " trial " << t;
          // At the minimum, or near it when a creep along a bound with no escape left stopped
          // (it would creep on in vain: issue 16, item 14).
          EXPECT_LE(projected_gradient_rel(c, goals[0], p), 1e-2) << "chain " << chain_i << " trial " << t;
        }
      }
    }
    EXPECT_GE(static_cast<double>(ok) / trials, ball ? 0.98 : 0.95) << (ball ? "ball" : "hinge");
  }
}

// Position + orientation of the tip (a 6-D goal) and an aim goal, from FK of random params.
TEST(Bfgs, OrientationAndAimGoalsAreMet) {
  const Chain c = test::make_ball_chain(4, 0.5);
  std::mt19937 rng(9);
  Workspace ws(c, 2);
  SolverOptions o = tight_options(c);
  o.orientation_tolerance = 1e-5;
  int ok = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng);
    forward_kinematics(c, truth.data(), ws);
    const glm::dvec3 tip = ws.tip;
    const glm::dquat q = effector_orientation(c, ws, 0);
    std::vector<Goal> goals;
    if (t % 2 == 0)
      goals = {Goal::position(tip), Goal::orientation(q)};
    else
      goals = {Goal::position(tip), Goal::aim(glm::dvec3(0, 0, 1), q * glm::dvec3(0, 0, 1))};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
    if (r.reason == TerminationReason::kConverged) {
      ++ok;
      EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
      EXPECT_LE(r.final_position_error, o.position_tolerance);
    }
  }
  EXPECT_GE(static_cast<double>(ok) / trials, 0.99);
}

// Elbow (effector 2 of 4) and hand (tip) targets at once, from FK of random params.
TEST(Bfgs, TwoGoalsElbowAndHand) {
  const Chain c = test::make_ball_chain(4);
  std::mt19937 rng(21);
  Workspace ws(c, 2);
  const SolverOptions o = tight_options(c);
  int ok = 0;
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng);
    forward_kinematics(c, truth.data(), ws);
    const std::vector<Goal> goals = {Goal::position(effector_position(c, ws, 2), 2),
                                     Goal::position(ws.tip)};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
    forward_kinematics(c, p.data(), ws);
    const bool met = glm::length(effector_position(c, ws, 2) - goals[0].target_position) <= o.position_tolerance &&
                     glm::length(ws.tip - goals[1].target_position) <= o.position_tolerance;
    EXPECT_EQ(met, r.reason == TerminationReason::kConverged);
    if (met) ++ok;
  }
  EXPECT_GE(static_cast<double>(ok) / trials, 0.999);
}

// warm_start = false: the result depends only on the goals, not on the incoming params.
TEST(Bfgs, DeterministicStartIgnoresIncomingParams) {
  const Chain c = test::make_hinge_chain(10);
  std::mt19937 rng(4);
  Workspace ws(c, 1);
  SolverOptions o = tight_options(c);
  o.warm_start = false;
  test::ColdStartChecks checks;
  checks.converged = true;
  test::expect_cold_start_ignores_incoming_params(kKind, c, o, ws, rng, checks);
  // Warm start from the answer's neighbourhood converges in fewer iterations than from rest.
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng)))};
  Eigen::VectorXd cold = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult rc = solve_bfgs_goals(c, goals, o, ws, cold);
  o.warm_start = true;
  Eigen::VectorXd warm = cold;
  warm[3] += 1e-3;
  const SolveResult rw = solve_bfgs_goals(c, goals, o, ws, warm);
  EXPECT_EQ(rw.reason, TerminationReason::kConverged);
  EXPECT_LT(rw.iterations, rc.iterations);
}

// A per-iteration joint rotation cap holds along the line search and the solve still converges.
TEST(Bfgs, MaxStepAngleStillConverges) {
  const Chain c = test::make_hinge_chain(7);
  std::mt19937 rng(8);
  Workspace ws(c, 1);
  SolverOptions o = tight_options(c);
  o.max_step_angle = 0.05;
  o.max_iterations = 400;
  for (int t = 0; t < 20; ++t) {
    const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng)))};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    o.max_iterations = 1;
    const SolveResult one = solve_bfgs_goals(c, goals, o, ws, p);
    EXPECT_LE(p.cwiseAbs().maxCoeff(), o.max_step_angle + 1e-12) << "one iteration moved too far";
    EXPECT_EQ(one.iterations, 1);
    o.max_iterations = 400;
    const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kConverged);
  }
}

TEST(Bfgs, SolveAllocatesNothing) {
  const Chain c = test::make_ball_chain(8);
  std::mt19937 rng(2);
  Workspace ws(c, 3);
  SolverOptions o = tight_options(c);
  forward_kinematics(c, test::random_params(c, rng).data(), ws);
  const std::vector<Goal> goals = {Goal::position(ws.tip), Goal::orientation(effector_orientation(c, ws, 0)),
                                   Goal::position(effector_position(c, ws, 3), 3)};
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  solve_bfgs_goals(c, goals, o, ws, p);  // warm-up
  p.setZero();
  const std::size_t before = test::allocation_count();
  const SolveResult r = solve_bfgs_goals(c, goals, o, ws, p);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_GT(r.iterations, 0);

  // And with limits (the projection path) and on the unreachable precision case.
  std::mt19937 rng2(3);
  const Chain lim = random_limited_chain(5, false, rng2);
  Workspace wl(lim, 1);
  const std::vector<Goal> far = {Goal::position(glm::dvec3(9.0, 3.0, 1.0))};
  Eigen::VectorXd q = Eigen::VectorXd::Zero(lim.dof_count());
  solve_bfgs_goals(lim, far, o, wl, q);
  q.setZero();
  const std::size_t before2 = test::allocation_count();
  solve_bfgs_goals(lim, far, o, wl, q);
  EXPECT_EQ(test::allocation_count(), before2);
}

}  // namespace
}  // namespace ikchain
