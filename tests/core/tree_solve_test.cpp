// Coupled solves of whole trees: several effectors at once, strict priority levels, a floating
// root, the posture task, limits at every level, no allocation, invalid problems by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>

#include "alloc_counter.hpp"
#include "ikchain/solve.hpp"
#include "ikchain/tree_solve.hpp"
#include "tree_reach.hpp"

namespace ikchain {
namespace {

using test::expect_result_is_the_pose;
using test::Humanoid;
using test::pose_goals_at;

// `goals` with `posture` below them at `stiffness` per DOF (the problem points into all three).
TreeProblem with_posture(const std::vector<TreeGoal>& goals, const Eigen::VectorXd& posture,
                         const std::vector<double>& stiffness) {
  TreeProblem p;
  p.goals = goals;
  p.posture = Span<const double>(posture.data(), static_cast<int>(posture.size()));
  p.posture_stiffness = Span<const double>(stiffness.data(), static_cast<int>(stiffness.size()));
  return p;
}

// 100 random 6-D poses of hands, feet and head with the default options (tree_reach.hpp).
TEST(TreeSolve, BodyReachesEveryEffectorsPoseAtOnce) {
  for (bool floating : {false, true}) {
    const test::ReachRate r = test::reach_random_poses(SolverKind::kDLS, floating, /*orientation=*/true,
                                                       SolverOptions(), 100, /*print_misses=*/true);
    EXPECT_GE(r.converged, 95) << (floating ? "floating" : "fixed") << " root";
  }
}

TEST(TreeSolve, WarmStartTracksAMovingBodyInFewIterations) {
  const Tree t = test::make_humanoid(true);
  std::mt19937 rng(4);
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  const Eigen::VectorXd a = test::random_tree_params(t, rng, 0.8, 0.1);
  const Eigen::VectorXd b = test::random_tree_params(t, rng, 0.8, 0.1);
  Eigen::VectorXd q = a;
  int worst_iterations = 0;
  for (int frame = 0; frame <= 60; ++frame) {
    const double s = frame / 60.0;
    Eigen::VectorXd pose = (1 - s) * a + s * b;
    project_tree_to_limits(t, pose.data());
    const std::vector<TreeGoal> goals = pose_goals_at(
        t, pose, {Humanoid::kHipsEffector, Humanoid::kLHand, Humanoid::kRHand, Humanoid::kLFoot, Humanoid::kRFoot}, 1);
    TreeProblem p;
    p.goals = goals;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    EXPECT_EQ(r.summary.reason, TerminationReason::kConverged) << "frame " << frame;
    worst_iterations = std::max(worst_iterations, r.summary.iterations);
  }
  EXPECT_LE(worst_iterations, 10);
}

// The tree DLS keeps its set-up (the goals' order and columns, supports, column scales) in the
// workspace from one solve to the next of the same tree build and goals. A tree rebuilt in place
// (the same shape, another translation cost: other column scales), another tree solver in
// between, or the same effectors at other levels must each find it redone: every solve gives
// what a fresh workspace gives, bit for bit.
TEST(TreeSolve, AReusedWorkspaceSolvesAsAFreshOneAcrossRebuildsSolversAndLevels) {
  Tree t = test::make_humanoid(true);
  std::mt19937 rng(7);
  const Eigen::VectorXd start = test::random_tree_params(t, rng, 0.5, 0.05);
  const Eigen::VectorXd target = test::random_tree_params(t, rng, 0.5, 0.05);
  auto goals_with_hands_at = [&](int hands_level) {
    std::vector<TreeGoal> goals = pose_goals_at(t, target, {Humanoid::kHipsEffector, Humanoid::kLFoot, Humanoid::kRFoot}, 1);
    for (const TreeGoal& g : pose_goals_at(t, target, {Humanoid::kLHand, Humanoid::kRHand}, hands_level))
      goals.push_back(g);
    return goals;
  };
  const std::vector<TreeGoal> hands_second = goals_with_hands_at(2), hands_first = goals_with_hands_at(1);
  TreeWorkspace ws(t, 12);
  auto expect_as_fresh = [&](SolverKind kind, const std::vector<TreeGoal>& goals, const char* what) {
    TreeProblem p;
    p.goals = goals;
    TreeWorkspace fresh(t, 12);
    Eigen::VectorXd reused_q = start, fresh_q = start;
    const TreeSolveResult reused = solve_tree(kind, t, p, SolverOptions(), ws, reused_q);
    const TreeSolveResult first = solve_tree(kind, t, p, SolverOptions(), fresh, fresh_q);
    EXPECT_EQ(reused.summary.iterations, first.summary.iterations) << what;
    EXPECT_EQ(reused.summary.final_error, first.summary.final_error) << what;
    EXPECT_EQ(0, std::memcmp(reused_q.data(), fresh_q.data(), sizeof(double) * reused_q.size())) << what;
  };
  expect_as_fresh(SolverKind::kDLS, hands_second, "first solve");
  expect_as_fresh(SolverKind::kDLS, hands_second, "the same goals again (the set-up kept)");
  TreeBuilder b = test::humanoid_builder(true);
  b.set_floating_root(true, 4.0);
  ASSERT_TRUE(b.build(t).ok());
  expect_as_fresh(SolverKind::kDLS, hands_second, "the tree rebuilt with another translation cost");
  expect_as_fresh(SolverKind::kBFGS, hands_second, "BFGS");
  expect_as_fresh(SolverKind::kDLS, hands_second, "DLS after BFGS");
  expect_as_fresh(SolverKind::kDLS, hands_first, "the hands at level 1");
  expect_as_fresh(SolverKind::kDLS, hands_second, "the hands back at level 2");
}

// Feet at level 1, hands chasing targets out of reach at level 2: the feet hold to 1e-4 m, and
// the hands end where a solve that treats the feet as (nearly) hard constraints ends: the same
// goals in one level, the feet weighted 1e8 times more.
TEST(TreeSolve, PriorityLevelOneHoldsWhileLevelTwoChasesTheUnreachable) {
  const Tree t = test::make_humanoid(true);
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  o.max_iterations = 2000;
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  std::vector<TreeGoal> goals = pose_goals_at(t, rest, {Humanoid::kLFoot, Humanoid::kRFoot}, 1);
  goals.push_back({Goal::position({1.5, 2.5, 1.5}, Humanoid::kLHand), 2});
  goals.push_back({Goal::position({-1.5, 0.3, 2.0}, Humanoid::kRHand), 2});
  TreeProblem p;
  p.goals = goals;
  Eigen::VectorXd q = rest;
  const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
  ASSERT_TRUE(r.usable());
  expect_result_is_the_pose(t, p, r, q);
  SCOPED_TRACE(::testing::Message() << to_string(r.summary.reason) << " after " << r.summary.iterations
                                    << " iterations, " << r.summary.escapes << " escapes");
  EXPECT_TRUE(r.level_met[0]);
  EXPECT_FALSE(r.level_met[1]);
  EXPECT_NE(r.summary.reason, TerminationReason::kConverged);
  for (int g = 0; g < 4; ++g) EXPECT_LE(r.goal_error[g], 1e-4) << "foot goal " << g;

  std::vector<TreeGoal> penalty = goals;
  for (TreeGoal& g : penalty) {
    if (g.level == 1) g.goal.weight *= 1e8;
    g.level = 1;
  }
  TreeProblem pp;
  pp.goals = penalty;
  o.max_iterations = 2000;
  const double hands = std::hypot(r.goal_error[4], r.goal_error[5]);
  // From the prioritised solve's pose, the penalty solve stays where it is: that pose is a minimum
  // of the hands' error among the poses that keep the feet.
  Eigen::VectorXd warm = q;
  const TreeSolveResult rw = solve_tree(SolverKind::kDLS, t, pp, o, ws, warm);
  ASSERT_TRUE(rw.usable());
  EXPECT_NEAR(hands, std::hypot(rw.goal_error[4], rw.goal_error[5]), 1e-3 * hands);
  // From the rest pose, it ends no better.
  Eigen::VectorXd cold = rest;
  const TreeSolveResult rc = solve_tree(SolverKind::kDLS, t, pp, o, ws, cold);
  ASSERT_TRUE(rc.usable());
  SCOPED_TRACE(::testing::Message() << "penalty: " << to_string(rc.summary.reason) << " after "
                                    << rc.summary.iterations << " iterations, " << rc.summary.escapes << " escapes");
  EXPECT_GE(std::hypot(rc.goal_error[4], rc.goal_error[5]), hands * (1.0 - 1e-3));
}

// A hand target on the floor in front: out of reach with the hips fixed in the air, reached with
// a floating root (the body crouches and bends), while the feet stay planted at level 1.
TEST(TreeSolve, FloatingRootCrouchesToTheFloorWithFeetPlanted) {
  SolverOptions o;
  o.max_iterations = 300;
  const glm::dvec3 floor_target(0.25, 0.3, 0.45);
  for (bool floating : {false, true}) {
    const Tree t = test::make_humanoid(floating);
    TreeWorkspace ws(t, 8);
    const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
    std::vector<TreeGoal> goals = pose_goals_at(t, rest, {Humanoid::kLFoot, Humanoid::kRFoot}, 1);
    goals.push_back({Goal::position(floor_target, Humanoid::kLHand), 2});
    TreeProblem p;
    p.goals = goals;
    Eigen::VectorXd q = rest;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(r.usable());
    expect_result_is_the_pose(t, p, r, q);
    SCOPED_TRACE(::testing::Message() << to_string(r.summary.reason) << " after " << r.summary.iterations
                                      << " iterations, " << r.summary.escapes << " escapes");
    for (int g = 0; g < 4; ++g) EXPECT_LE(r.goal_error[g], 1e-4) << "foot goal " << g;
    if (floating) {
      EXPECT_EQ(r.summary.reason, TerminationReason::kConverged);
      EXPECT_LE(r.goal_error[4], o.position_tolerance);
      // The hips went down: the fixed root's best leaves the hand over 0.1 m short, so the reach
      // needs the crouch (how far the solution shares it with the spine is the solver's choice).
      EXPECT_LT(q[1], -0.05);
    } else {
      EXPECT_GT(r.goal_error[4], 0.1);
    }
  }
}

// With a posture (the rest pose), the redundant DOFs stay nearer to it than without, and the goals
// are met just the same.
TEST(TreeSolve, PostureTaskResolvesRedundancyTowardThePreferredPose) {
  const Tree t = test::make_humanoid(false);
  std::mt19937 rng(8);
  TreeWorkspace ws(t, 4);
  SolverOptions o;
  o.max_iterations = 200;
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  int nearer = 0;
  const int trials = 30;
  for (int trial = 0; trial < trials; ++trial) {
    const Eigen::VectorXd target = test::random_tree_params(t, rng, 0.8);
    const std::vector<TreeGoal> goals = pose_goals_at(t, target, {Humanoid::kLHand}, 1, false);
    TreeProblem p;
    p.goals = goals;
    Eigen::VectorXd start = test::random_tree_params(t, rng, 0.8);
    Eigen::VectorXd q_free = start, q_posture = start;
    const TreeSolveResult free = solve_tree(SolverKind::kDLS, t, p, o, ws, q_free);
    p.posture = Span<const double>(rest.data(), static_cast<int>(rest.size()));
    const TreeSolveResult posed = solve_tree(SolverKind::kDLS, t, p, o, ws, q_posture);
    ASSERT_EQ(free.summary.reason, TerminationReason::kConverged);
    ASSERT_EQ(posed.summary.reason, TerminationReason::kConverged);
    EXPECT_LE(posed.goal_error[0], o.position_tolerance);
    if (q_posture.norm() < q_free.norm()) ++nearer;
  }
  EXPECT_EQ(nearer, trials);
}

// A start that already meets the goals (the last frame's solution, warm) but lies far from the
// posture: the posture steps drift the goals by their square; the solve takes that drift back
// (the second-order correction) instead of refusing the step and stopping where it started.
TEST(TreeSolve, PostureMovesOnFromAStartThatAlreadyMeetsTheGoals) {
  const Tree t = test::make_humanoid(false);
  std::mt19937 rng(5);
  TreeWorkspace ws(t, 4);
  SolverOptions o;
  o.max_iterations = 200;
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const std::vector<double> stiffness(size_t(t.dof_count()), 0.1);  // IKBody's
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd start = test::random_tree_params(t, rng, 0.8);
    const std::vector<TreeGoal> goals = pose_goals_at(t, start, {Humanoid::kLHand}, 1, false);
    const TreeProblem p = with_posture(goals, rest, stiffness);
    Eigen::VectorXd q = start;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(r.usable());
    EXPECT_LE(r.goal_error[0], o.position_tolerance);
    EXPECT_GT(r.summary.iterations, 1) << "trial " << trial;
    EXPECT_LT(q.norm(), 0.5 * start.norm()) << "trial " << trial << ": the posture got nearer: " << start.norm()
                                            << " -> " << q.norm();
  }
}

// IKBody's tracking frame: feet and hips (position and rotation, the rotations weighted by their
// Tree::lever) at level 1, hands at level 2, the rest pose as a posture at stiffness 0.1,
// posture_iterations 4, each frame from the last one's pose while the targets move smoothly. Every
// frame meets every goal within a few iterations: the goals are polished without the posture
// (with it, the polish converged linearly for as long as the posture moved: 14-19 iterations a
// frame in Godot, with the hips' rotation weighted by its 0 m reach from the root).
TEST(TreeSolve, TrackingFramesWithLevelsAndAPostureTakeAFewIterations) {
  using H = Humanoid;
  const Tree t = test::make_humanoid(true);
  EXPECT_NEAR(t.lever(H::kHipsEffector), t.reach_from_root(H::kLHand), 1e-12);  // the farthest effector
  EXPECT_DOUBLE_EQ(t.lever(H::kLHand), t.reach_from_root(H::kLHand));          // a leaf: its own reach
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  o.position_tolerance = 1e-4;
  o.orientation_tolerance = 1e-3;
  o.time_cap_usec = 0.0;  // iteration counts, not the machine's load
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const std::vector<double> stiffness(size_t(t.dof_count()), 0.1);
  Eigen::VectorXd q = rest;
  std::vector<int> iterations;
  for (int frame = 0; frame < 120; ++frame) {
    // The target pose: hips down 5 cm and swaying, arms swinging, legs bending with the hips.
    const double w = 2.0 * 3.14159265358979 * frame / 60.0;
    Eigen::VectorXd target = rest;
    target[1] = -0.05 + 0.02 * std::sin(w);
    target[t.dof_offset(H::kLShoulder) + 2] = 0.4 + 0.3 * std::sin(w);
    target[t.dof_offset(H::kRShoulder) + 2] = -0.4 + 0.3 * std::cos(w);
    target[t.dof_offset(H::kLElbow)] = 0.5 + 0.3 * std::sin(w);
    target[t.dof_offset(H::kRElbow)] = 0.5 + 0.3 * std::cos(w);
    target[t.dof_offset(H::kLKnee)] = 0.4;
    target[t.dof_offset(H::kRKnee)] = 0.4;
    project_tree_to_limits(t, target.data());
    tree_forward_kinematics(t, target.data(), ws);
    std::vector<TreeGoal> goals;
    for (int e : {H::kHipsEffector, H::kLFoot, H::kRFoot}) {
      const double weight = (e == H::kHipsEffector ? 0.1 : 1.0);
      goals.push_back({Goal::position(tree_effector_position(t, ws, e), e, weight), 1});
      goals.push_back({Goal::orientation(tree_effector_orientation(t, ws, e), e, weight * t.lever(e) * t.lever(e)), 1});
    }
    for (int e : {H::kLHand, H::kRHand}) goals.push_back({Goal::position(tree_effector_position(t, ws, e), e), 2});
    TreeProblem p;
    p.goals = goals;
    p.posture = Span<const double>(rest.data(), static_cast<int>(rest.size()));
    p.posture_stiffness = Span<const double>(stiffness.data(), static_cast<int>(stiffness.size()));
    p.posture_iterations = 4;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(r.usable());
    ASSERT_EQ(r.summary.reason, TerminationReason::kConverged) << "frame " << frame;
    for (int g = 0; g < p.goals.size; ++g)
      EXPECT_LE(r.goal_error[g], p.goals[g].goal.kind == GoalKind::kPosition ? o.position_tolerance : o.orientation_tolerance)
          << "frame " << frame << " goal " << g;
    if (frame > 0) iterations.push_back(r.summary.iterations);  // frame 0 starts from the rest pose
  }
  std::sort(iterations.begin(), iterations.end());
  const int median = iterations[iterations.size() / 2];
  std::printf("  tracking frames: median %d iterations, worst %d\n", median, iterations.back());
  EXPECT_LE(median, 6);  // at most the polish and posture_iterations + 1 posture steps
  EXPECT_LE(iterations.back(), 12);
}

// A cold start with straight knees (each on its hinge's 0 bound) and the hips 8 cm lower: the feet
// must bend the knees. The stall and creep rules ask the first unmet level the step moved: the
// hands' error swinging up and down at level 2 while the feet crept at level 1 counted as progress
// and hid the creep until max_iterations (IKBody `deterministic` frames: 50 of 480 failed so).
TEST(TreeSolve, ACreepAtLevelOneIsSeenWhileALowerLevelSwings) {
  using H = Humanoid;
  const Tree t = test::make_humanoid(true);
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  o.position_tolerance = 1e-4;
  o.orientation_tolerance = 1e-3;
  o.time_cap_usec = 0.0;
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const std::vector<double> stiffness(size_t(t.dof_count()), 0.1);
  int converged = 0;
  const int trials = 24;
  for (int trial = 0; trial < trials; ++trial) {
    const double w = 2.0 * 3.14159265358979 * trial / trials;
    tree_forward_kinematics(t, rest.data(), ws);
    std::vector<TreeGoal> goals;
    for (int e : {H::kLFoot, H::kRFoot}) {
      goals.push_back({Goal::position(tree_effector_position(t, ws, e), e), 1});
      goals.push_back({Goal::orientation(tree_effector_orientation(t, ws, e), e, t.lever(e) * t.lever(e)), 1});
    }
    const glm::dvec3 hips = tree_effector_position(t, ws, H::kHipsEffector);
    const glm::dquat turn = glm::angleAxis(0.09 * std::sin(w), glm::dvec3(0, 1, 0));
    goals.push_back({Goal::position(hips + glm::dvec3(0.02 * std::sin(w), -0.08, 0.02 * std::cos(w)), H::kHipsEffector, 0.1), 1});
    goals.push_back({Goal::orientation(turn, H::kHipsEffector, 0.1 * t.lever(H::kHipsEffector) * t.lever(H::kHipsEffector)), 1});
    for (int e : {H::kLHand, H::kRHand}) {
      const glm::dvec3 hand = tree_effector_position(t, ws, e);
      goals.push_back({Goal::position(glm::dvec3(0.6 * hand.x, hand.y - 0.3 + 0.08 * std::sin(w), 0.25), e), 2});
    }
    TreeProblem p;
    p.goals = goals;
    p.posture = Span<const double>(rest.data(), static_cast<int>(rest.size()));
    p.posture_stiffness = Span<const double>(stiffness.data(), static_cast<int>(stiffness.size()));
    p.posture_iterations = 4;
    Eigen::VectorXd q = rest;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(r.usable());
    if (r.summary.reason == TerminationReason::kConverged) ++converged;
    else
      test::print_miss(trial, r);
  }
  EXPECT_EQ(converged, trials);
}

// A settling solve (posture_iterations 0: IKBody's first frame) brings the joints no goal moves onto
// their posture, however soft: at IKBody's stiffness 0.1 the right arm, which the left hand's goal
// does not move, ends on its preferred pose. Its steps used to take the posture's gain, which
// refused steps of the goals' joints shorten to 1/64, and the settle stopped with the arm still
// turned (0.003-0.04 rad); the tracking frames after it crept the rest.
TEST(TreeSolve, ASettlingPostureSettlesTheJointsNoGoalMoves) {
  using H = Humanoid;
  const Tree t = test::make_humanoid(false);
  std::mt19937 rng(12);
  TreeWorkspace ws(t, 4);
  SolverOptions o;
  o.time_cap_usec = 0.0;  // iteration counts, not the machine's load
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const std::vector<double> stiffness(size_t(t.dof_count()), 0.1);  // IKBody's
  const int arm_begin = t.dof_offset(H::kRShoulder), arm_end = t.dof_offset(H::kRWrist) + t.dof_count_of(H::kRWrist);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::VectorXd start = test::random_tree_params(t, rng, 0.8);
    const std::vector<TreeGoal> goals = pose_goals_at(t, start, {Humanoid::kLHand}, 1, false);
    const TreeProblem p = with_posture(goals, rest, stiffness);
    Eigen::VectorXd q = start;
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_EQ(r.summary.reason, TerminationReason::kConverged) << "trial " << trial;
    const double arm_left = (q - rest).segment(arm_begin, arm_end - arm_begin).cwiseAbs().maxCoeff();
    EXPECT_LE(arm_left, 1e-3) << "trial " << trial << ": the free arm's largest param left to its posture (rad), from "
                              << (start - rest).segment(arm_begin, arm_end - arm_begin).cwiseAbs().maxCoeff();
  }
}

