// Goal kinds and the tip (tool) frame, across the solvers: aim-at-a-point goals (FK round trips
// and an exact-gradient check of their Jacobian rows), orientation goals on a rotated tool frame,
// and FABRIK / CCD pursuing orientation goals (or FABRIK rejecting them where it cannot).
#include <cmath>
#include <random>
#include <string>

#include "solver_test_util.hpp"

namespace ikchain {
namespace {

// Every solver that takes any goal (two-bone takes one tip position goal only).
const SolverKind kGeneralSolvers[] = {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS,
                                      SolverKind::kBFGS, SolverKind::kFABRIK};

SolverOptions goal_options(const Chain& c) {
  SolverOptions o;
  o.position_tolerance = 1e-5 * c.total_length();
  o.orientation_tolerance = 1e-5;
  o.max_iterations = 500;
  o.warm_start = false;
  return o;
}

// A 4-ball chain (0.5 links along +Y) with a rotated, offset tool frame.
Chain tool_chain(const glm::dquat& tool_rotation) {
  ChainBuilder b;
  for (int i = 0; i < 4; ++i) {
    JointDesc j;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 0.5, 0);
    b.add_joint(j);
  }
  b.set_tip_frame(glm::dvec3(0.1, 0.4, 0.0), tool_rotation);
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_TRUE(m.empty()) << m.c_str();
  return c;
}

double angle_between(const glm::dquat& a, const glm::dquat& b) {
  return glm::length(so3::log(glm::normalize(a) * glm::conjugate(glm::normalize(b))));
}

// The effector's aim axis in base space and its angle to the direction effector -> point.
double aim_at_angle(const Chain& c, const Eigen::VectorXd& p, const Goal& g) {
  Workspace fk(c, 1);
  forward_kinematics(c, p.data(), fk);
  const glm::dvec3 axis = glm::normalize(effector_orientation(c, fk, g.effector) * g.aim_axis);
  const glm::dvec3 to_point = glm::normalize(g.target_position - effector_position(c, fk, g.effector));
  return std::acos(std::clamp(glm::dot(axis, to_point), -1.0, 1.0));
}

TEST(TipFrame, EffectorOrientationIsTheToolFrame) {
  const glm::dquat tool = glm::angleAxis(1.2, glm::normalize(glm::dvec3(1, 0.5, -0.3)));
  const Chain c = tool_chain(tool);
  std::mt19937 rng(3);
  const Eigen::VectorXd p = test::random_params(c, rng, 1.5);
  Workspace fk(c, 1);
  forward_kinematics(c, p.data(), fk);
  EXPECT_LT(angle_between(effector_orientation(c, fk, 0), fk.joint_orientations[3] * tool), 1e-12);
  EXPECT_LT(angle_between(effector_orientation(c, fk, 3), fk.joint_orientations[2]), 1e-12);  // not the tip
  const glm::dvec3 expected_tip = fk.joint_origins[3] + fk.joint_orientations[3] * glm::dvec3(0.1, 0.4, 0.0);
  EXPECT_LT(glm::length(fk.tip - expected_tip), 1e-12);
}

TEST(TipFrame, BuildRejectsBadToolRotation) {
  ChainBuilder b;
  b.add_joint(JointDesc());
  b.set_tip_frame(glm::dvec3(0, 1, 0), glm::dquat(0, 0, 0, 0));
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_NE(std::string(m.c_str()).find("tip_rotation"), std::string::npos) << m.c_str();
  EXPECT_FALSE(c.valid());
}

// Full poses (tip position + tool-frame orientation) made by FK, solved from rest by every solver.
// The oracle is our own FK of the tool frame: Q_3 * tool_rotation.
TEST(TipFrame, FullPoseRoundTripsWithRotatedTool) {
  const glm::dquat tool = glm::angleAxis(0.5 * so3::kPi, glm::dvec3(1, 0, 0));
  const Chain c = tool_chain(tool);
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 2);
  for (SolverKind kind : kGeneralSolvers) {
    std::mt19937 rng(17);
    int ok = 0;
    const int trials = 60;
    for (int t = 0; t < trials; ++t) {
      const Eigen::VectorXd truth = test::random_params(c, rng, 1.2);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      const glm::dquat tool_in_base = fk.joint_orientations[3] * tool;
      const std::vector<Goal> goals = {Goal::position(fk.tip), Goal::orientation(tool_in_base)};
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      ASSERT_TRUE(r.usable()) << to_string(kind) << ": " << r.message.c_str();
      forward_kinematics(c, p.data(), fk);
      const double position_error = glm::length(fk.tip - goals[0].target_position);
      const double orientation_error = angle_between(fk.joint_orientations[3] * tool, tool_in_base);
      EXPECT_NEAR(r.final_position_error, position_error, 1e-9);
      EXPECT_NEAR(r.final_orientation_error, orientation_error, 1e-9);
      if (position_error <= o.position_tolerance && orientation_error <= o.orientation_tolerance) {
        EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
        ++ok;
      }
    }
    // Measured (60 poses): pinv, DLS, BFGS 60; FABRIK 58; CCD 42 (its tip-to-root sweeps trade
    // position against orientation slowly: 500 sweeps are not enough for the rest).
    const double at_least = kind == SolverKind::kCCD ? 0.65 : kind == SolverKind::kFABRIK ? 0.95 : 1.0;
    EXPECT_GE(ok, at_least * trials) << to_string(kind);
  }
}

