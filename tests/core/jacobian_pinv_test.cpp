// Jacobian pseudo-inverse with residual check and step halving (src/core/solvers/jacobian_pinv.cpp).
#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "core/so3.hpp"
#include "core/solvers/jacobian_common.hpp"
#include "test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kJacobianPinv;

SolveResult run(const Chain& chain, const std::vector<Goal>& goals, const SolverOptions& o, Workspace& ws,
                Eigen::VectorXd& params) {
  return solve(kKind, chain, Span<const Goal>(goals), o, ws, params);
}

SolverOptions options_for(const Chain& chain) {
  SolverOptions o;
  o.position_tolerance = 1e-5 * chain.total_length();
  o.warm_start = false;
  return o;
}

// FK round trip (KDL solvertest style): random params -> tip target -> solve from the rest pose
// -> own FK distance. Returns the fraction within 1e-5 * L.
double round_trip_success(const Chain& chain, int trials, unsigned seed) {
  std::mt19937 rng(seed);
  Workspace ws(chain, 1);
  const SolverOptions o = options_for(chain);
  Eigen::VectorXd params(chain.dof_count());
  int ok = 0;
  for (int t = 0; t < trials; ++t) {
    const glm::dvec3 target = test::tip_of(chain, test::random_params(chain, rng));
    params = test::random_params(chain, rng);  // ignored: warm_start = false starts from rest
    const std::vector<Goal> goals = {Goal::position(target)};
    const SolveResult r = run(chain, goals, o, ws, params);
    const double d = glm::length(test::tip_of(chain, params) - target);
    if (d <= o.position_tolerance) {
      ++ok;
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
    }
  }
  return static_cast<double>(ok) / trials;
}

// >= 99.9% within 1e-5 L for every n, from the rest pose, 100 iterations. The 3-joint z/y/z chain
// (3 DOF for 3 rows, often near singular) is the hard one: it needs the truncated retries of
// jacobian_pinv.cpp (68.5% without them).
TEST(JacobianPinv, FkRoundTripHingeChains) {
  const struct {
    int n;
    double at_least;
  } cases[] = {{2, 0.999}, {3, 0.999}, {7, 0.999}, {10, 0.999}, {30, 0.999}};
  for (const auto& c : cases) {
    const int trials = c.n >= 30 ? 300 : 1000;
    EXPECT_GE(round_trip_success(test::make_hinge_chain(c.n), trials, 100 + c.n), c.at_least) << c.n << " hinges";
  }
}

TEST(JacobianPinv, FkRoundTripBallChains) {
  for (int n : {2, 3, 7, 10, 30}) {
    const int trials = n >= 30 ? 200 : 1000;
    EXPECT_GE(round_trip_success(test::make_ball_chain(n, 0.5), trials, 200 + n), 0.999) << n << " balls";
  }
}

// The lecture's precision case: target L + 2 from the root. The best reach is the stretched chain
// pointing at it, 2 away (lecture: JI 5.85, CCD 3.37, BFGS 2.53). Needs target clamping (without
// it the pseudo-inverse stops at 2.23 on the hinge chain and 2.83 on the ball chain).
TEST(JacobianPinv, PrecisionCaseEndsExactlyTwoBeyondReach) {
  struct Case {
    Chain chain;
    glm::dvec3 direction;
  };
  // The 3-D hinge chain straightens only within the xy-plane (joint 0 turns about z, the y-hinges
  // twist about their own bones); the ball chain can point anywhere.
  const std::vector<Case> cases = {
      {test::make_hinge_chain(10), glm::dvec3(std::cos(0.7), std::sin(0.7), 0.0)},
      {test::make_ball_chain(10, 0.5), glm::normalize(glm::dvec3(0.3, 0.8, -0.5))},
  };
  for (const Case& c : cases) {
    const double L = c.chain.total_length();
    Workspace ws(c.chain, 1);
    SolverOptions o = options_for(c.chain);
    o.warm_start = true;
    Eigen::VectorXd params(c.chain.dof_count());
    for (int i = 0; i < params.size(); ++i) params[i] = (i % 2 == 0) ? 0.35 : -0.25;  // bent start
    const glm::dvec3 target = c.chain.root_in_base() + c.direction * (L + 2.0);
    const SolveResult r = run(c.chain, {Goal::position(target)}, o, ws, params);
    const double d = glm::length(test::tip_of(c.chain, params) - target);
    EXPECT_NEAR(d, 2.0, 1e-6 * L);  // the optimum (lecture's JI: 5.85)
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable);
    EXPECT_NEAR(r.final_error, d, 1e-12);
  }
}

