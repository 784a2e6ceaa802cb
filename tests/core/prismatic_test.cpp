// Prismatic (sliding) joints: forward kinematics, the Jacobian against finite differences, round
// trips with the Jacobian solvers and BFGS within the slide range, and the rules (a range is
// required; the geometric solvers reject such chains with a message).
#include <random>
#include <string>

#include "solver_test_util.hpp"
#include "telescope_arm.hpp"

namespace ikchain {
namespace {

using test::telescope_arm;

Eigen::VectorXd random_in_range(const Chain& c, std::mt19937& rng) {
  Eigen::VectorXd p = test::random_params(c, rng, 1.2);
  const int o = c.dof_offset(1);
  p[o] = std::uniform_real_distribution<double>(0.0, 0.8)(rng);
  return p;
}

TEST(Prismatic, SlideMovesTheLaterJointsAlongItsAxis) {
  const Chain c = telescope_arm();
  EXPECT_EQ(c.first_prismatic(), 1);
  EXPECT_EQ(c.dof_count(), 3 + 1 + 1 + 3);
  EXPECT_NEAR(c.bone_length(1), 0.5 + 0.8, 1e-15);  // the longest the upper arm can be
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  Workspace a(c, 1), b(c, 1);
  forward_kinematics(c, p.data(), a);
  p[c.dof_offset(1)] = 0.3;
  forward_kinematics(c, p.data(), b);
  EXPECT_LT(glm::length(b.joint_origins[1] - a.joint_origins[1]), 1e-15);  // the slide's own origin stays
  EXPECT_LT(glm::length(b.joint_origins[2] - a.joint_origins[2] - glm::dvec3(0, 0.3, 0)), 1e-15);
  EXPECT_LT(glm::length(b.tip - a.tip - glm::dvec3(0, 0.3, 0)), 1e-15);
}

// d current / d params by central differences of FK, for a position and an aim-at goal.
TEST(Prismatic, JacobianMatchesFiniteDifferences) {
  const Chain c = telescope_arm();
  std::mt19937 rng(5);
  Workspace ws(c, 2);
  for (int t = 0; t < 10; ++t) {
    const Eigen::VectorXd p = random_in_range(c, rng);
    const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.4, 1.0, 0.2)),
                                     Goal::aim_at(glm::dvec3(2, 1, -1), glm::dvec3(0, 1, 0))};
    Eigen::MatrixXd J(6, c.dof_count());
    Eigen::VectorXd e(6), e_plus(6), e_minus(6);
    forward_kinematics(c, p.data(), ws);
    compute_dof_axes(c, p.data(), ws);
    compute_jacobian(c, goals, ws, J);
    const int o = c.dof_offset(1);  // the slide's column
    const double h = 1e-6;
    Eigen::VectorXd plus = p, minus = p;
    plus[o] += h;
    minus[o] -= h;
    forward_kinematics(c, plus.data(), ws);
    evaluate_goals(c, goals, ws, e_plus);
    forward_kinematics(c, minus.data(), ws);
    evaluate_goals(c, goals, ws, e_minus);
    // e = desired - current, so d current = -(d e).
    const Eigen::VectorXd numeric = -(e_plus - e_minus) / (2 * h);
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(J(r, o), numeric[r], 1e-7) << "position row " << r;
    // Aim-at rows: the gradient of the cost is exact (as for the rotational columns).
    forward_kinematics(c, p.data(), ws);
    evaluate_goals(c, goals, ws, e);
    const double grad = -(J.col(o).tail(3).dot(e.tail(3)));
    forward_kinematics(c, plus.data(), ws);
    const double f_plus = 0.5 * [&] { Eigen::VectorXd x(6); evaluate_goals(c, goals, ws, x); return x.tail(3).squaredNorm(); }();
    forward_kinematics(c, minus.data(), ws);
    const double f_minus = 0.5 * [&] { Eigen::VectorXd x(6); evaluate_goals(c, goals, ws, x); return x.tail(3).squaredNorm(); }();
    EXPECT_NEAR(grad, (f_plus - f_minus) / (2 * h), 1e-6);
  }
}

