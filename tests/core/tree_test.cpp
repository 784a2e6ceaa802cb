// The tree model: build validation by name, forward kinematics against 4x4 matrices, the Jacobian
// against finite differences, and a chain as the tree without branches.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <random>
#include <string>

#include "core/kinematics_internal.hpp"
#include "ikchain/solve.hpp"
#include "core/solvers/tree_solvers.hpp"
#include "ikchain/tree.hpp"
#include "test_util.hpp"
#include "tree_test_util.hpp"

namespace ikchain {
namespace {

using test::Humanoid;

TEST(Tree, HumanoidBuildsWithSupportsRootFirst) {
  Tree t;
  ASSERT_TRUE(test::humanoid_builder(true).build(t).ok());
  EXPECT_EQ(t.joint_count(), Humanoid::kJointCount);
  EXPECT_EQ(t.dof_count(), 3 + 13 * 3 + 4);  // root translation, 13 balls, 4 hinges
  EXPECT_EQ(t.dof_offset(0), 3);
}

TEST(Tree, SupportsAreTheEffectorsJointAndItsAncestors) {
  const Tree t = test::make_humanoid(false);
  const int* s = t.support_list(Humanoid::kLHand);
  const std::vector<int> expected = {Humanoid::kHips, Humanoid::kSpine, Humanoid::kChest, Humanoid::kLShoulder,
                                     Humanoid::kLElbow, Humanoid::kLWrist};
  ASSERT_EQ(t.support_count(Humanoid::kLHand), static_cast<int>(expected.size()));
  for (size_t k = 0; k < expected.size(); ++k) EXPECT_EQ(s[k], expected[k]);
  EXPECT_TRUE(t.supports(Humanoid::kLFoot, Humanoid::kLKnee));
  EXPECT_FALSE(t.supports(Humanoid::kLFoot, Humanoid::kRKnee));
  EXPECT_FALSE(t.supports(Humanoid::kLHand, Humanoid::kNeck));
  // Reach from the root joint: spine + chest + shoulder offset + upper arm + forearm + hand.
  EXPECT_NEAR(t.reach_from_root(Humanoid::kLHand), 0.1 + 0.2 + std::sqrt(0.18 * 0.18 + 0.04) + 0.28 + 0.25 + 0.08,
              1e-12);
}

TEST(Tree, ForwardKinematicsMatchesFourByFourMatrices) {
  std::mt19937 rng(7);
  for (bool floating : {false, true}) {
    const Tree t = test::make_humanoid(floating);
    TreeWorkspace ws(t, 8);
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::VectorXd q = test::random_tree_params(t, rng, 2.5, 0.5);
      tree_forward_kinematics(t, q.data(), ws);
      const std::vector<glm::dmat4> f = test::frames_by_matrices(t, q);
      for (int j = 0; j < t.joint_count(); ++j) {
        const glm::dvec3 origin(f[j][3]);
        EXPECT_NEAR(glm::length(origin - ws.joint_origins[j]), 0.0, 1e-12) << "joint " << j;
        const glm::dmat3 r = glm::mat3_cast(ws.joint_orientations[j]);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(glm::length(glm::dvec3(f[j][c]) - r[c]), 0.0, 1e-12) << "joint " << j;
      }
      for (int e = 0; e < t.effector_count(); ++e)
        EXPECT_NEAR(glm::length(tree_effector_position(t, ws, e) - test::effector_by_matrices(t, q, e)), 0.0, 1e-12);
    }
  }
}

TEST(Tree, PrismaticJointShiftsItsChildrenAndEffectors) {
  TreeBuilder b;
  TreeJointDesc base = test::ball(-1, {0, 0, 0}, 0);
  b.add_joint(base);
  TreeJointDesc slide;
  slide.parent = 0;
  slide.type = JointType::kPrismatic;
  slide.offset_in_parent = {0, 1, 0};
  slide.axis = {0, 2, 0};  // normalised by the build
  slide.limits.has_slide_limit = true;
  slide.limits.slide_min = 0.0;
  slide.limits.slide_max = 0.5;
  b.add_joint(slide);
  b.add_joint(test::hinge(1, {0, 1, 0}, {0, 0, 1}, -90, 90));
  b.add_effector({2, {0, 1, 0}, {1, 0, 0, 0}});
  Tree t;
  ASSERT_TRUE(b.build(t).ok());
  EXPECT_NEAR(t.reach_from_root(0), 1 + 0.5 + 1 + 1, 1e-12);
  TreeWorkspace ws(t, 1);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(t.dof_count());
  q[3] = 0.25;
  q[4] = test::kDeg * 90.0;
  tree_forward_kinematics(t, q.data(), ws);
  const glm::dvec3 p = tree_effector_position(t, ws, 0);
  EXPECT_NEAR(glm::length(p - glm::dvec3(-1, 2.25, 0)), 0.0, 1e-12);
  EXPECT_NEAR(glm::length(p - test::effector_by_matrices(t, q, 0)), 0.0, 1e-12);
}

// Central differences of the goal's "current" side against tree_jacobian_column, for every goal
// kind on every effector of a floating humanoid: position, orientation (as a rotation vector of
// the relative turn), aim and aim-at (their error vectors' negated change).
TEST(Tree, JacobianMatchesFiniteDifferences) {
  const Tree t = test::make_humanoid(true, false);
  TreeWorkspace ws(t, 4), probe(t, 4);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd q = test::random_tree_params(t, rng, 1.5, 0.3);
    tree_forward_kinematics(t, q.data(), ws);
    tree_dof_axes(t, q.data(), ws);
    for (int e = 0; e < t.effector_count(); ++e) {
      const Goal goals[] = {Goal::position({0.3, 0.4, 0.5}, e), Goal::orientation(glm::dquat(1, 0, 0, 0), e),
                            Goal::aim({0, 0, 1}, {1, 0, 0}, e), Goal::aim_at({2.0, 1.5, 3.0}, {0, 1, 0}, e)};
      for (const Goal& g : goals) {
        const GoalLinearization lin = tree_linearize_goal(t, ws, g);
        for (int d = 0; d < t.dof_count(); ++d) {
          constexpr double h = 1e-6;
          Eigen::VectorXd qp = q, qm = q;
          qp[d] += h;
          qm[d] -= h;
          glm::dvec3 fd;
          if (g.kind == GoalKind::kOrientation) {
            tree_forward_kinematics(t, qp.data(), probe);
            const glm::dquat a = tree_effector_orientation(t, probe, e);
            tree_forward_kinematics(t, qm.data(), probe);
            const glm::dquat b = tree_effector_orientation(t, probe, e);
            fd = so3::log(a * glm::conjugate(b)) / (2 * h);
          } else {
            tree_forward_kinematics(t, qp.data(), probe);
            const glm::dvec3 a = tree_goal_error(t, probe, g);
            tree_forward_kinematics(t, qm.data(), probe);
            const glm::dvec3 b = tree_goal_error(t, probe, g);
            fd = -(a - b) / (2 * h);
          }
          const glm::dvec3 col = tree_jacobian_column(t, ws, g, lin, d);
          if (g.kind == GoalKind::kAim || g.kind == GoalKind::kAimAt) {
            // The error is a rotation vector whose axis turns with the pose: compare the change
            // of its length (the angle), which is what the column's projection onto it gives.
            const glm::dvec3 e0 = tree_goal_error(t, ws, g);
            const double angle = glm::length(e0);
            if (angle < 1e-3 || angle > 3.1) continue;
            tree_forward_kinematics(t, qp.data(), probe);
            const double ap = glm::length(tree_goal_error(t, probe, g));
            tree_forward_kinematics(t, qm.data(), probe);
            const double am = glm::length(tree_goal_error(t, probe, g));
            EXPECT_NEAR(-(ap - am) / (2 * h), glm::dot(col, e0 / angle), 1e-5) << "effector " << e << " dof " << d;
          } else {
            EXPECT_NEAR(glm::length(fd - col), 0.0, 1e-6) << "effector " << e << " dof " << d << " kind "
                                                         << static_cast<int>(g.kind);
          }
        }
      }
    }
  }
}

