// Jacobian pseudo-inverse with residual check and step halving (src/core/solvers/jacobian_pinv.cpp).
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "ikchain/so3.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kJacobianPinv;

// Always from the rest pose (warm_start = false), the default budget, tolerance 1e-5 L.
SolverOptions options_for(const Chain& chain) { return test::cold_start_options(chain); }

// >= 99.9% within 1e-5 L for every n, from the rest pose, 100 iterations. The 3-joint z/y/z chain
// (3 DOF for 3 rows, often near singular) is the hard one: it needs the truncated retries of
// jacobian_pinv.cpp (68.5% without them).
TEST(JacobianPinv, FkRoundTripHingeChains) {
  test::expect_benchmark_round_trips(kKind, options_for, test::cold_start_checks(), JointType::kHinge, 100, 300, 0.999);
}

TEST(JacobianPinv, FkRoundTripBallChains) {
  test::expect_benchmark_round_trips(kKind, options_for, test::cold_start_checks(), JointType::kBall, 200, 200, 0.999);
}

// The benchmark's targets (bench/core_bench.cpp, random_targets): FK tips of joint vectors drawn
// uniformly from [-pi, pi]^n by std::mt19937(seed), in order.
std::vector<glm::dvec3> benchmark_targets(const Chain& chain, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-so3::kPi, so3::kPi);
  Eigen::VectorXd q(chain.dof_count());
  std::vector<glm::dvec3> targets;
  for (int t = 0; t < count; ++t) {
    for (int i = 0; i < q.size(); ++i) q[i] = u(rng);
    targets.push_back(test::tip_of(chain, q));
  }
  return targets;
}

// Regression: the benchmark's own target sets, from the rest pose, at the seeds where targets were
// missed. Before the singular-saddle escape and the lenient full-step retry (jacobian_pinv.cpp):
// seed 11 reached 99.88 % (n = 3) and 99.82 % (n = 7), seed 12 99.86 % and 99.84 %, seed 13
// 99.96 % at n = 10; the misses ended folded at a singular pose, or crept to a nearly singular
// solution. Now every target is reached, judged by FK of the returned pose, and reports
// kConverged; and the solves (many escape or take the lenient step) allocate nothing.
TEST(JacobianPinv, BenchmarkTargetSetsAllReached) {
  struct Set {
    int n;
    unsigned seed;
  };
  for (const Set set : {Set{3, 11}, Set{7, 11}, Set{3, 12}, Set{7, 12}, Set{10, 13}}) {
    const Chain chain = test::make_hinge_chain(set.n);
    const SolverOptions o = options_for(chain);
    Workspace ws(chain, 1);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(set.n);
    const std::vector<glm::dvec3> targets = benchmark_targets(chain, 5000, set.seed);
    const Goal warm_up = Goal::position(targets[0]);
    solve(kKind, chain, Span<const Goal>(&warm_up, 1), o, ws, p);
    int missed = 0;
    std::size_t allocations = 0;
    for (std::size_t t = 0; t < targets.size(); ++t) {
      const Goal g = Goal::position(targets[t]);
      const std::size_t before = test::allocation_count();
      const SolveResult r = solve(kKind, chain, Span<const Goal>(&g, 1), o, ws, p);
      allocations += test::allocation_count() - before;
      const double dist = glm::length(test::tip_of(chain, p) - targets[t]);
      if (dist > o.position_tolerance) {
        if (++missed <= 5) ADD_FAILURE() << "n " << set.n << " seed " << set.seed << " target " << t << ": "
                                         << dist << " left after " << r.iterations << " iterations";
      } else {
        EXPECT_EQ(r.reason, TerminationReason::kConverged) << set.n << " " << set.seed << " " << t;
      }
    }
    EXPECT_EQ(missed, 0) << "n " << set.n << " seed " << set.seed;
    EXPECT_EQ(allocations, 0u) << "n " << set.n << " seed " << set.seed;
  }
}

