// What the tree solve tests (tree_solve_test.cpp: DLS) and the every-tree-solver tests
// (tree_solvers_test.cpp) share: the check that a result is the pose it returned, the sampling of
// random reachable five-effector poses, and the goals of the no-allocation solves.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

#include "ikchain/solve.hpp"
#include "ikchain/tree_solve.hpp"
#include "tree_test_util.hpp"

namespace ikchain {
namespace test {

// The errors solve_tree reports are the pose's: measured again from the params it returned, and
// for position goals by 4x4 matrices (the oracle); the pose is finite and within the limits.
inline void expect_result_is_the_pose(const Tree& tree, const TreeProblem& p, const TreeSolveResult& r,
                                      const Eigen::VectorXd& q) {
  TreeWorkspace ws(tree, p.goals.size);
  tree_forward_kinematics(tree, q.data(), ws);
  for (int g = 0; g < p.goals.size; ++g) {
    EXPECT_NEAR(glm::length(tree_goal_error(tree, ws, p.goals[g].goal)), r.goal_error[g], 1e-12) << "goal " << g;
    if (p.goals[g].goal.kind == GoalKind::kPosition) {
      const glm::dvec3 by_matrices = effector_by_matrices(tree, q, p.goals[g].goal.effector);
      EXPECT_NEAR(glm::length(by_matrices - p.goals[g].goal.target_position), r.goal_error[g], 1e-9) << "goal " << g;
    }
  }
  EXPECT_TRUE(q.allFinite());
  EXPECT_TRUE(within_tree_limits(tree, q.data(), 1e-9));
}

// One line for a solve that did not converge (trial, reason, iterations, escapes, errors).
inline void print_miss(int trial, const TreeSolveResult& r) {
  std::printf("  trial %d: %s after %d iterations, %d escapes, errors %g m %g rad\n", trial,
              to_string(r.summary.reason), r.summary.iterations, r.summary.escapes, r.summary.final_position_error,
              r.summary.final_orientation_error);
}

struct ReachRate {
  int trials = 0;
  int converged = 0;
  double median_position_error = 0.0;  // m
  int iterations = 0;  // summed over the trials
};

// `trials` random reachable poses of make_humanoid(floating)'s hands, feet and head (joints turned
// by up to 1.2 rad, the root moved by up to 0.2 m; seed 21), as goals at level 1 (6-D, or positions
// only), each solved with `kind` from rest. Every result is checked against its pose, a converged
// one against the tolerances. `print_misses`: a line for each solve that did not converge.
inline ReachRate reach_random_poses(SolverKind kind, bool floating, bool orientation, const SolverOptions& o,
                                    int trials, bool print_misses = false) {
  const Tree t = make_humanoid(floating);
  std::mt19937 rng(21);
  TreeWorkspace ws(t, 12);
  ReachRate rate;
  rate.trials = trials;
  std::vector<double> errors;
  for (int trial = 0; trial < trials; ++trial) {
    const Eigen::VectorXd target = random_tree_params(t, rng, 1.2, 0.2);
    const std::vector<TreeGoal> goals = pose_goals_at(
        t, target, {Humanoid::kLHand, Humanoid::kRHand, Humanoid::kLFoot, Humanoid::kRFoot, Humanoid::kHeadEffector}, 1,
        orientation);
    TreeProblem p;
    p.goals = goals;
    Eigen::VectorXd q = Eigen::VectorXd::Zero(t.dof_count());
    const TreeSolveResult r = solve_tree(kind, t, p, o, ws, q);
    EXPECT_TRUE(r.usable()) << r.summary.message.c_str();
    expect_result_is_the_pose(t, p, r, q);
    if (r.summary.reason == TerminationReason::kConverged) {
      ++rate.converged;
      EXPECT_LE(r.summary.final_position_error, o.position_tolerance);
      EXPECT_LE(r.summary.final_orientation_error, o.orientation_tolerance);
    } else if (print_misses) {
      print_miss(trial, r);
    }
    rate.iterations += r.summary.iterations;
    errors.push_back(r.summary.final_position_error);
  }
  std::sort(errors.begin(), errors.end());
  rate.median_position_error = 0.5 * (errors[(trials - 1) / 2] + errors[trials / 2]);
  return rate;
}

// The no-allocation solves' problem on the humanoid `t`: goals of every kind at three levels (12
// fit a TreeWorkspace(t, 12)) - 6-D goals for the feet (level 1) and hands (level 2) at a seeded
// random pose, the head aiming at a point (level 3) - and a posture toward the rest pose.
struct LeveledProblem {
  std::vector<TreeGoal> goals;
  Eigen::VectorXd rest;

  explicit LeveledProblem(const Tree& t) : rest(Eigen::VectorXd::Zero(t.dof_count())) {
    std::mt19937 rng(2);
    const Eigen::VectorXd target = random_tree_params(t, rng, 1.0, 0.1);
    goals = pose_goals_at(t, target, {Humanoid::kLFoot, Humanoid::kRFoot}, 1);
    const std::vector<TreeGoal> hands = pose_goals_at(t, target, {Humanoid::kLHand, Humanoid::kRHand}, 2);
    goals.insert(goals.end(), hands.begin(), hands.end());
    goals.push_back({Goal::aim_at({0, 1.6, 3}, {0, 0, 1}, Humanoid::kHeadEffector), 3});
  }
  // Views into this object: it must outlive the problem.
  TreeProblem problem() const {
    TreeProblem p;
    p.goals = goals;
    p.posture = Span<const double>(rest.data(), static_cast<int>(rest.size()));
    return p;
  }
};

}  // namespace test
}  // namespace ikchain