// Straight chain (rest pose), target on its own line: J^T e = 0 there, every Jacobian method stands
// still without the solver's deterministic kick. Straight ahead but closer, and behind the root.
TEST(JacobianPinv, SingularStartsOnTheChainLineAreSolved) {
  for (const Chain& chain : {test::make_hinge_chain(10), test::make_ball_chain(6)}) {
    const double L = chain.total_length();
    Workspace ws(chain, 1);
    const SolverOptions o = options_for(chain);
    for (const glm::dvec3& target : {glm::dvec3(0, 0.6 * L, 0), glm::dvec3(0, -0.5 * L, 0)}) {
      Eigen::VectorXd params = Eigen::VectorXd::Zero(chain.dof_count());
      const SolveResult r = run(chain, {Goal::position(target)}, o, ws, params);
      EXPECT_EQ(r.reason, TerminationReason::kConverged) << target.y;
      EXPECT_LE(glm::length(test::tip_of(chain, params) - target), o.position_tolerance);
    }
  }
}

// Target exactly on the root: no NaN ever reaches the caller. Asserted: a finite pose no worse than
// the start, and (these chains can fold back onto their root) the target is reached.
TEST(JacobianPinv, TargetOnTheRootGivesAFinitePose) {
  for (const Chain& chain : {test::make_hinge_chain(4), test::make_ball_chain(4)}) {
    Workspace ws(chain, 1);
    const SolverOptions o = options_for(chain);
    Eigen::VectorXd params = Eigen::VectorXd::Zero(chain.dof_count());
    const SolveResult r = run(chain, {Goal::position(chain.root_in_base())}, o, ws, params);
    EXPECT_TRUE(params.allFinite());
    EXPECT_TRUE(r.pose_usable);
    EXPECT_LE(r.final_error, r.initial_error);
    EXPECT_EQ(r.reason, TerminationReason::kConverged);
  }
}

glm::dvec3 effector_of(const Chain& chain, const Eigen::VectorXd& params, int effector) {
  Workspace ws(chain, 1);
  forward_kinematics(chain, params.data(), ws);
  return effector_position(chain, ws, effector);
}

Chain limited_chain(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    if (i % 3 == 2) {
      j.type = JointType::kBall;
      j.limits.has_cone_limit = true;
      j.limits.cone_angle = 0.3 + 1.2 * u(rng);
      j.limits.has_twist_limit = true;
      j.limits.twist_min = -0.2 - u(rng);
      j.limits.twist_max = 0.2 + u(rng);
    } else {
      j.type = JointType::kHinge;
      j.hinge_axis = (i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
      j.limits.has_hinge_limit = true;
      j.limits.hinge_min = -0.2 - 1.5 * u(rng);
      j.limits.hinge_max = 0.2 + 1.5 * u(rng);
    }
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).empty());
  return c;
}