TEST(Tree, ChainAsTreeHasTheChainsKinematics) {
  std::mt19937 rng(3);
  const Chain chains[] = {test::make_hinge_chain(6), test::make_ball_chain(5)};
  for (const Chain& c : chains) {
    Tree t;
    ASSERT_TRUE(tree_from_chain(c, t).ok());
    ASSERT_EQ(t.dof_count(), c.dof_count());
    ASSERT_EQ(t.effector_count(), c.effector_count());
    Workspace cws(c, 1);
    TreeWorkspace tws(t, 1);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd q = test::random_params(c, rng);
      forward_kinematics(c, q.data(), cws);
      tree_forward_kinematics(t, q.data(), tws);
      for (int k = 1; k <= c.effector_count(); ++k) {
        EXPECT_NEAR(glm::length(effector_position(c, cws, k) - tree_effector_position(t, tws, k - 1)), 0.0, 1e-12);
        const glm::dquat a = effector_orientation(c, cws, k), b = tree_effector_orientation(t, tws, k - 1);
        EXPECT_NEAR(std::abs(glm::dot(a, b)), 1.0, 1e-12);
      }
    }
  }
}

TEST(Tree, ChainAsTreeSolvesTheChainsGoals) {
  const Chain c = test::make_hinge_chain(7);
  Tree t;
  ASSERT_TRUE(tree_from_chain(c, t).ok());
  std::mt19937 rng(5);
  Workspace cws(c, 2);
  TreeWorkspace tws(t, 2);
  SolverOptions o;
  int both = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::VectorXd target_pose = test::random_params(c, rng);
    forward_kinematics(c, target_pose.data(), cws);
    const glm::dvec3 tip = cws.tip;
    const Goal g = Goal::position(tip);
    Eigen::VectorXd qc = Eigen::VectorXd::Zero(c.dof_count()), qt = qc;
    const SolveResult rc = solve(SolverKind::kDLS, c, Span<const Goal>(&g, 1), o, cws, qc);
    TreeGoal tg{Goal::position(tip, t.effector_count() - 1), 1};
    TreeProblem p;
    p.goals = Span<const TreeGoal>(&tg, 1);
    const TreeSolveResult rt = solve_tree(SolverKind::kDLS, t, p, o, tws, qt);
    ASSERT_TRUE(rt.usable()) << rt.summary.message.c_str();
    EXPECT_EQ(rt.summary.reason == TerminationReason::kConverged, rt.summary.final_position_error <= 1e-5);
    if (rc.reason == TerminationReason::kConverged && rt.summary.reason == TerminationReason::kConverged) ++both;
    // The tree's verdict is its pose's: FK of the returned params.
    tree_forward_kinematics(t, qt.data(), tws);
    EXPECT_NEAR(glm::length(tree_effector_position(t, tws, t.effector_count() - 1) - tip),
                rt.summary.final_position_error, 1e-12);
  }
  EXPECT_EQ(both, 50);
}