// Goal::pose / pose_goals: the two goals of a 6-D pose, the orientation weighted by L^2 (a radian
// counts like one chain length); a pose made by FK is met, position and tool frame.
TEST(PoseGoal, WeightsAndRoundTrip) {
  const glm::dquat tool = glm::angleAxis(0.9, glm::normalize(glm::dvec3(0.2, 1, 0.4)));
  const Chain c = tool_chain(tool);
  const double L = c.total_length();
  const std::array<Goal, 2> explicit_length = Goal::pose(glm::dvec3(1, 2, 3), tool, 2.0, 3, 0.5);
  EXPECT_EQ(explicit_length[0].kind, GoalKind::kPosition);
  EXPECT_EQ(explicit_length[1].kind, GoalKind::kOrientation);
  EXPECT_EQ(explicit_length[0].effector, 3);
  EXPECT_DOUBLE_EQ(explicit_length[0].weight, 0.5);
  EXPECT_DOUBLE_EQ(explicit_length[1].weight, 0.5 * 4.0);
  EXPECT_DOUBLE_EQ(pose_goals(c, glm::dvec3(0), tool)[1].weight, L * L);
  EXPECT_DOUBLE_EQ(pose_goals(c, glm::dvec3(0), tool, 0, 0.5)[1].weight, 0.25 * L * L);
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 2);
  std::mt19937 rng(31);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kJacobianPinv}) {
    int ok = 0;
    for (int t = 0; t < 40; ++t) {
      const Eigen::VectorXd truth = test::random_params(c, rng, 1.2);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      const std::array<Goal, 2> goals = pose_goals(c, fk.tip, effector_orientation(c, fk, 0));
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = solve(kind, c, Span<const Goal>(goals.data(), 2), o, ws, p);
      forward_kinematics(c, p.data(), fk);
      if (r.reason == TerminationReason::kConverged &&
          glm::length(fk.tip - goals[0].target_position) <= o.position_tolerance &&
          angle_between(fk.joint_orientations[3] * tool, goals[1].target_orientation) <= o.orientation_tolerance)
        ++ok;
    }
    EXPECT_EQ(ok, 40) << to_string(kind);
  }
}

// An aim goal in the tool frame: the tool's +Z (a barrel along the rotated frame) takes a direction.
TEST(TipFrame, AimAxisIsInTheToolFrame) {
  const glm::dquat tool = glm::angleAxis(0.7, glm::dvec3(0, 0, 1));
  const Chain c = tool_chain(tool);
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 1);
  const glm::dvec3 direction = glm::normalize(glm::dvec3(0.3, -0.2, 1.0));
  for (SolverKind kind : kGeneralSolvers) {
    const std::vector<Goal> goals = {Goal::aim(glm::dvec3(0, 0, 1), direction)};
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
    Workspace fk(c, 1);
    forward_kinematics(c, p.data(), fk);
    const glm::dvec3 barrel = fk.joint_orientations[3] * (tool * glm::dvec3(0, 0, 1));
    EXPECT_GE(glm::dot(barrel, direction), std::cos(o.orientation_tolerance)) << to_string(kind);
  }
}

