// FABRIK (src/core/solvers/fabrik.cpp): forward-kinematics round trips with measured success rates, the
// lecture's precision case, singular starts, limits, orientation / aim / two-goal solves,
// deterministic starts and the no-allocation guarantee.
#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "core/kinematics.hpp"
#include "core/so3.hpp"
#include "test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kFABRIK;

SolverOptions options_for(const Chain& c, int max_iterations = 200) {
  SolverOptions o;
  o.max_iterations = max_iterations;
  o.position_tolerance = 1e-5 * c.total_length();
  return o;
}

// Random reachable targets (FK of random feasible params), solved from the rest pose. Every solve
// must stay finite and within the limits; returns the fraction within position_tolerance.
double round_trip_rate(const Chain& c, int trials, int max_iterations, unsigned seed) {
  std::mt19937 rng(seed);
  Workspace ws(c, 1);
  const SolverOptions o = options_for(c, max_iterations);
  int ok = 0;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng);
    const Goal g = Goal::position(test::tip_of(c, truth));
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
    EXPECT_TRUE(r.pose_usable);
    EXPECT_TRUE(p.allFinite());
    EXPECT_TRUE(within_limits(c, p.data()));
    const double dist = glm::length(test::tip_of(c, p) - g.target_position);
    EXPECT_NEAR(dist, r.final_position_error, 1e-9);  // the reported error is the measured one
    if (dist <= o.position_tolerance) {
      ++ok;
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
    }
  }
  return static_cast<double>(ok) / trials;
}

// Rates measured with these seeds and budgets (200 iterations from the rest pose, tolerance
// 1e-5 L), asserted with a margin.
TEST(FABRIK, FkRoundTripHingeChains) {
  EXPECT_GE(round_trip_rate(test::make_hinge_chain(2), 1000, 200, 1), 0.999);  // measured 1.000
  EXPECT_GE(round_trip_rate(test::make_hinge_chain(3), 1000, 200, 2), 0.69);   // measured 0.723
  EXPECT_GE(round_trip_rate(test::make_hinge_chain(7), 500, 200, 3), 0.99);    // measured 1.000
  EXPECT_GE(round_trip_rate(test::make_hinge_chain(10), 500, 200, 4), 0.985);  // measured 0.996
  EXPECT_GE(round_trip_rate(test::make_hinge_chain(30), 100, 200, 5), 0.97);   // measured 0.990
}

TEST(FABRIK, FkRoundTripBallChains) {
  EXPECT_GE(round_trip_rate(test::make_ball_chain(2), 1000, 200, 6), 0.90);   // measured 0.923
  EXPECT_GE(round_trip_rate(test::make_ball_chain(3), 1000, 200, 7), 0.98);   // measured 0.992
  EXPECT_GE(round_trip_rate(test::make_ball_chain(7), 500, 200, 8), 0.995);   // measured 1.000
  EXPECT_GE(round_trip_rate(test::make_ball_chain(10), 500, 200, 9), 0.995);  // measured 1.000
  EXPECT_GE(round_trip_rate(test::make_ball_chain(30), 100, 200, 10), 0.99);  // measured 1.000
}

// The lecture's case: a target 2 beyond full reach, from a bent start. The optimum is the straight
// chain toward the target, distance exactly 2 (the lecture's CCD stopped at 3.37); FABRIK's first
// iteration is that line.
TEST(FABRIK, PrecisionCaseOutOfReachEndsAtTheOptimum) {
  std::mt19937 rng(21);
  for (int n : {2, 3, 7, 10, 30}) {
    const Chain c = test::make_ball_chain(n);
    Workspace ws(c, 1);
    const double L = c.total_length();
    const glm::dvec3 dir = glm::normalize(glm::dvec3(0.3, -0.5, 0.81));
    const Goal g = Goal::position(dir * (L + 2.0));
    Eigen::VectorXd p = test::random_params(c, rng, 1.0);  // bent start
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), options_for(c), ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable) << "n=" << n;
    EXPECT_NEAR(glm::length(test::tip_of(c, p) - g.target_position), 2.0, 1e-6 * L) << "n=" << n;
  }
  // The hinge benchmark chain can only lie straight in the xy plane (its first bone turns about z):
  // a generic direction in that plane.
  for (int n : {3, 7, 10}) {
    const Chain c = test::make_hinge_chain(n);
    Workspace ws(c, 1);
    const double L = c.total_length();
    const Goal g = Goal::position(glm::normalize(glm::dvec3(-0.6, 0.35, 0.0)) * (L + 2.0));
    Eigen::VectorXd p = test::random_params(c, rng, 1.0);
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), options_for(c), ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable) << "n=" << n;
    EXPECT_NEAR(glm::length(test::tip_of(c, p) - g.target_position), 2.0, 1e-6 * L) << "n=" << n;
  }
}