// Limits are never violated, and feasible targets (FK of feasible params) are still reached.
// Measured: 68.4% of these targets reached from the rest pose (the projected pseudo-inverse step
// keeps pushing DOFs that sit on a limit, then stalls; DLS: 84.6%). Limits are never violated.
TEST(JacobianPinv, LimitsRespectedAndFeasibleTargetsReached) {
  std::mt19937 rng(11);
  int ok = 0, trials = 0;
  for (int chain_index = 0; chain_index < 10; ++chain_index) {
    const Chain chain = limited_chain(7, rng);
    Workspace ws(chain, 1);
    const SolverOptions o = options_for(chain);
    for (int t = 0; t < 50; ++t, ++trials) {
      const glm::dvec3 target = test::tip_of(chain, test::random_params(chain, rng));
      Eigen::VectorXd params(chain.dof_count());
      run(chain, {Goal::position(target)}, o, ws, params);
      ASSERT_TRUE(within_limits(chain, params.data())) << "chain " << chain_index << " trial " << t;
      if (glm::length(test::tip_of(chain, params) - target) <= o.position_tolerance) ++ok;
    }
  }
  EXPECT_GE(static_cast<double>(ok) / trials, 0.65) << ok << "/" << trials;
}

// Orientation, aim and two-goal (elbow + hand) solves of poses made by FK, from the rest pose.
TEST(JacobianPinv, OrientationAimAndTwoGoalSolves) {
  const Chain chain = test::make_ball_chain(4, 0.5);
  std::mt19937 rng(5);
  Workspace ws(chain, 4);
  SolverOptions o = options_for(chain);
  int ok = 0;
  const int trials = 100;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(chain, rng, 1.5);
    Workspace fk(chain, 1);
    forward_kinematics(chain, truth.data(), fk);
    const glm::dvec3 hand = fk.tip, elbow = fk.joint_origins[2];
    const glm::dquat hand_rotation = fk.joint_orientations[3];
    const std::vector<std::vector<Goal>> problems = {
        {Goal::position(hand), Goal::orientation(hand_rotation)},
        {Goal::orientation(hand_rotation, 2)},
        {Goal::aim(glm::dvec3(0, 1, 0), hand_rotation * glm::dvec3(0, 1, 0))},
        {Goal::position(elbow, 2), Goal::position(hand)},
    };
    bool all = true;
    for (const std::vector<Goal>& goals : problems) {
      Eigen::VectorXd params(chain.dof_count());
      const SolveResult r = run(chain, goals, o, ws, params);
      all = all && r.reason == TerminationReason::kConverged;
      EXPECT_LE(r.final_position_error, o.position_tolerance);
      EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
    }
    ok += all;
  }
  EXPECT_EQ(ok, trials);
}

// warm_start = false: the result depends only on the goals, not on the incoming params.
TEST(JacobianPinv, DeterministicStartIgnoresIncomingParams) {
  const Chain chain = test::make_hinge_chain(10);
  Workspace ws(chain, 2);
  SolverOptions o = options_for(chain);
  std::mt19937 rng(3);
  for (int t = 0; t < 20; ++t) {
    const std::vector<Goal> goals = {Goal::position(test::tip_of(chain, test::random_params(chain, rng)))};
    Eigen::VectorXd a = test::random_params(chain, rng), b = test::random_params(chain, rng);
    const SolveResult ra = run(chain, goals, o, ws, a);
    const SolveResult rb = run(chain, goals, o, ws, b);
    EXPECT_EQ(a, b);
    EXPECT_EQ(ra.iterations, rb.iterations);
    // warm start from a converged pose: nothing left to do.
    o.warm_start = true;
    const SolveResult warm = run(chain, goals, o, ws, a);
    EXPECT_EQ(warm.reason, TerminationReason::kConverged);
    EXPECT_EQ(warm.iterations, 0);
    EXPECT_EQ(a, b);
    o.warm_start = false;
  }
}