// -J^T e must be the exact gradient of the cost 0.5 |e|^2 for aim-at rows (BFGS relies on it):
// compared with central differences of the measured cost, on random poses and points.
TEST(AimAt, JacobianGivesTheExactGradient) {
  const Chain c = tool_chain(glm::angleAxis(0.4, glm::dvec3(0, 1, 0)));
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  Workspace ws(c, 1);
  Eigen::MatrixXd J(3, c.dof_count());
  Eigen::VectorXd e(3);
  for (int t = 0; t < 20; ++t) {
    const Eigen::VectorXd p = test::random_params(c, rng, 1.5);
    const Goal g = Goal::aim_at(glm::dvec3(u(rng), u(rng), u(rng)), glm::dvec3(0, 0, 1), 0, 2.0);
    const std::vector<Goal> goals = {g};
    forward_kinematics(c, p.data(), ws);
    compute_dof_axes(c, p.data(), ws);
    evaluate_goals(c, goals, ws, e);
    compute_jacobian(c, goals, ws, J);
    const Eigen::VectorXd gradient = -J.transpose() * e;
    for (int d = 0; d < c.dof_count(); ++d) {
      const double h = 1e-6;
      Eigen::VectorXd plus = p, minus = p;
      plus[d] += h;
      minus[d] -= h;
      forward_kinematics(c, plus.data(), ws);
      const double f_plus = measure_goals(c, goals, ws).cost;
      forward_kinematics(c, minus.data(), ws);
      const double f_minus = measure_goals(c, goals, ws).cost;
      EXPECT_NEAR(gradient[d], (f_plus - f_minus) / (2 * h), 1e-6 * (1.0 + std::abs(gradient[d])))
          << "trial " << t << " dof " << d;
    }
  }
}

// Turret / look-at: the tool axis points at a point (FK round trip: axis . normalize(point - tip)
// >= cos(tol)), from rest, for every solver; points 1.5-4 from the root in every direction.
TEST(AimAt, PointsTheAxisAtThePointEverySolver) {
  const Chain c = tool_chain(glm::angleAxis(0.3, glm::dvec3(1, 0, 0)));
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 1);
  for (SolverKind kind : kGeneralSolvers) {
    std::mt19937 rng(23);
    std::uniform_real_distribution<double> u(-1.0, 1.0), r(1.5, 4.0);
    int ok = 0;
    const int trials = 50;
    for (int t = 0; t < trials; ++t) {
      glm::dvec3 dir(u(rng), u(rng), u(rng));
      if (glm::length(dir) < 1e-3) dir = glm::dvec3(1, 0, 0);
      const Goal g = Goal::aim_at(glm::normalize(dir) * r(rng), glm::dvec3(0, 1, 0));
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult res = test::run(kind, c, {g}, o, ws, p);
      ASSERT_TRUE(res.usable());
      const double angle = aim_at_angle(c, p, g);
      EXPECT_NEAR(res.final_orientation_error, angle, 1e-7);
      if (angle <= o.orientation_tolerance) {
        EXPECT_EQ(res.reason, TerminationReason::kConverged);
        ++ok;
      }
    }
    EXPECT_EQ(ok, trials) << to_string(kind);
  }
}