// Straight rest pose, a fixed point of plain FABRIK when the target is straight ahead. Asserted:
// ahead-but-closer (0.6 L, 0.9 L) and behind-the-root targets (all reachable) converge (one
// exception below); a target exactly on the root gives a finite pose no farther
// from it than the start, and the 4-bone chain (which can fold onto its root) reaches it.
TEST(FABRIK, SingularStartsStraightChain) {
  for (const Chain& c : {test::make_ball_chain(4), test::make_hinge_chain(4)}) {
    Workspace ws(c, 1);
    const SolverOptions o = options_for(c);
    const double L = c.total_length();
    for (const glm::dvec3& target : {glm::dvec3(0, 0.6 * L, 0), glm::dvec3(0, 0.9 * L, 0),
                                     glm::dvec3(0, -0.5 * L, 0)}) {
      const Goal g = Goal::position(target);
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
      EXPECT_TRUE(p.allFinite());
      EXPECT_LE(r.final_error, r.initial_error);
      // The 4-hinge chain (z, y, z, y: a 2 + 2 arm with twists) from straight to 0.6 L ends at a
      // fixed point of FABRIK's hinge conversion (measured error 1.35, kStalled): a known weakness
      // of positional FABRIK with hinges, not asserted as converged.
      if (c.joint_type(0) == JointType::kBall || target.y != 0.6 * L) {
        EXPECT_EQ(r.reason, TerminationReason::kConverged) << target.y;
      }
    }
    const Goal on_root = Goal::position(c.root_in_base());
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve(kKind, c, Span<const Goal>(&on_root, 1), o, ws, p);
    EXPECT_TRUE(p.allFinite());
    EXPECT_TRUE(r.pose_usable);
    EXPECT_LE(r.final_error, r.initial_error);
    if (c.joint_type(0) == JointType::kBall) {
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
    }
  }
}

Chain limited_chain(int n, bool hinge, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    j.type = hinge ? JointType::kHinge : JointType::kBall;
    j.hinge_axis = (i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    j.limits.has_hinge_limit = hinge;
    j.limits.hinge_min = -0.2 - 1.8 * u(rng);
    j.limits.hinge_max = 0.2 + 1.8 * u(rng);
    j.limits.has_cone_limit = !hinge;
    j.limits.cone_angle = 0.3 + 1.2 * u(rng);
    j.limits.has_twist_limit = !hinge;
    j.limits.twist_min = -0.1 - 0.9 * u(rng);
    j.limits.twist_max = 0.1 + 0.9 * u(rng);
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).empty());
  return c;
}