// Every invalid field is rejected by name (joint or effector, field, message), one at a time.
TEST(Tree, InvalidTreesAreRejectedByName) {
  struct Case {
    const char* what;
    void (*mutate)(TreeBuilder&);
    int joint, effector;
    const char* field;
  };
  const Case cases[] = {
      {"parent after child", [](TreeBuilder& b) { b.add_joint(test::ball(40, {0, 1, 0}, 0)); }, 17, -1, "parent"},
      {"parent below -1", [](TreeBuilder& b) { b.add_joint(test::ball(-2, {0, 1, 0}, 0)); }, 17, -1, "parent"},
      {"NaN offset", [](TreeBuilder& b) { b.add_joint(test::ball(3, {0, NAN, 0}, 0)); }, 17, -1, "offset_in_parent"},
      {"huge offset", [](TreeBuilder& b) { b.add_joint(test::ball(3, {0, 1e60, 0}, 0)); }, 17, -1, "offset_in_parent"},
      {"zero hinge axis", [](TreeBuilder& b) { b.add_joint(test::hinge(3, {0, 1, 0}, {0, 0, 0}, 0, 1)); }, 17, -1,
       "axis"},
      {"hinge min > max", [](TreeBuilder& b) { b.add_joint(test::hinge(3, {0, 1, 0}, {1, 0, 0}, 10, -10)); }, 17, -1,
       "limits.hinge_min"},
      {"cone > pi",
       [](TreeBuilder& b) {
         TreeJointDesc d = test::ball(3, {0, 1, 0}, 0);
         d.limits.has_cone_limit = true;
         d.limits.cone_angle = 4.0;
         b.add_joint(d);
       },
       17, -1, "limits.cone_angle"},
      {"zero motion cost",
       [](TreeBuilder& b) {
         TreeJointDesc d = test::ball(3, {0, 1, 0}, 0);
         d.motion_cost = 0.0;
         b.add_joint(d);
       },
       17, -1, "motion_cost"},
      {"effector joint out of range", [](TreeBuilder& b) { b.add_effector({17, {0, 0, 0}, {1, 0, 0, 0}}); }, -1, 6,
       "joint"},
      {"effector NaN offset", [](TreeBuilder& b) { b.add_effector({2, {NAN, 0, 0}, {1, 0, 0, 0}}); }, -1, 6, "offset"},
      {"effector zero rotation", [](TreeBuilder& b) { b.add_effector({2, {0, 0, 0}, {0, 0, 0, 0}}); }, -1, 6,
       "rotation"},
  };
  for (const Case& c : cases) {
    TreeBuilder b = test::humanoid_builder(false);
    c.mutate(b);
    Tree t;
    const TreeBuildError e = b.build(t);
    EXPECT_FALSE(e.ok()) << c.what;
    EXPECT_FALSE(t.valid()) << c.what;
    EXPECT_EQ(e.joint, c.joint) << c.what << ": " << e.message.c_str();
    EXPECT_EQ(e.effector, c.effector) << c.what << ": " << e.message.c_str();
    EXPECT_STREQ(e.field, c.field) << c.what << ": " << e.message.c_str();
    const char* dot = std::strrchr(c.field, '.');
    EXPECT_NE(std::strstr(e.message.c_str(), dot ? dot + 1 : c.field), nullptr) << c.what << ": " << e.message.c_str();
    // The message is made from the data: the joint or effector by index, then the reason, which
    // names neither (so a caller showing a bone's name does not show the index too).
    char prefix[32];
    std::snprintf(prefix, sizeof prefix, c.joint >= 0 ? "joint %d: " : "effector %d: ", c.joint >= 0 ? c.joint : c.effector);
    EXPECT_EQ(std::string(e.message.c_str()), prefix + std::string(e.reason.c_str())) << c.what;
    EXPECT_EQ(std::strstr(e.reason.c_str(), "joint 17"), nullptr) << c.what << ": " << e.reason.c_str();
    EXPECT_EQ(std::strstr(e.reason.c_str(), "effector 6"), nullptr) << c.what << ": " << e.reason.c_str();
  }
  // A floating root must be a ball hanging from the base.
  TreeBuilder b;
  b.add_joint(test::hinge(-1, {0, 1, 0}, {1, 0, 0}, -1, 1));
  b.set_floating_root(true);
  Tree t;
  const TreeBuildError e = b.build(t);
  EXPECT_EQ(e.joint, 0);
  EXPECT_STREQ(e.field, "type");
  EXPECT_STREQ(e.reason.c_str(), "a floating root must be a ball joint with parent -1");
  EXPECT_STREQ(e.message.c_str(), "joint 0: a floating root must be a ball joint with parent -1");
  // Nothing at all.
  EXPECT_FALSE(TreeBuilder().build(t).ok());
}

}  // namespace
}  // namespace ikchain