// A turret that must also keep its muzzle at a point: tip position + aim-at (consistent, made by
// FK), for the Jacobian solvers and BFGS.
TEST(AimAt, WithAPositionGoal) {
  const Chain c = tool_chain(glm::dquat(1, 0, 0, 0));
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 2);
  for (SolverKind kind : {SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kCCD}) {
    std::mt19937 rng(29);
    int ok = 0;
    const int trials = 40;
    for (int t = 0; t < trials; ++t) {
      const Eigen::VectorXd truth = test::random_params(c, rng, 1.2);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      const glm::dvec3 point = fk.tip + 2.0 * (fk.joint_orientations[3] * glm::dvec3(0, 0, 1));
      const std::vector<Goal> goals = {Goal::position(fk.tip), Goal::aim_at(point, glm::dvec3(0, 0, 1))};
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      if (r.reason == TerminationReason::kConverged) {
        EXPECT_LE(glm::length(test::tip_of(c, p) - fk.tip), o.position_tolerance);
        EXPECT_LE(aim_at_angle(c, p, goals[1]), o.orientation_tolerance);
        ++ok;
      }
    }
    // Measured (40 poses): pinv, DLS, BFGS 40; CCD 38.
    EXPECT_GE(ok, kind == SolverKind::kCCD ? 0.9 * trials : trials) << to_string(kind);
  }
}

TEST(AimAt, InvalidInputNamesTheField) {
  const Chain c = tool_chain(glm::dquat(1, 0, 0, 0));
  Workspace ws(c, 1);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolverOptions o;
  SolveResult r = test::run(SolverKind::kDLS, c, {Goal::aim_at(glm::dvec3(NAN, 0, 0), glm::dvec3(0, 1, 0))}, o, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("target_position"), std::string::npos) << r.message.c_str();
  r = test::run(SolverKind::kDLS, c, {Goal::aim_at(glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 0))}, o, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("aim_axis"), std::string::npos) << r.message.c_str();
}

// The effector on the point: no direction to aim along, the goal is met (error 0), no NaN.
TEST(AimAt, EffectorOnThePointIsMet) {
  const Chain c = tool_chain(glm::dquat(1, 0, 0, 0));
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 1);
  for (SolverKind kind : kGeneralSolvers) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(kind, c, {Goal::aim_at(c.rest_tip(), glm::dvec3(1, 0, 0))}, o, ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
    EXPECT_TRUE(p.allFinite());
  }
}

// FABRIK pursues tip-frame goals but rejects them on an intermediate effector, naming the goal.
TEST(FabrikOrientation, RejectsOrientationOnAnIntermediateEffector) {
  const Chain c = test::make_ball_chain(4);
  Workspace ws(c, 2);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(1, 2, 0)),
                                   Goal::orientation(glm::angleAxis(0.3, glm::dvec3(1, 0, 0)), 2)};
  const SolveResult r = test::run(SolverKind::kFABRIK, c, goals, SolverOptions(), ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("goal 1"), std::string::npos) << r.message.c_str();
  EXPECT_EQ(p, Eigen::VectorXd::Zero(c.dof_count()));
}

// FABRIK and CCD on orientation-only goals of the tip (no position goal): met, not ignored.
TEST(FabrikOrientation, OrientationOnlyGoalIsPursued) {
  const Chain c = test::make_ball_chain(4, 0.5);
  const SolverOptions o = goal_options(c);
  Workspace ws(c, 1);
  for (SolverKind kind : {SolverKind::kFABRIK, SolverKind::kCCD}) {
    std::mt19937 rng(41);
    int ok = 0;
    for (int t = 0; t < 30; ++t) {
      const Eigen::VectorXd truth = test::random_params(c, rng, 1.5);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      const glm::dquat target = fk.joint_orientations[3];
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, {Goal::orientation(target)}, o, ws, p);
      forward_kinematics(c, p.data(), fk);
      if (angle_between(fk.joint_orientations[3], target) <= o.orientation_tolerance) {
        EXPECT_EQ(r.reason, TerminationReason::kConverged);
        ++ok;
      }
    }
    EXPECT_EQ(ok, 30) << to_string(kind);
  }
}

TEST(AimAt, SolveAllocatesNothing) {
  const Chain c = tool_chain(glm::angleAxis(0.3, glm::dvec3(1, 0, 0)));
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.5, 1.0, 0.3)),
                                   Goal::aim_at(glm::dvec3(2, 1, 1), glm::dvec3(0, 0, 1))};
  for (SolverKind kind : kGeneralSolvers) test::expect_solves_allocate_nothing(kind, c, goals, goal_options(c));
}

}  // namespace
}  // namespace ikchain