// posture_iterations: once every goal is met, a tracking solve stops after that many more
// iterations instead of waiting for the posture to settle (IKBody's stiffness 0.1 took ~20
// iterations a frame); every goal stays met, and frames that start from the last one's pose get
// to the settled posture within a few frames.
TEST(TreeSolve, PostureIterationsCapTheWorkOnceTheGoalsAreMet) {
  const Tree t = test::make_humanoid(false);
  std::mt19937 rng(9);
  TreeWorkspace ws(t, 4);
  SolverOptions o;
  o.max_iterations = 200;
  o.time_cap_usec = 0.0;  // iteration counts, not the machine's load
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const std::vector<double> stiffness(size_t(t.dof_count()), 0.1);
  int capped_total = 0, settled_total = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd start = test::random_tree_params(t, rng, 0.8);
    const std::vector<TreeGoal> goals = pose_goals_at(t, start, {Humanoid::kLHand, Humanoid::kRFoot}, 1, false);
    TreeProblem p;
    p.goals = goals;
    p.posture = Span<const double>(rest.data(), static_cast<int>(rest.size()));
    p.posture_stiffness = Span<const double>(stiffness.data(), static_cast<int>(stiffness.size()));
    Eigen::VectorXd settled = start;
    const TreeSolveResult rs = solve_tree(SolverKind::kDLS, t, p, o, ws, settled);
    p.posture_iterations = 2;
    Eigen::VectorXd q = start;
    const TreeSolveResult rc = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(rs.usable() && rc.usable());
    EXPECT_EQ(rc.summary.reason, TerminationReason::kConverged) << "trial " << trial;
    EXPECT_LE(rc.summary.iterations, 5) << "trial " << trial;  // the start meets the goals
    EXPECT_LT(rc.summary.iterations, rs.summary.iterations) << "trial " << trial;
    capped_total += rc.summary.iterations;
    settled_total += rs.summary.iterations;
    // Tracking: each frame starts from the last one's pose; the posture goes on, as near the
    // preferred pose as a settled solve gets (the goals' null space is curved: not to the same pose).
    for (int frame = 0; frame < 30; ++frame) {
      const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
      ASSERT_EQ(r.summary.reason, TerminationReason::kConverged) << "trial " << trial << " frame " << frame;
      for (int g = 0; g < r.goal_count; ++g) EXPECT_LE(r.goal_error[g], o.position_tolerance);
    }
    EXPECT_LT((q - rest).norm(), 1.05 * (settled - rest).norm() + 1e-6) << "trial " << trial;
  }
  EXPECT_LT(3 * capped_total, settled_total);
  TreeProblem bad;
  bad.posture_iterations = -1;
  Eigen::VectorXd q = rest;
  EXPECT_NE(std::string(solve_tree(SolverKind::kDLS, t, bad, o, ws, q).summary.message.c_str()).find("posture_iterations"),
            std::string::npos);
}

