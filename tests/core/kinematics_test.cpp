#include "core/kinematics_internal.hpp"
#include "ikchain/so3.hpp"

#include <random>

#include "test_util.hpp"

namespace ikchain {
namespace {

Chain mixed_chain() {
  ChainBuilder b;
  JointDesc ball;
  ball.offset_translation = glm::dvec3(0.1, 0.2, 0.0);
  ball.rest_rotation = glm::angleAxis(0.3, glm::normalize(glm::dvec3(1, 1, 0)));
  b.add_joint(ball);
  JointDesc hinge;
  hinge.type = JointType::kHinge;
  hinge.offset_translation = glm::dvec3(0, 1.2, 0);
  hinge.axis = glm::dvec3(1, 0, 0);
  b.add_joint(hinge);
  JointDesc ball2 = ball;
  ball2.offset_translation = glm::dvec3(0.0, 0.8, 0.1);
  b.add_joint(ball2);
  b.set_tip_offset(glm::dvec3(0, 0.5, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

TEST(Kinematics, RestPoseOfStraightChainIsAlongY) {
  const Chain c = test::make_ball_chain(3, 0.5);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const glm::dvec3 tip = test::tip_of(c, p);
  EXPECT_NEAR(tip.x, 0.0, 1e-15);
  EXPECT_NEAR(tip.y, 1.5, 1e-15);
  EXPECT_NEAR(tip.z, 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(c.total_length(), 1.5);
  EXPECT_EQ(c.dof_count(), 9);
}

// The rest-pose frames the chain computes at build are the forward kinematics of params = 0.
TEST(Kinematics, ChainRestFramesAreForwardKinematicsAtZero) {
  for (const Chain& c : {mixed_chain(), test::make_hinge_chain(7), test::make_ball_chain(4)}) {
    Workspace ws(c, 1);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(c.dof_count());
    forward_kinematics(c, zero.data(), ws);
    compute_dof_axes(c, zero.data(), ws);
    ASSERT_EQ(c.rest_joint_origins().size(), static_cast<size_t>(c.joint_count()));
    ASSERT_EQ(c.rest_dof_axes().size(), static_cast<size_t>(c.dof_count()));
    for (int i = 0; i < c.joint_count(); ++i) EXPECT_EQ(c.rest_joint_origins()[i], ws.joint_origins[i]);
    for (int d = 0; d < c.dof_count(); ++d) EXPECT_EQ(c.rest_dof_axes()[d], ws.dof_axes[d]);
    EXPECT_EQ(c.rest_tip(), ws.tip);
  }
}

TEST(Kinematics, HingeQuarterTurnMovesTipExactly) {
  const Chain c = test::make_hinge_chain(1, 1.0);  // one hinge about z, tip at (0,1,0)
  Eigen::VectorXd p(1);
  p[0] = so3::kPi / 2;
  const glm::dvec3 tip = test::tip_of(c, p);
  EXPECT_NEAR(tip.x, -1.0, 1e-15);
  EXPECT_NEAR(tip.y, 0.0, 1e-15);
}

// The analytic Jacobian matches central finite differences for every goal kind and effector.
TEST(Kinematics, JacobianMatchesFiniteDifferences) {
  const Chain c = mixed_chain();
  std::mt19937 rng(7);
  std::vector<Goal> goals = {
      Goal::position(glm::dvec3(0.3, 1.0, 0.2)),
      Goal::position(glm::dvec3(0.0, 1.0, 0.0), 2, 0.5),
      Goal::orientation(glm::angleAxis(0.7, glm::dvec3(0, 0, 1))),
      Goal::aim(glm::dvec3(0, 1, 0), glm::dvec3(1, 0.2, 0), 2),
  };
  Workspace ws(c, 4);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd p = test::random_params(c, rng, 2.5);
    forward_kinematics(c, p.data(), ws);
    compute_dof_axes(c, p.data(), ws);
    Eigen::MatrixXd J(12, c.dof_count());
    compute_jacobian(c, goals, ws, J);
    const double h = 1e-6;
    for (int d = 0; d < c.dof_count(); ++d) {
      Eigen::VectorXd plus = p, minus = p;
      plus[d] += h;
      minus[d] -= h;
      Eigen::VectorXd ep(12), em(12);
      forward_kinematics(c, plus.data(), ws);
      evaluate_goals(c, goals, ws, ep);
      forward_kinematics(c, minus.data(), ws);
      evaluate_goals(c, goals, ws, em);
      // residual = desired - current, so d(current) = -d(residual).
      const Eigen::VectorXd fd = -(ep - em) / (2 * h);
      // Orientation rows: the log map's derivative equals the angular velocity only near zero
      // error; compare position rows exactly, the rest through their action below.
      for (int r = 0; r < 6; ++r) EXPECT_NEAR(J(r, d), fd[r], 1e-6) << "row " << r << " dof " << d;
    }
  }
}

// Orientation and aim rows are exact at zero error: there d(log) = angular velocity.
TEST(Kinematics, OrientationJacobianExactAtGoal) {
  const Chain c = mixed_chain();
  std::mt19937 rng(11);
  Workspace ws(c, 2);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::VectorXd p = test::random_params(c, rng, 2.0);
    forward_kinematics(c, p.data(), ws);
    std::vector<Goal> goals = {
        Goal::orientation(effector_orientation(c, ws, 0)),
        Goal::aim(glm::dvec3(0, 0, 1), effector_orientation(c, ws, 2) * glm::dvec3(0, 0, 1), 2)};
    compute_dof_axes(c, p.data(), ws);
    Eigen::MatrixXd J(6, c.dof_count());
    compute_jacobian(c, goals, ws, J);
    const double h = 1e-6;
    for (int d = 0; d < c.dof_count(); ++d) {
      Eigen::VectorXd plus = p, minus = p;
      plus[d] += h;
      minus[d] -= h;
      Eigen::VectorXd ep(6), em(6);
      forward_kinematics(c, plus.data(), ws);
      evaluate_goals(c, goals, ws, ep);
      forward_kinematics(c, minus.data(), ws);
      evaluate_goals(c, goals, ws, em);
      const Eigen::VectorXd fd = -(ep - em) / (2 * h);
      for (int r = 0; r < 6; ++r) EXPECT_NEAR(J(r, d), fd[r], 1e-6) << "row " << r << " dof " << d;
    }
  }
}

TEST(Kinematics, ApplyStepCapsRotationAndWrapsBallAngle) {
  const Chain c = test::make_ball_chain(1);
  double params[3] = {3.0, 0.0, 0.0};
  const double step[3] = {0.5, 0.0, 0.0};
  apply_step(c, step, 0.0, params);
  // 3.5 rad about x is the same rotation as 3.5 - 2*pi.
  EXPECT_NEAR(params[0], 3.5 - 2 * so3::kPi, 1e-12);
  double capped[3] = {0.0, 0.0, 0.0};
  const double big[3] = {0.0, 3.0, 4.0};
  apply_step(c, big, 0.1, capped);
  EXPECT_NEAR(glm::length(glm::dvec3(capped[0], capped[1], capped[2])), 0.1, 1e-15);
}

TEST(Limits, HingeClampAndBallConeTwistProjection) {
  ChainBuilder b;
  JointDesc h;
  h.type = JointType::kHinge;
  h.limits.has_hinge_limit = true;
  h.limits.hinge_min = -0.5;
  h.limits.hinge_max = 0.25;
  b.add_joint(h);
  JointDesc ball;
  ball.offset_translation = glm::dvec3(0, 1, 0);
  ball.limits.has_cone_limit = true;
  ball.limits.cone_angle = 0.4;
  ball.limits.has_twist_limit = true;
  ball.limits.twist_min = -0.1;
  ball.limits.twist_max = 0.2;
  b.add_joint(ball);
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  ASSERT_TRUE(b.build(c).ok());
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::VectorXd p(4);
    std::uniform_real_distribution<double> u(-2.5, 2.5);
    for (int i = 0; i < 4; ++i) p[i] = u(rng);
    project_to_limits(c, p.data());
    EXPECT_TRUE(within_limits(c, p.data(), 1e-9)) << p.transpose();
    EXPECT_GE(p[0], -0.5);
    EXPECT_LE(p[0], 0.25);
    // Projecting a feasible pose changes nothing.
    Eigen::VectorXd q = p;
    project_to_limits(c, q.data());
    EXPECT_LT((q - p).norm(), 1e-9);
  }
}

TEST(ChainBuilder, RejectsBadInputNamingTheField) {
  Chain c;
  EXPECT_NE(std::string(ChainBuilder().build(c).message.c_str()).find("0 joints"), std::string::npos);
  EXPECT_FALSE(c.valid());

  ChainBuilder b;
  JointDesc h;
  h.type = JointType::kHinge;
  h.limits.has_hinge_limit = true;
  h.limits.hinge_min = 1.5;
  h.limits.hinge_max = 0.5;
  b.add_joint(h).set_tip_offset(glm::dvec3(0, 1, 0));
  EXPECT_NE(std::string(b.build(c).message.c_str()).find("hinge_min (1.5) > hinge_max (0.5)"), std::string::npos);

  ChainBuilder z;
  z.add_joint(JointDesc()).add_joint(JointDesc());
  EXPECT_NE(std::string(z.build(c).message.c_str()).find("zero-length chain"), std::string::npos);

  ChainBuilder nan;
  JointDesc j;
  j.offset_translation.x = std::nan("");
  nan.add_joint(j).set_tip_offset(glm::dvec3(0, 1, 0));
  EXPECT_NE(std::string(nan.build(c).message.c_str()).find("offset_translation"), std::string::npos);
}

// The error is data: the joint and field as values, and the reason without the joint, so a caller
// that names joints by bone (the Godot layer) maps them without parsing the message.
TEST(ChainBuilder, BuildErrorCarriesJointFieldAndReason) {
  Chain c;
  ChainBuilder b;
  JointDesc ball;
  JointDesc h;
  h.type = JointType::kHinge;
  h.offset_translation = glm::dvec3(0, 1, 0);
  h.limits.has_hinge_limit = true;
  h.limits.hinge_min = 1.5;
  h.limits.hinge_max = 0.5;
  b.add_joint(ball).add_joint(h).set_tip_offset(glm::dvec3(0, 1, 0));
  const BuildError e = b.build(c);
  EXPECT_FALSE(e.ok());
  EXPECT_EQ(e.joint, 1);
  EXPECT_STREQ(e.field, "limits.hinge_min");
  EXPECT_STREQ(e.message.c_str(), "joint 1: hinge_min (1.5) > hinge_max (0.5)");
  EXPECT_STREQ(e.reason.c_str(), "hinge_min (1.5) > hinge_max (0.5)");
  EXPECT_FALSE(c.valid());

  const BuildError empty = ChainBuilder().build(c);
  EXPECT_EQ(empty.joint, -1);
  EXPECT_STREQ(empty.field, "joints");
  EXPECT_STREQ(empty.message.c_str(), empty.reason.c_str());

  ChainBuilder tip;
  tip.add_joint(ball).set_tip_offset(glm::dvec3(std::nan(""), 0, 0));
  const BuildError t = tip.build(c);
  EXPECT_EQ(t.joint, -1);
  EXPECT_STREQ(t.field, "tip_offset");

  ChainBuilder ok;
  ok.add_joint(ball).set_tip_offset(glm::dvec3(0, 1, 0));
  const BuildError fine = ok.build(c);
  EXPECT_TRUE(fine.ok());
  EXPECT_EQ(fine.joint, -1);
  EXPECT_TRUE(c.valid());
}

}  // namespace
}  // namespace ikchain

#include "alloc_counter.hpp"

namespace ikchain {
namespace {

// The counter itself must see Eigen's dynamic allocations, or the no-allocation tests prove nothing.
TEST(AllocCounter, SeesEigenAndStdAllocations) {
  const std::size_t before = test::allocation_count();
  Eigen::VectorXd v(100);
  v.setZero();
  std::vector<int> w(10);
  EXPECT_GE(test::allocation_count() - before, 2u);
  EXPECT_EQ(v.sum() + w.size(), 10.0);
}

}  // namespace
}  // namespace ikchain
