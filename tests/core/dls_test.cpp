// Damped least squares / Levenberg-Marquardt (src/core/solvers/dls.cpp).
#include <random>
#include <vector>

#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kDLS;

// Always from the rest pose (warm_start = false), the default budget, tolerance 1e-5 L.
SolverOptions options_for(const Chain& chain) { return test::cold_start_options(chain); }

// FK round trips from the rest pose (the random incoming params are ignored) on the benchmark
// chains n = 2, 3, 7, 10, 30: at least 99.9% within 1e-5 L for every n.
TEST(DLS, FkRoundTripHingeChains) {
  test::expect_benchmark_round_trips(kKind, options_for, test::cold_start_checks(), JointType::kHinge, 100, 300, 0.999);
}

TEST(DLS, FkRoundTripBallChains) {
  test::expect_benchmark_round_trips(kKind, options_for, test::cold_start_checks(), JointType::kBall, 200, 200, 0.999);
}

// The lecture's precision case: target L + 2 from the root. The best reach is the stretched chain
// pointing at it, 2 away; the solver must end there (lecture: JI 5.85, CCD 3.37, BFGS 2.53).
TEST(DLS, PrecisionCaseEndsExactlyTwoBeyondReach) {
  test::expect_precision_case_from_fixed_bent_start(kKind, options_for);
}

// Straight chain (rest pose), target on its own line: J^T e = 0 there, every Jacobian method stands
// still without the shared escape (solvers/stuck.hpp). Straight ahead but closer, and behind the root.
TEST(DLS, SingularStartsOnTheChainLineAreSolved) {
  test::expect_jacobian_singular_starts_solved(kKind, options_for);
}

// Target exactly on the root: no NaN ever reaches the caller. Asserted: a finite pose no worse than
// the start, and (these chains can fold back onto their root) the target is reached.
TEST(DLS, TargetOnTheRootGivesAFinitePose) { test::expect_jacobian_target_on_root_reached(kKind, options_for); }

// Limits are never violated, and feasible targets (FK of feasible params) are still reached.
// Measured: 84.6% of these targets reached from the rest pose (the rest stall against a limit: a
// local minimum of the constrained problem, which a local method cannot leave).
TEST(DLS, LimitsRespectedAndFeasibleTargetsReached) {
  test::Tally tally;
  ASSERT_NO_FATAL_FAILURE(test::reach_feasible_targets_on_mixed_chains(kKind, options_for, tally));
  EXPECT_GE(tally.rate(), 0.80);
}

// Orientation, aim and two-goal (elbow + hand) solves of poses made by FK, from the rest pose.
TEST(DLS, OrientationAimAndTwoGoalSolves) { test::expect_orientation_aim_and_two_goal_solves(kKind, options_for); }

// warm_start = false: the result depends only on the goals, not on the incoming params; a warm
// re-solve from the converged pose has nothing left to do.
TEST(DLS, DeterministicStartIgnoresIncomingParams) {
  test::expect_jacobian_solver_ignores_incoming_params(kKind, options_for);
}

// The fused single-position fast path and the generic goal machinery: the same cost and Jacobian
// at random poses (to rounding), and both solve every one of the problems.
TEST(DLS, FastPathAgreesWithGenericPath) {
  test::expect_fast_path_agrees_with_generic(options_for, solve_dls, jacobian::solve_dls_generic,
                                             test::PathAgreement::kBothConverge);
}

