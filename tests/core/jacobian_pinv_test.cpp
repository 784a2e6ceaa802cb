// Jacobian pseudo-inverse with residual check and step halving (src/core/solvers/jacobian_pinv.cpp).
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/so3.hpp"
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

// The lecture's precision case: target L + 2 from the root. The best reach is the stretched chain
// pointing at it, 2 away (lecture: JI 5.85, CCD 3.37, BFGS 2.53). Needs target clamping (without
// it the pseudo-inverse stops at 2.23 on the hinge chain and 2.83 on the ball chain).
TEST(JacobianPinv, PrecisionCaseEndsExactlyTwoBeyondReach) {
  test::expect_precision_case_from_fixed_bent_start(kKind, options_for);  // the optimum (lecture's JI: 5.85)
}

// Straight chain (rest pose), target on its own line: J^T e = 0 there, every Jacobian method stands
// still without the solver's deterministic kick. Straight ahead but closer, and behind the root.
TEST(JacobianPinv, SingularStartsOnTheChainLineAreSolved) {
  test::expect_jacobian_singular_starts_solved(kKind, options_for);
}

// Target exactly on the root: no NaN ever reaches the caller. Asserted: a finite pose no worse than
// the start, and (these chains can fold back onto their root) the target is reached.
TEST(JacobianPinv, TargetOnTheRootGivesAFinitePose) { test::expect_jacobian_target_on_root_reached(kKind, options_for); }

// Limits are never violated, and feasible targets (FK of feasible params) are still reached.
// Measured: 68.4% of these targets reached from the rest pose (the projected pseudo-inverse step
// keeps pushing DOFs that sit on a limit, then stalls; DLS: 84.6%). Limits are never violated.
TEST(JacobianPinv, LimitsRespectedAndFeasibleTargetsReached) {
  test::Tally tally;
  ASSERT_NO_FATAL_FAILURE(test::reach_feasible_targets_on_mixed_chains(kKind, options_for, tally));
  EXPECT_GE(tally.rate(), 0.65) << tally.ok << "/" << tally.trials;
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