// Regression, the escape itself: warm starts at two poses where the old solver stopped (its final
// poses, rounded to 1e-3 rad), each a saddle of the cost at a singular pose with the residual along
// the nearly singular direction: the 3-hinge chain folded at joint 2 (tip 0.047 short of a target
// just outside the inner boundary), the 7-hinge chain folded back at joint 2 over a twisted joint 1
// (1.66 short of a target behind the root). Before: 100 iterations without getting closer. Now the
// target is reached, by the fast path and by the generic goal machinery, allocation-free.
TEST(JacobianPinv, EscapesSingularSaddles) {
  struct Trap {
    int n;
    unsigned seed;
    int index;  // of the target in benchmark_targets(chain, index + 1, seed)
    std::vector<double> pose;
  };
  const std::vector<Trap> traps = {
      {3, 11, 367, {-2.776, -1.104, -3.140}},
      {7, 11, 3718, {0.059, 1.060, -3.138, 0.322, 0.002, 0.011, 0.000}},
  };
  for (const Trap& trap : traps) {
    const Chain chain = test::make_hinge_chain(trap.n);
    SolverOptions o = options_for(chain);
    o.warm_start = true;
    const Goal g = Goal::position(benchmark_targets(chain, trap.index + 1, trap.seed)[trap.index]);
    const Eigen::VectorXd start = Eigen::Map<const Eigen::VectorXd>(trap.pose.data(), trap.n);
    ASSERT_GT(glm::length(test::tip_of(chain, start) - g.target_position), 0.04) << trap.n;
    Workspace ws(chain, 1);
    for (const bool generic : {false, true}) {
      Eigen::VectorXd p = start;
      auto solve_from_trap = [&] {
        p = start;
        const Span<const Goal> goals(&g, 1);
        if (generic) return jacobian::solve_jacobian_pinv_generic(chain, goals, o, ws, p.data()).reason;
        return solve(kKind, chain, goals, o, ws, p).reason;
      };
      solve_from_trap();  // warm-up
      const std::size_t before = test::allocation_count();
      const TerminationReason reason = solve_from_trap();
      EXPECT_EQ(test::allocation_count(), before) << trap.n << (generic ? " generic" : " fast");
      EXPECT_EQ(reason, TerminationReason::kConverged) << trap.n << (generic ? " generic" : " fast");
      EXPECT_LE(glm::length(test::tip_of(chain, p) - g.target_position), o.position_tolerance)
          << trap.n << (generic ? " generic" : " fast");
    }
  }
}

// The lecture's precision case: target L + 2 from the root. The best reach is the stretched chain
// pointing at it, 2 away (lecture: JI 5.85, CCD 3.37, BFGS 2.53). Needs target clamping (without
// it the pseudo-inverse stops at 2.23 on the hinge chain and 2.83 on the ball chain).
TEST(JacobianPinv, PrecisionCaseEndsExactlyTwoBeyondReach) {
  test::expect_precision_case_from_fixed_bent_start(kKind, options_for);  // the optimum (lecture's JI: 5.85)
}

// Straight chain (rest pose), target on its own line: J^T e = 0 there, every Jacobian method stands
// still without the shared escape (solvers/stuck.hpp). Straight ahead but closer, and behind the root.
TEST(JacobianPinv, SingularStartsOnTheChainLineAreSolved) {
  test::expect_jacobian_singular_starts_solved(kKind, options_for);
}

// Target exactly on the root: no NaN ever reaches the caller. Asserted: a finite pose no worse than
// the start, and (these chains can fold back onto their root) the target is reached.
TEST(JacobianPinv, TargetOnTheRootGivesAFinitePose) { test::expect_jacobian_target_on_root_reached(kKind, options_for); }