// Limits hold after every solve (reachable and unreachable targets), and targets made from
// feasible params are still reached at the measured rate.
TEST(FABRIK, LimitsNeverViolatedAndFeasibleTargetsReached) {
  std::mt19937 rng(31);
  for (bool hinge : {true, false}) {
    for (int n : {3, 7}) {
      const Chain c = limited_chain(n, hinge, rng);
      // Measured: hinge n=3 0.810, n=7 0.797; ball n=3 0.870, n=7 0.757 (FABRIK's positional
      // stages do not see the limits; the per-joint projection pulls it off its path).
      const double expected = hinge ? (n == 3 ? 0.77 : 0.75) : (n == 3 ? 0.83 : 0.71);
      EXPECT_GE(round_trip_rate(c, 300, 200, 40 + n), expected) << "hinge=" << hinge << " n=" << n;
      Workspace ws(c, 1);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      for (int t = 0; t < 50; ++t) {
        const Goal g = Goal::position(glm::dvec3(u(rng), u(rng), u(rng)) * (1.5 * c.total_length()));
        Eigen::VectorXd p = test::random_params(c, rng);
        solve(kKind, c, Span<const Goal>(&g, 1), options_for(c), ws, p);
        EXPECT_TRUE(within_limits(c, p.data()));
      }
    }
  }
}

// Elbow + hand position goals: the elbow's goal pins its point during forward reaching (a
// sub-base). An orientation goal is not pursued by FABRIK (documented in fabrik.cpp): asserted is
// that the position goal next to it is still met and the solve does not claim convergence unless
// the orientation happens to be met too.
TEST(FABRIK, TwoPositionGoalsAndIgnoredOrientation) {
  std::mt19937 rng(51);
  const Chain c = test::make_ball_chain(5);
  Workspace ws(c, 2);
  const SolverOptions o = options_for(c, 200);
  Workspace fk(c, 1);
  int two_ok = 0, position_ok = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng, 2.0);
    forward_kinematics(c, truth.data(), fk);
    const std::vector<Goal> two = {Goal::position(fk.joint_origins[3], 3), Goal::position(fk.tip)};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    SolveResult r = solve(kKind, c, two, o, ws, p);
    EXPECT_TRUE(p.allFinite());
    if (r.reason == TerminationReason::kConverged) ++two_ok;
    const std::vector<Goal> pose = {Goal::position(fk.tip),
                                    Goal::orientation(glm::angleAxis(2.0, glm::dvec3(1, 0, 0)))};
    p.setZero();
    r = solve(kKind, c, pose, o, ws, p);
    EXPECT_TRUE(r.pose_usable);
    EXPECT_LE(r.final_error, r.initial_error);
    if (r.final_position_error <= o.position_tolerance) ++position_ok;
    if (r.reason == TerminationReason::kConverged) {
      EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
    }
  }
  // Measured: 178 of 200 two-goal solves converge. With the ignored orientation goal the position
  // goal ends met in 105 of 200: the pose returned is the lowest-cost one over ALL goals (the
  // contract), which is often a pose where the position is not yet met but the orientation is
  // closer; FABRIK should not be given orientation goals.
  EXPECT_GE(two_ok, 0.85 * trials);
  EXPECT_GE(position_ok, 0.45 * trials);
}

TEST(FABRIK, DeterministicStartIgnoresIncomingParams) {
  std::mt19937 rng(61);
  const Chain c = test::make_hinge_chain(7);
  Workspace ws(c, 1);
  SolverOptions o = options_for(c);
  o.warm_start = false;
  for (int t = 0; t < 20; ++t) {
    const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
    Eigen::VectorXd a = test::random_params(c, rng), b = test::random_params(c, rng);
    const SolveResult ra = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, a);
    const SolveResult rb = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, b);
    EXPECT_EQ(a, b);
    EXPECT_EQ(ra.iterations, rb.iterations);
  }
}

TEST(FABRIK, SolveAllocatesNothing) {
  const Chain c = test::make_ball_chain(10);
  Workspace ws(c, 2);
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(1.0, 2.0, 1.0), 5),
                                   Goal::position(glm::dvec3(1.0, 4.0, 2.0))};
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolverOptions o = options_for(c);
  solve(kKind, c, goals, o, ws, p);  // warm-up
  p.setZero();
  const std::size_t before = test::allocation_count();
  solve(kKind, c, goals, o, ws, p);
  const Goal far = Goal::position(glm::dvec3(0, 30, 0));
  solve(kKind, c, Span<const Goal>(&far, 1), o, ws, p);
  EXPECT_EQ(test::allocation_count(), before);
}

}  // namespace
}  // namespace ikchain
