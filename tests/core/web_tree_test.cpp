// The web page's flat tree API (src/wasm/web_tree.hpp), compiled natively: no embind in it, so its
// per-frame path can be checked here with the allocation counter. The page's body view calls, per
// frame, the goal setters, solve() and frames(); none may allocate once the tree is built.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "wasm/web_tree.hpp"

namespace ikchain {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A small body: floating hips, a spine, two arms (shoulder ball, elbow hinge), two legs (hip ball,
// knee hinge, ankle ball); effectors: hands, feet (sole), head top. Returns the effector indices.
struct Body {
  web::WebTree tree;
  int hand_l = -1, hand_r = -1, foot_l = -1, foot_r = -1, head = -1;
};

void build_body(Body& b) {
  web::WebTree& t = b.tree;
  const int hips = t.add_ball(-1, 0, 0.9, 0, true, 35 * kDeg, -90 * kDeg, 90 * kDeg, 0, 1, 0, 1.0);
  const int spine = t.add_ball(hips, 0, 0.3, 0, true, 30 * kDeg, -30 * kDeg, 30 * kDeg, 0, 1, 0, 2.0);
  const int sl = t.add_ball(spine, 0.2, 0.2, 0, true, 120 * kDeg, -90 * kDeg, 90 * kDeg, 1, 0, 0, 1.0);
  const int el = t.add_hinge(sl, 0.28, 0, 0, 0, -1, 0, true, 0.0, 150 * kDeg, 1.0);
  const int sr = t.add_ball(spine, -0.2, 0.2, 0, true, 120 * kDeg, -90 * kDeg, 90 * kDeg, -1, 0, 0, 1.0);
  const int er = t.add_hinge(sr, -0.28, 0, 0, 0, 1, 0, true, 0.0, 150 * kDeg, 1.0);
  const int hl = t.add_ball(hips, 0.1, -0.05, 0, true, 90 * kDeg, -40 * kDeg, 40 * kDeg, 0, -1, 0, 1.0);
  const int kl = t.add_hinge(hl, 0, -0.4, 0, 1, 0, 0, true, 0.0, 150 * kDeg, 1.0);
  const int al = t.add_ball(kl, 0, -0.4, 0, true, 40 * kDeg, -30 * kDeg, 30 * kDeg, 0, -1, 0, 1.0);
  const int hr = t.add_ball(hips, -0.1, -0.05, 0, true, 90 * kDeg, -40 * kDeg, 40 * kDeg, 0, -1, 0, 1.0);
  const int kr = t.add_hinge(hr, 0, -0.4, 0, 1, 0, 0, true, 0.0, 150 * kDeg, 1.0);
  const int ar = t.add_ball(kr, 0, -0.4, 0, true, 40 * kDeg, -30 * kDeg, 30 * kDeg, 0, -1, 0, 1.0);
  b.hand_l = t.add_effector(el, 0.25, 0, 0);
  b.hand_r = t.add_effector(er, -0.25, 0, 0);
  b.foot_l = t.add_effector(al, 0, -0.05, 0.05);
  b.foot_r = t.add_effector(ar, 0, -0.05, 0.05);
  b.head = t.add_effector(spine, 0, 0.45, 0);
  t.set_floating_root(true, 0.5);
  ASSERT_EQ(t.build(), "");
}

TEST(WebTree, BuildsWithFloatingRootAndReportsSizes) {
  Body b;
  build_body(b);
  EXPECT_EQ(b.tree.joint_count(), 12);
  EXPECT_EQ(b.tree.dof_count(), 3 + 8 * 3 + 4);
  EXPECT_EQ(b.tree.effector_count(), 5);
  // frames(): 7 per joint, then 3 per effector; the left sole at rest.
  const std::vector<double>& f = b.tree.frames();
  ASSERT_EQ(f.size(), 7u * 12 + 3u * 5);
  EXPECT_NEAR(f[7 * 12 + 3 * b.foot_l + 1], 0.9 - 0.05 - 0.8 - 0.05, 1e-12);
}

// Feet planted at level 1, hands at level 2 going down and up, the head's aim, a posture: every goal met,
// the FK effector positions equal the targets, and a tracking frame (goal updates, solve, frames)
// allocates nothing.
TEST(WebTree, PerFrameSolveMeetsLevelsAndAllocatesNothing) {
  Body b;
  build_body(b);
  web::WebTree& t = b.tree;
  const std::vector<double> rest(t.dof_count(), 0.0);
  ASSERT_EQ(t.set_posture(rest.data(), t.dof_count(), 0.1), "");
  t.set_posture_iterations(4);
  t.set_tolerances(1e-4, 1e-3);
  t.set_max_iterations(60);
  ASSERT_EQ(t.add_position_goal(0.1, 0.0, 0.05, b.foot_l, 1.0, 1), "");
  ASSERT_EQ(t.add_orientation_goal(0, 0, 0, 1, b.foot_l, 1.0, 1), "");
  ASSERT_EQ(t.add_position_goal(-0.1, 0.0, 0.05, b.foot_r, 1.0, 1), "");
  ASSERT_EQ(t.add_orientation_goal(0, 0, 0, 1, b.foot_r, 1.0, 1), "");
  ASSERT_EQ(t.add_position_goal(0.35, 1.1, 0.25, b.hand_l, 1.0, 2), "");
  ASSERT_EQ(t.add_position_goal(-0.35, 1.1, 0.25, b.hand_r, 1.0, 2), "");
  ASSERT_EQ(t.add_aim_goal(0, 0, 1, 0, 0, 1, b.head, 1.0, 2), "");
  t.solve(static_cast<int>(SolverKind::kDLS));  // the first frame: anything may warm up

  std::size_t allocations = 0;
  for (int frame = 1; frame <= 40; ++frame) {
    const double s = 0.5 - 0.5 * std::cos(frame * 0.08);  // the hands go down 15 cm and back up
    const double y = 1.1 - 0.15 * s;
    const std::size_t before = test::allocation_count();
    ASSERT_TRUE(t.set_goal_position(4, 0.35, y, 0.25));
    ASSERT_TRUE(t.set_goal_position(5, -0.35, y, 0.25));
    ASSERT_TRUE(t.set_goal_aim_direction(6, 0.2 * s, 0, 1));
    const int reason = t.solve(static_cast<int>(SolverKind::kDLS));
    const std::vector<double>& f = t.frames();
    allocations += test::allocation_count() - before;

    ASSERT_NE(reason, static_cast<int>(TerminationReason::kInvalidInput)) << t.last_result().summary.message.c_str();
    const TreeSolveResult& r = t.last_result();
    ASSERT_EQ(r.goal_count, 7);
    EXPECT_TRUE(r.level_met[0]) << "frame " << frame;
    EXPECT_TRUE(r.level_met[1]) << "frame " << frame;
    const double* hand = f.data() + 7 * t.joint_count() + 3 * b.hand_l;
    EXPECT_NEAR(std::hypot(hand[0] - 0.35, hand[1] - y, hand[2] - 0.25), r.goal_error[4], 1e-9);
    EXPECT_LT(r.goal_error[4], 1e-4) << "frame " << frame;
  }
  EXPECT_EQ(allocations, 0u);
}

TEST(WebTree, BadInputIsNamedAndLeavesThePose) {
  Body b;
  build_body(b);
  web::WebTree& t = b.tree;
  ASSERT_EQ(t.add_position_goal(0, 0, 0, b.hand_l, 1.0, kMaxPriorityLevels + 1), "");
  const Eigen::VectorXd before = t.params();
  EXPECT_EQ(t.solve(static_cast<int>(SolverKind::kDLS)), static_cast<int>(TerminationReason::kInvalidInput));
  EXPECT_NE(std::string(t.last_result().summary.message.c_str()).find("level"), std::string::npos)
      << t.last_result().summary.message.c_str();
  EXPECT_EQ(t.params(), before);
  EXPECT_FALSE(t.set_goal_orientation(0, 0, 0, 0, 1));  // goal 0 is a position goal
  EXPECT_NE(t.set_posture(before.data(), 3, 0.1).find("expected"), std::string::npos);
  const std::vector<double> posture(t.dof_count(), 0.0);
  EXPECT_NE(t.set_posture(posture.data(), t.dof_count(), 1.5).find("stiffness"), std::string::npos);
  t.clear_goals();
  for (int i = 0; i < web::kMaxWebTreeGoals; ++i) ASSERT_EQ(t.add_position_goal(0, 0, 0, b.hand_l, 1.0, 1), "");
  EXPECT_NE(t.add_position_goal(0, 0, 0, b.hand_l, 1.0, 1).find("at most"), std::string::npos);
  web::WebTree bad;
  bad.add_ball(2, 0, 0, 0, false, 0, 0, 0, 0, 1, 0, 1.0);
  EXPECT_NE(bad.build().find("parent"), std::string::npos);
}

}  // namespace
}  // namespace ikchain