// The geodesic acceleration's second derivative of the effector along a joint direction h,
// against a central finite difference of forward kinematics, on hinge chains with rest rotations,
// tilted axes and a mid-chain effector. Step 1e-4: truncation ~1e-8 relative.
TEST(DLS, EffectorSecondDerivativeMatchesFiniteDifference) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    ChainBuilder b;
    const int n = 2 + trial % 9;
    for (int i = 0; i < n; ++i) {
      JointDesc j;
      j.type = JointType::kHinge;
      j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0.2 * u(rng), 1.0, 0.2 * u(rng));
      j.axis = trial % 2 ? glm::dvec3(u(rng), u(rng), u(rng)) : glm::dvec3(0, 0, 1);
      j.rest_rotation = glm::angleAxis(0.5 * u(rng), glm::normalize(glm::dvec3(u(rng), u(rng), 1.0)));
      b.add_joint(j);
    }
    b.set_tip_offset(glm::dvec3(0.1, 0.8, 0.0));
    Chain chain;
    ASSERT_TRUE(b.build(chain).ok());
    const int effector = trial % 3 == 0 ? n - 1 : 0;  // a joint origin or the tip
    Workspace ws(chain, 1);
    const Eigen::VectorXd theta = test::random_params(chain, rng);
    Eigen::VectorXd h(n);
    for (int i = 0; i < n; ++i) h[i] = u(rng);
    const Goal goal = Goal::position(glm::dvec3(1, 2, 3), effector, 0.6);
    jacobian::SinglePositionModel model(chain, goal, ws);
    model.evaluate(theta.data());
    model.accept();
    model.linearize(theta.data());
    const glm::dvec3 analytic = model.effector_second_derivative(h.data());
    const double eps = 1e-4;
    const Eigen::VectorXd plus = theta + eps * h, minus = theta - eps * h;
    const glm::dvec3 fd = (test::effector_of(chain, plus, effector) - 2.0 * test::effector_of(chain, theta, effector) +
                           test::effector_of(chain, minus, effector)) / (eps * eps);
    EXPECT_LE(glm::length(analytic - fd), 1e-5 * (1.0 + glm::length(fd))) << "trial " << trial;
  }
}

// A start at the rest pose copies the chain's precomputed frames instead of evaluating them: the
// same cost and the same Jacobian as evaluating, for tip and mid-chain effectors; any other start
// is evaluated.
TEST(DLS, RestStartUsesPrecomputedFramesWithTheSameResult) {
  std::mt19937 rng(43);
  for (const Chain& chain : {test::make_hinge_chain(6), test::make_ball_chain(4)}) {
    for (int effector : {0, 2}) {
      const Goal goal = Goal::position(glm::dvec3(0.5, 1.5, -0.5), effector, 0.8);
      for (bool at_rest : {true, false}) {
        const Eigen::VectorXd start =
            at_rest ? Eigen::VectorXd(Eigen::VectorXd::Zero(chain.dof_count())) : test::random_params(chain, rng);
        Workspace a_ws(chain, 1), b_ws(chain, 1);
        jacobian::SinglePositionModel a(chain, goal, a_ws), b(chain, goal, b_ws);
        const double cost_a = a.evaluate_start(start.data());
        const double cost_b = b.evaluate(start.data());
        EXPECT_NEAR(cost_a, cost_b, 1e-14 * (1.0 + cost_b));
        a.accept();
        b.accept();
        a.linearize(start.data());
        b.linearize(start.data());
        const int active = a.active_dofs();
        EXPECT_LE((a_ws.jacobian.topLeftCorner(3, active) - b_ws.jacobian.topLeftCorner(3, active)).norm(),
                  1e-14 * (1.0 + b_ws.jacobian.norm()));
      }
    }
  }
}

TEST(DLS, SolveAllocatesNothing) { test::expect_jacobian_solves_allocate_nothing(kKind, options_for); }

TEST(DLS, InvalidInputLeavesParamsUntouched) {
  const Chain chain = test::make_hinge_chain(3);
  SolverOptions o = options_for(chain);
  o.dls_max_damping = 0.5 * o.dls_min_damping;
  test::expect_rejected_and_untouched(kKind, chain, {Goal::position(glm::dvec3(1, 1, 0))}, o,
                                      Eigen::VectorXd::Constant(3, 0.3), "dls_max_damping");
}

}  // namespace
}  // namespace ikchain