// The fused single-position fast path and the generic goal machinery: the same cost and Jacobian
// at random poses (to rounding), and both solve the same problems.
TEST(JacobianPinv, FastPathAgreesWithGenericPath) {
  for (const Chain& chain : {test::make_hinge_chain(10), test::make_ball_chain(5), test::make_hinge_chain(3)}) {
    std::mt19937 rng(9);
    Workspace ws(chain, 1), generic_ws(chain, 1);
    const SolverOptions o = options_for(chain);
    const int n = chain.dof_count();
    for (int t = 0; t < 200; ++t) {
      const int effector = t % 3 == 0 ? 0 : 1 + t % chain.joint_count();
      const std::vector<Goal> goals = {
          Goal::position(effector_of(chain, test::random_params(chain, rng), effector), effector, 0.7)};
      const Eigen::VectorXd pose = test::random_params(chain, rng);
      jacobian::SinglePositionModel model(chain, goals[0], ws);
      const double cost = model.evaluate(pose.data());
      model.accept();
      model.linearize(pose.data());
      forward_kinematics(chain, pose.data(), generic_ws);
      compute_dof_axes(chain, pose.data(), generic_ws);
      Eigen::VectorXd e(3);
      const GoalErrors err = evaluate_goals(chain, goals, generic_ws, e);
      Eigen::MatrixXd J(3, n);
      compute_jacobian(chain, goals, generic_ws, J);
      EXPECT_NEAR(cost, err.cost, 1e-12 * (1.0 + err.cost));
      const int active = model.active_dofs();
      EXPECT_LE((ws.jacobian.topLeftCorner(3, active) - J.leftCols(active)).norm(), 1e-12 * (1.0 + J.norm()));
      EXPECT_EQ(J.rightCols(n - active).norm(), 0.0);  // DOFs past the effector do not move it

      Eigen::VectorXd fast = Eigen::VectorXd::Zero(n), generic = fast;
      const SolverStatus sf = solve_jacobian_pinv(chain, goals, o, ws, fast.data());
      const SolverStatus sg = jacobian::solve_jacobian_pinv_generic(chain, goals, o, ws, generic.data());
      EXPECT_EQ(sf.reason, sg.reason);
      if (sf.reason == TerminationReason::kConverged) {
        EXPECT_LE(glm::length(effector_of(chain, fast, goals[0].effector) - goals[0].target_position),
                  o.position_tolerance);
        EXPECT_LE(glm::length(effector_of(chain, generic, goals[0].effector) - goals[0].target_position),
                  o.position_tolerance);
      }
    }
  }
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

TEST(JacobianPinv, SolveAllocatesNothing) {
  const Chain chain = test::make_hinge_chain(10);
  Workspace ws(chain, 4);
  const SolverOptions o = options_for(chain);
  std::mt19937 rng(1);
  const glm::dvec3 hand = test::tip_of(chain, test::random_params(chain, rng));
  const std::vector<std::vector<Goal>> problems = {
      {Goal::position(hand)},                                              // fast path
      {Goal::position(glm::dvec3(1, 2, 0), 5), Goal::position(hand)},      // generic, m < n
      {Goal::position(hand), Goal::orientation(glm::dquat(1, 0, 0, 0)),   // generic, m >= n
       Goal::aim(glm::dvec3(0, 1, 0), glm::dvec3(1, 0, 0), 3), Goal::position(glm::dvec3(0, 3, 0), 4)},
  };
  Eigen::VectorXd params(chain.dof_count());
  for (const std::vector<Goal>& goals : problems) {
    run(chain, goals, o, ws, params);  // warm-up
    const std::size_t before = test::allocation_count();
    const SolveResult r = run(chain, goals, o, ws, params);
    EXPECT_EQ(test::allocation_count(), before);
    EXPECT_TRUE(r.pose_usable);
  }
}

TEST(JacobianPinv, InvalidInputLeavesParamsUntouched) {
  const Chain chain = test::make_hinge_chain(3);
  Workspace ws(chain, 1);
  SolverOptions o = options_for(chain);
  o.pinv_residual_tolerance = 1.5;
  Eigen::VectorXd params = Eigen::VectorXd::Constant(3, 0.3);
  const SolveResult r = run(chain, {Goal::position(glm::dvec3(1, 1, 0))}, o, ws, params);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("pinv_residual_tolerance"), std::string::npos);
  EXPECT_EQ(params, Eigen::VectorXd::Constant(3, 0.3));
}

}  // namespace
}  // namespace ikchain
