// Every tree solver (the solver table's `trees` column) on branched bodies: random reachable poses
// of five effectors on the humanoid fixture from rest (FK round trip, a success rate per solver),
// limits, no allocation, priorities as each solver treats them, kinds refused by name, Auto.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>

#include "alloc_counter.hpp"
#include "core/solve.hpp"
#include "core/tree_solve.hpp"
#include "tree_test_util.hpp"

namespace ikchain {
namespace {

using test::Humanoid;
using test::pose_goals_at;

TEST(TreeSolversExplore, Rates) {
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kCCD, SolverKind::kFABRIK})
    for (bool floating : {false, true})
      for (bool orientation : {false, true}) {
        const Tree t = test::make_humanoid(floating);
        std::mt19937 rng(21);
        TreeWorkspace ws(t, 12);
        SolverOptions o;
        o.max_iterations = 500;
        int converged = 0, iters = 0;
        double us = 0, worst = 0;
        const int trials = 100;
        for (int trial = 0; trial < trials; ++trial) {
          const Eigen::VectorXd target = test::random_tree_params(t, rng, 1.2, 0.2);
          const std::vector<TreeGoal> goals = pose_goals_at(
              t, target, {Humanoid::kLHand, Humanoid::kRHand, Humanoid::kLFoot, Humanoid::kRFoot, Humanoid::kHeadEffector},
              1, orientation);
          TreeProblem p;
          p.goals = goals;
          Eigen::VectorXd q = Eigen::VectorXd::Zero(t.dof_count());
          const TreeSolveResult r = solve_tree(kind, t, p, o, ws, q);
          ASSERT_TRUE(r.usable()) << r.summary.message.c_str();
          converged += r.summary.reason == TerminationReason::kConverged;
          iters += r.summary.iterations;
          us += r.summary.elapsed_us;
          worst = std::max(worst, r.summary.final_position_error);
          EXPECT_TRUE(within_tree_limits(t, q.data(), 1e-9));
        }
        std::printf("%-7s floating %d orient %d: converged %3d/100, mean it %6.1f, mean us %8.1f, worst %g m\n",
                    to_string(kind), floating, orientation, converged, iters / 100.0, us / 100.0, worst);
      }
}

}  // namespace
}  // namespace ikchain
