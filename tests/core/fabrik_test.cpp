// FABRIK (src/core/solvers/fabrik.cpp): forward-kinematics round trips with measured success rates, the
// lecture's precision case, singular starts, limits, orientation / aim / two-goal solves,
// deterministic starts and the no-allocation guarantee.
#include <cmath>
#include <random>
#include <vector>

#include "ikchain/kinematics.hpp"
#include "ikchain/so3.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kFABRIK;

SolverOptions options_for(const Chain& c, int max_iterations = 200) { return test::sweep_options(c, max_iterations); }

// Random reachable targets (FK of random feasible params), solved from the rest pose. Every solve
// must stay finite and within the limits; returns the fraction within position_tolerance.
double round_trip_rate(const Chain& c, int trials, int max_iterations, unsigned seed) {
  return test::round_trip_rate(kKind, c, options_for(c, max_iterations), trials, seed, test::rest_start_checks());
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
  test::expect_precision_case_from_random_bent_starts(kKind);
}

// Straight rest pose, a fixed point of plain FABRIK when the target is straight ahead. Asserted:
// ahead-but-closer (0.6 L, 0.9 L) and behind-the-root targets (all reachable) converge (one
// exception below); a target exactly on the root gives a finite pose no farther
// from it than the start, and the 4-bone chain (which can fold onto its root) reaches it.
TEST(FABRIK, SingularStartsStraightChain) {
  test::StraightStartChecks ball;
  ball.finite = true;
  ball.no_worse = true;
  // The 4-hinge chain (z, y, z, y: a 2 + 2 arm with twists) from straight to 0.6 L ends at a
  // fixed point of FABRIK's hinge conversion (measured error 1.35, kStalled): a known weakness
  // of positional FABRIK with hinges, not asserted as converged.
  test::StraightStartChecks hinge = ball;
  hinge.not_asserted_converged = 0.6;
  test::expect_sweep_singular_starts(kKind, ball, hinge);
}

// Limits hold after every solve (reachable and unreachable targets), and targets made from
// feasible params are still reached at the measured rate.
TEST(FABRIK, LimitsNeverViolatedAndFeasibleTargetsReached) {
  // Measured: hinge n=3 0.810, n=7 0.797; ball n=3 0.870, n=7 0.757 (FABRIK's positional
  // stages do not see the limits; the per-joint projection pulls it off its path).
  test::expect_limits_respected_on_uniform_chains(kKind, {0.77, 0.75, 0.83, 0.71});
}

// Elbow + hand position goals: the elbow's goal pins its point during forward reaching (a
// sub-base). A full pose of the hand (position + orientation, made by FK) is pursued: the
// orientation pins the last joint's point and the last joint takes the final alignment (fabrik.cpp).
TEST(FABRIK, TwoPositionGoalsAndFullPose) {
  std::mt19937 rng(51);
  const Chain c = test::make_ball_chain(5);
  Workspace ws(c, 2);
  SolverOptions o = options_for(c, 200);
  Workspace fk(c, 1);
  int two_ok = 0, pose_ok = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng, 2.0);
    forward_kinematics(c, truth.data(), fk);
    const std::vector<Goal> two = {Goal::position(fk.joint_origins[3], 3), Goal::position(fk.tip)};
    const std::vector<Goal> pose = {Goal::position(fk.tip), Goal::orientation(fk.joint_orientations[4])};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    SolveResult r = solve(kKind, c, two, o, ws, p);
    EXPECT_TRUE(p.allFinite());
    if (r.reason == TerminationReason::kConverged) ++two_ok;
    p.setZero();
    r = solve(kKind, c, pose, o, ws, p);
    EXPECT_TRUE(r.usable());
    EXPECT_LE(r.final_error, r.initial_error);
    if (r.reason == TerminationReason::kConverged) {
      EXPECT_LE(r.final_position_error, o.position_tolerance);
      EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
      ++pose_ok;
    }
  }
  // Measured: 178 of 200 two-goal solves converge, 199 of 200 full poses.
  EXPECT_GE(two_ok, 0.85 * trials);
  EXPECT_GE(pose_ok, 0.97 * trials);
}