TEST(TreeSolve, LimitsHoldAtEveryLevel) {
  const Tree t = test::make_humanoid(true);
  std::mt19937 rng(31);
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<TreeGoal> goals;
    for (int e = 0; e < t.effector_count(); ++e)
      goals.push_back({Goal::position({u(rng), 1.0 + u(rng), u(rng)}, e), 1 + (e % 3)});
    TreeProblem p;
    p.goals = goals;
    Eigen::VectorXd q = test::random_tree_params(t, rng, 1.0, 0.1);
    const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
    ASSERT_TRUE(r.usable());
    expect_result_is_the_pose(t, p, r, q);
  }
}

TEST(TreeSolve, SolveAllocatesNothing) {
  const Tree t = test::make_humanoid(true);
  TreeWorkspace ws(t, 12);
  SolverOptions o;
  const test::LeveledProblem leveled(t);
  const TreeProblem p = leveled.problem();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(t.dof_count());
  const std::size_t before = test::allocation_count();
  const TreeSolveResult r = solve_tree(SolverKind::kDLS, t, p, o, ws, q);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(r.usable());
  EXPECT_GT(r.summary.iterations, 0);
}

TEST(TreeSolve, InvalidProblemsAreRejectedByNameAndLeaveParamsUntouched) {
  const Tree t = test::make_humanoid(true);
  TreeWorkspace ws(t, 4);
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(t.dof_count());
  const Eigen::VectorXd short_posture = Eigen::VectorXd::Zero(3);
  struct Case {
    const char* expect;
    TreeGoal goal;
    SolverKind kind;
    bool short_posture;
    int restarts;
  };
  const Case cases[] = {
      {"level", {Goal::position({0, 1, 0}, 0), 0}, SolverKind::kDLS, false, 0},
      {"level", {Goal::position({0, 1, 0}, 0), kMaxPriorityLevels + 1}, SolverKind::kDLS, false, 0},
      {"effector", {Goal::position({0, 1, 0}, 6), 1}, SolverKind::kDLS, false, 0},
      {"weight", {Goal::position({0, 1, 0}, 0, -1.0), 1}, SolverKind::kDLS, false, 0},
      {"target_position", {Goal::position({0, NAN, 0}, 0), 1}, SolverKind::kDLS, false, 0},
      {"target_orientation", {Goal::orientation({0, 0, 0, 0}, 0), 1}, SolverKind::kDLS, false, 0},
      {"posture", {Goal::position({0, 1, 0}, 0), 1}, SolverKind::kDLS, true, 0},
      {"max_restarts", {Goal::position({0, 1, 0}, 0), 1}, SolverKind::kDLS, false, 3},
      {"two_bone", {Goal::position({0, 1, 0}, 0), 1}, SolverKind::kTwoBone, false, 0},
  };
  for (const Case& c : cases) {
    TreeProblem p;
    p.goals = Span<const TreeGoal>(&c.goal, 1);
    if (c.short_posture) p.posture = Span<const double>(short_posture.data(), 3);
    SolverOptions o;
    o.max_restarts = c.restarts;
    Eigen::VectorXd q = Eigen::VectorXd::Constant(t.dof_count(), 0.1);
    const TreeSolveResult r = solve_tree(c.kind, t, p, o, ws, q);
    EXPECT_EQ(r.summary.reason, TerminationReason::kInvalidInput) << c.expect;
    EXPECT_NE(std::strstr(r.summary.message.c_str(), c.expect), nullptr) << r.summary.message.c_str();
    EXPECT_TRUE((q.array() == 0.1).all()) << c.expect;
  }
  // A workspace sized for fewer goals, and params of the wrong size.
  TreeGoal two[2] = {{Goal::position({0, 1, 0}, 0), 1}, {Goal::position({0, 1, 0}, 1), 1}};
  TreeWorkspace small(t, 1);
  TreeProblem p;
  p.goals = Span<const TreeGoal>(two, 2);
  Eigen::VectorXd q = rest;
  EXPECT_NE(std::strstr(solve_tree(SolverKind::kDLS, t, p, SolverOptions(), small, q).summary.message.c_str(),
                        "workspace"),
            nullptr);
  Eigen::VectorXd wrong(5);
  EXPECT_NE(std::strstr(solve_tree(SolverKind::kDLS, t, p, SolverOptions(), ws, wrong).summary.message.c_str(),
                        "params"),
            nullptr);
}

TEST(TreeSolve, SolverTableSaysWhichSolversTakeTrees) {
  const Tree t = test::make_humanoid(false);
  TreeWorkspace ws(t, 1);
  TreeGoal g{Goal::position({0.5, 1.3, 0.2}, Humanoid::kLHand), 1};
  TreeProblem p;
  p.goals = Span<const TreeGoal>(&g, 1);
  for (const SolverInfo& info : solver_table()) {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(t.dof_count());
    const TreeSolveResult r = solve_tree(info.kind, t, p, SolverOptions(), ws, q);
    EXPECT_EQ(r.usable(), info.trees) << info.id << ": " << r.summary.message.c_str();
  }
}

}  // namespace
}  // namespace ikchain