// Limits are never violated, and feasible targets (FK of feasible params) are still reached.
// Measured: 89.4% of these targets reached from the rest pose (DLS: 84.6%). The projected
// pseudo-inverse step keeps pushing DOFs that sit on a limit and passes the residual check only
// after heavy halving; before the lenient full-step retry took over there (jacobian_pinv.cpp),
// 68.4% (88.4% with that retry alone, 70.0% with the singular-saddle escape alone).
TEST(JacobianPinv, LimitsRespectedAndFeasibleTargetsReached) {
  test::Tally tally;
  ASSERT_NO_FATAL_FAILURE(test::reach_feasible_targets_on_mixed_chains(kKind, options_for, tally));
  EXPECT_GE(tally.rate(), 0.85) << tally.ok << "/" << tally.trials;
}

// Orientation, aim and two-goal (elbow + hand) solves of poses made by FK, from the rest pose.
TEST(JacobianPinv, OrientationAimAndTwoGoalSolves) {
  test::expect_orientation_aim_and_two_goal_solves(kKind, options_for);
}

// warm_start = false: the result depends only on the goals, not on the incoming params; a warm
// re-solve from the converged pose has nothing left to do.
TEST(JacobianPinv, DeterministicStartIgnoresIncomingParams) {
  test::expect_jacobian_solver_ignores_incoming_params(kKind, options_for);
}

// The fused single-position fast path and the generic goal machinery: the same cost and Jacobian
// at random poses (to rounding), and both stop for the same reason (within tolerance when converged).
TEST(JacobianPinv, FastPathAgreesWithGenericPath) {
  test::expect_fast_path_agrees_with_generic(options_for, solve_jacobian_pinv, jacobian::solve_jacobian_pinv_generic,
                                             test::PathAgreement::kSameReason);
}

// The shared helpers (jacobian_common.hpp): Jacobi eigen-decomposition and the inline sincos.
TEST(JacobianPinv, JacobiEigenDecomposesSymmetricMatrices) {
  std::mt19937 rng(4);
  for (int k : {1, 3, 6}) {
    const Eigen::MatrixXd B = Eigen::MatrixXd::Random(k, 2);  // rank <= 2: exercises zero eigenvalues
    const Eigen::MatrixXd A = B * B.transpose();
    Eigen::MatrixXd D = A, V(k, k);
    jacobian::jacobi_eigen(D, V, k);
    EXPECT_LE((V * D.diagonal().asDiagonal() * V.transpose() - A).norm(), 1e-13 * (1.0 + A.norm())) << k;
    EXPECT_LE((V.transpose() * V - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-13) << k;
    EXPECT_LE((D - Eigen::MatrixXd(D.diagonal().asDiagonal())).norm(), 1e-13 * (1.0 + A.norm())) << k;
  }
}

TEST(JacobianPinv, FastSincosMatchesLibm) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 100000; ++i) {
    const double x = u(rng) * (i % 2 ? 4.0 : 2000.0);
    double s, c;
    so3::fast_sincos(x, s, c);
    worst = std::max(worst, std::max(std::abs(s - std::sin(x)), std::abs(c - std::cos(x))));
  }
  EXPECT_LE(worst, 4e-16);
  double s, c;
  so3::fast_sincos(1e7, s, c);  // libm fallback
  EXPECT_EQ(s, std::sin(1e7));
  EXPECT_EQ(c, std::cos(1e7));
}

TEST(JacobianPinv, SolveAllocatesNothing) { test::expect_jacobian_solves_allocate_nothing(kKind, options_for); }

TEST(JacobianPinv, InvalidInputLeavesParamsUntouched) {
  const Chain chain = test::make_hinge_chain(3);
  SolverOptions o = options_for(chain);
  o.pinv_residual_tolerance = 1.5;
  test::expect_rejected_and_untouched(kKind, chain, {Goal::position(glm::dvec3(1, 1, 0))}, o,
                                      Eigen::VectorXd::Constant(3, 0.3), "pinv_residual_tolerance");
}

}  // namespace
}  // namespace ikchain