// A 7-hinge arm shaped like the xArm7 (its URDF's joint offsets and turns, rounded): the tool frame
// sits on the last hinge's origin (tip_offset 0) and is turned (tip_rotation). Pinning the last
// joint's point from the orientation then says nothing (it is the tip); the orientation has to come
// from the last hinge's axis and the circle of the joint before it (fabrik.cpp). Full poses from FK
// of random params, checked by the matrix FK (test::hinge_tool_frame_by_matrices).
TEST(FABRIK, FullPoseWithToolFrameOnTheLastHinge) {
  const double quarter = 0.5 * so3::kPi;
  const struct {
    glm::dvec3 offset;
    double turn_about_x;
  } joints[7] = {{{0.0, 0.0, 0.267}, 0.0},      {{0.0, 0.0, 0.0}, -quarter},     {{0.0, -0.293, 0.0}, quarter},
                 {{0.0525, 0.0, 0.0}, quarter}, {{0.0775, -0.3425, 0.0}, quarter}, {{0.0, 0.0, 0.0}, quarter},
                 {{0.076, 0.097, 0.0}, -quarter}};
  ChainBuilder b;
  for (const auto& j : joints) {
    JointDesc d;
    d.type = JointType::kHinge;
    d.offset_translation = j.offset;
    d.rest_rotation = glm::angleAxis(j.turn_about_x, glm::dvec3(1.0, 0.0, 0.0));
    d.axis = glm::dvec3(0.0, 0.0, 1.0);
    b.add_joint(d);
  }
  b.set_tip_frame(glm::dvec3(0.0), glm::angleAxis(0.9, glm::normalize(glm::dvec3(1.0, -2.0, 0.5))));
  Chain c;
  ASSERT_TRUE(b.build(c).ok());
  ASSERT_EQ(c.tip_offset(), glm::dvec3(0.0));
  SolverOptions o = options_for(c, 500);
  o.orientation_tolerance = 1e-4;
  Workspace ws(c, 2);
  std::mt19937 rng(61);
  int reached = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = test::random_params(c, rng, 3.0);
    const glm::dmat4 goal_frame = test::hinge_tool_frame_by_matrices(c, truth.data());
    const glm::dvec3 goal_position(goal_frame[3]);
    const glm::dquat goal_orientation = glm::quat_cast(glm::dmat3(goal_frame));
    const auto goals = pose_goals(c, goal_position, goal_orientation);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve(kKind, c, Span<const Goal>(goals.data(), 2), o, ws, p);
    ASSERT_TRUE(r.usable());
    const glm::dmat4 got = test::hinge_tool_frame_by_matrices(c, p.data());
    const double position_error = glm::length(glm::dvec3(got[3]) - goal_position);
    const glm::dquat delta = glm::quat_cast(glm::dmat3(got)) * glm::conjugate(goal_orientation);
    const double angle = 2.0 * std::atan2(glm::length(glm::dvec3(delta.x, delta.y, delta.z)), std::abs(delta.w));
    if (r.reason == TerminationReason::kConverged) {
      EXPECT_LE(position_error, o.position_tolerance * (1.0 + 1e-9));
      EXPECT_LE(angle, o.orientation_tolerance * (1.0 + 1e-9));
    }
    reached += position_error <= o.position_tolerance && angle <= o.orientation_tolerance;
  }
  // Measured: 159 of 200 (0 when only the last joint's point was pinned: it is the tip).
  EXPECT_GE(reached, 0.72 * trials);
}

TEST(FABRIK, DeterministicStartIgnoresIncomingParams) { test::expect_sweep_solver_ignores_incoming_params(kKind); }

TEST(FABRIK, SolveAllocatesNothing) {
  const Chain c = test::make_ball_chain(10);
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(1.0, 2.0, 1.0), 5),
                                   Goal::position(glm::dvec3(1.0, 4.0, 2.0))};
  test::expect_solves_allocate_nothing(kKind, c, goals, options_for(c));
}

}  // namespace
}  // namespace ikchain
