// tools/urdf_chain.py and bench/robot_chain.hpp on tests/robots/fixture.urdf (its chain file is made
// by the build): the parsed joints, our forward kinematics against KDL's on the URDF as written,
// the prismatic joint, and a full-pose solve checked by KDL's FK.
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/jntarray.hpp>

#include "robot_chain.hpp"

namespace {

robots::RobotDescription load_fixture() {
  robots::RobotDescription robot;
  const std::string error = robots::read_robot(IKCHAIN_FIXTURE_CHAIN, robot);
  EXPECT_EQ(error, "");
  return robot;
}

struct Pose {
  glm::dvec3 position;
  glm::dquat orientation;
};

Pose kdl_tip(const KDL::Chain& chain, const Eigen::VectorXd& q) {
  KDL::ChainFkSolverPos_recursive fk(chain);
  KDL::JntArray kq(chain.getNrOfJoints());
  for (int i = 0; i < q.size(); ++i) kq(i) = q[i];
  KDL::Frame f;
  EXPECT_GE(fk.JntToCart(kq, f), 0);
  Pose p;
  robots::from_kdl(f, p.position, p.orientation);
  return p;
}

Pose our_tip(const ikchain::Chain& chain, const Eigen::VectorXd& q) {
  ikchain::Workspace ws(chain, 1);
  ikchain::forward_kinematics(chain, q.data(), ws);
  return {ws.tip, ikchain::effector_orientation(chain, ws, 0)};
}

TEST(RobotChain, FixtureJointsAsInTheUrdf) {
  const robots::RobotDescription robot = load_fixture();
  EXPECT_EQ(robot.name, "fixture");
  // Every URDF joint on base -> tool, the branch (side_joint) left out.
  ASSERT_EQ(robot.segments.size(), 7u);
  const char* path[] = {"mount_joint", "shoulder", "slide", "offset", "elbow", "wrist", "tool_joint"};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(robot.segments[i].name, path[i]);
  ASSERT_EQ(robot.joints.size(), 4u);
  EXPECT_EQ(robot.joints[0].type, "revolute");
  EXPECT_EQ(robot.joints[1].type, "prismatic");
  EXPECT_EQ(robot.joints[2].type, "continuous");
  EXPECT_FALSE(robot.joints[2].limited());
  EXPECT_DOUBLE_EQ(robot.joints[1].lower, 0.0);
  EXPECT_DOUBLE_EQ(robot.joints[1].upper, 0.3);
  EXPECT_DOUBLE_EQ(robot.joints[3].lower, -1.0);
  EXPECT_DOUBLE_EQ(robot.joints[3].upper, 1.5);
  // Axes normalised: (2, 0, 0) -> x, (0, 1, 1) -> (0, 1, 1) / sqrt 2.
  EXPECT_DOUBLE_EQ(robot.joints[1].axis.x, 1.0);
  EXPECT_NEAR(robot.joints[2].axis.y, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(robot.joints[2].axis.z, std::sqrt(0.5), 1e-15);
  // The fixed mount (z 0.1, yaw 0.5) folded into the shoulder: its origin (0.01, 0, 0.2) turned by
  // the yaw, plus the mount's 0.1 up.
  EXPECT_NEAR(robot.joints[0].origin_translation.x, 0.01 * std::cos(0.5), 1e-15);
  EXPECT_NEAR(robot.joints[0].origin_translation.y, 0.01 * std::sin(0.5), 1e-15);
  EXPECT_NEAR(robot.joints[0].origin_translation.z, 0.3, 1e-15);
  // The tool frame is tool_joint alone (nothing fixed between the wrist and it).
  EXPECT_DOUBLE_EQ(robot.tool_translation.x, 0.05);
  EXPECT_DOUBLE_EQ(robot.tool_translation.y, 0.02);
  EXPECT_DOUBLE_EQ(robot.tool_translation.z, 0.1);

  ikchain::Chain chain;
  const ikchain::Message m = robots::build_ikchain(robot, chain);
  ASSERT_TRUE(m.empty()) << m.c_str();
  EXPECT_EQ(chain.joint_count(), 4);
  EXPECT_EQ(chain.joint_type(1), ikchain::JointType::kPrismatic);
  EXPECT_TRUE(chain.limits(0).has_hinge_limit);
  EXPECT_FALSE(chain.limits(2).has_hinge_limit);
  EXPECT_EQ(robots::build_kdl(robot).getNrOfJoints(), 4u);
  EXPECT_EQ(robots::build_kdl(robot).getNrOfSegments(), 7u);
}

// Our FK of the folded chain equals KDL's FK of the URDF joints as written, at the zero pose and
// at random poses within the limits (the continuous joint over [-pi, pi]).
TEST(RobotChain, ForwardKinematicsMatchesKdl) {
  const robots::RobotDescription robot = load_fixture();
  ikchain::Chain chain;
  ASSERT_TRUE(robots::build_ikchain(robot, chain).empty());
  const KDL::Chain kdl = robots::build_kdl(robot);
  std::mt19937 rng(11);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(4);
  for (int t = 0; t < 200; ++t) {
    if (t > 0) robots::random_in_limits(robot, rng, q);
    const Pose ours = our_tip(chain, q), theirs = kdl_tip(kdl, q);
    EXPECT_LT(glm::length(ours.position - theirs.position), 1e-12) << "pose " << t;
    EXPECT_LT(robots::rotation_distance(ours.orientation, theirs.orientation), 1e-12) << "pose " << t;
  }
}

// The prismatic joint translates everything after it without turning it: the tip moves by exactly
// the slide and keeps its orientation (by KDL's FK too).
TEST(RobotChain, PrismaticJointSlidesTheTip) {
  const robots::RobotDescription robot = load_fixture();
  ikchain::Chain chain;
  ASSERT_TRUE(robots::build_ikchain(robot, chain).empty());
  const KDL::Chain kdl = robots::build_kdl(robot);
  Eigen::VectorXd q(4);
  q << 0.4, 0.05, -1.2, 0.3;
  Eigen::VectorXd slid = q;
  slid[1] += 0.2;
  const Pose a = our_tip(chain, q), b = our_tip(chain, slid);
  EXPECT_NEAR(glm::length(b.position - a.position), 0.2, 1e-14);
  EXPECT_LT(robots::rotation_distance(a.orientation, b.orientation), 1e-14);
  const Pose ka = kdl_tip(kdl, q), kb = kdl_tip(kdl, slid);
  EXPECT_LT(glm::length((b.position - a.position) - (kb.position - ka.position)), 1e-14);
}

// A full-pose goal (tip position and the rotated tool frame's orientation) made from a random
// in-limit pose is met by DLS with restarts, as KDL's FK of the returned joints says, within limits.
TEST(RobotChain, FullPoseSolveCheckedByKdl) {
  const robots::RobotDescription robot = load_fixture();
  ikchain::Chain chain;
  ASSERT_TRUE(robots::build_ikchain(robot, chain).empty());
  const KDL::Chain kdl = robots::build_kdl(robot);
  ikchain::SolverOptions o;
  o.max_restarts = 20;
  o.restart_seed = 3;
  ikchain::Workspace ws(chain, 2);
  std::mt19937 rng(5);
  Eigen::VectorXd truth(4), q(4);
  for (int t = 0; t < 20; ++t) {
    robots::random_in_limits(robot, rng, truth);
    const Pose goal = kdl_tip(kdl, truth);
    const auto goals = ikchain::pose_goals(chain, goal.position, goal.orientation);
    q = robots::middle_of_limits(robot);
    const ikchain::SolveResult r =
        ikchain::solve(ikchain::SolverKind::kDLS, chain, ikchain::Span<const ikchain::Goal>(goals.data(), 2), o, ws, q);
    EXPECT_EQ(r.reason, ikchain::TerminationReason::kConverged) << "goal " << t;
    const Pose reached = kdl_tip(kdl, q);
    EXPECT_LE(glm::length(reached.position - goal.position), o.position_tolerance) << "goal " << t;
    EXPECT_LE(robots::rotation_distance(reached.orientation, goal.orientation), o.orientation_tolerance) << "goal " << t;
    EXPECT_TRUE(robots::within_urdf_limits(robot, q, 1e-9)) << "goal " << t;
  }
}

// A malformed chain file is refused with its line named.
TEST(RobotChain, MalformedFileNamesTheLine) {
  const std::string path = ::testing::TempDir() + "robot_chain_bad.chain";
  FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("robot bad\njoint j1 revolute 0 0 0 1 0 0 0 0 0 1 -1\ntool 0 0 0 1 0 0 0\n", f);
  std::fclose(f);
  robots::RobotDescription robot;
  EXPECT_EQ(robots::read_robot(path, robot), path + ":2: joint: expected name type and 12 numbers");
  std::remove(path.c_str());
}

}  // namespace