// Positions and full poses made by FK of in-range poses, solved from rest; the slide stays in range.
TEST(Prismatic, RoundTripsWithinTheSlideRange) {
  const Chain c = telescope_arm();
  Workspace ws(c, 2);
  SolverOptions o;
  o.position_tolerance = 1e-5 * c.total_length();
  o.orientation_tolerance = 1e-5;
  o.max_iterations = 300;
  o.warm_start = false;
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS}) {
    std::mt19937 rng(19);
    int position_ok = 0, pose_ok = 0;
    for (int t = 0; t < 50; ++t) {
      const Eigen::VectorXd truth = random_in_range(c, rng);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      SolveResult r = test::run(kind, c, {Goal::position(fk.tip)}, o, ws, p);
      ASSERT_TRUE(within_limits(c, p.data(), 1e-12)) << to_string(kind);
      position_ok += r.reason == TerminationReason::kConverged &&
                     glm::length(test::tip_of(c, p) - fk.tip) <= o.position_tolerance;
      const std::array<Goal, 2> pose = pose_goals(c, fk.tip, effector_orientation(c, fk, 0));
      p.setZero();
      r = solve(kind, c, Span<const Goal>(pose.data(), 2), o, ws, p);
      ASSERT_TRUE(within_limits(c, p.data(), 1e-12)) << to_string(kind);
      pose_ok += r.reason == TerminationReason::kConverged;
    }
    EXPECT_EQ(position_ok, 50) << to_string(kind);
    EXPECT_GE(pose_ok, 48) << to_string(kind);
  }
}

TEST(Prismatic, NeedsASlideRange) {
  ChainBuilder b;
  JointDesc slide;
  slide.type = JointType::kPrismatic;
  slide.axis = glm::dvec3(0, 1, 0);
  b.add_joint(slide).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_NE(std::string(m.c_str()).find("prismatic"), std::string::npos) << m.c_str();
  EXPECT_FALSE(c.valid());
  // The range is the slide's own (metres), not the hinge's: a hinge range does not count for it,
  // and the error names the field to set.
  auto build_with = [&](const JointLimits& limits) {
    slide.limits = limits;
    b.clear();
    b.add_joint(slide).set_tip_offset(glm::dvec3(0, 1, 0));
    return b.build(c);
  };
  JointLimits hinge_range;
  hinge_range.has_hinge_limit = true;
  hinge_range.hinge_min = 0.0;
  hinge_range.hinge_max = 0.5;
  const BuildError e = build_with(hinge_range);
  EXPECT_STREQ(e.field, "limits.slide_min") << e.message.c_str();
  EXPECT_FALSE(c.valid());
  JointLimits slide_range;
  slide_range.has_slide_limit = true;
  slide_range.slide_min = 0.0;
  slide_range.slide_max = 0.5;
  ASSERT_TRUE(build_with(slide_range).ok());
  EXPECT_DOUBLE_EQ(c.bone_length(0), 1.5);  // the offset to the tip plus the longest slide
}

TEST(Prismatic, GeometricSolversRejectIt) {
  const Chain c = telescope_arm();
  Workspace ws(c, 1);
  for (SolverKind kind : {SolverKind::kCCD, SolverKind::kFABRIK, SolverKind::kTwoBone}) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(kind, c, {Goal::position(glm::dvec3(0.3, 1.5, 0.2))}, SolverOptions(), ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kInvalidInput) << to_string(kind);
    EXPECT_NE(std::string(r.message.c_str()).find("prismatic"), std::string::npos) << r.message.c_str();
    EXPECT_EQ(p, Eigen::VectorXd::Zero(c.dof_count()));
  }
}

TEST(Prismatic, SolveAllocatesNothing) {
  const Chain c = telescope_arm();
  SolverOptions o;
  o.max_restarts = 3;
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS})
    test::expect_solves_allocate_nothing(kind, c, {Goal::position(glm::dvec3(0.3, 1.5, 0.2))}, o);
}

}  // namespace
}  // namespace ikchain
