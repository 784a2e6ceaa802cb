// One result struct for every solver (like Ceres' Solver::Summary).
#pragma once
#include "ikchain/message.hpp"

namespace ikchain {

enum class TerminationReason : int {
  kConverged = 0,      // every goal within tolerance
  kMaxIterations = 1,  // iteration or time budget spent while still improving; pose usable, not
                       // converged (budget_exhausted tells the time budget apart)
  kStalled = 2,        // no more progress, goals not met: a local minimum, a limit in the way, or
                       // goals that may be unreachable but are not provably so; says nothing about
                       // reachability (another start may succeed)
  kUnreachable = 3,    // goals provably out of reach (a position goal beyond its effector's reach
                       // from the root, or two beyond the bones between them) and the pose is the
                       // best reach (a stationary point; see is_best_reach() in solve.cpp)
  kInvalidInput = 4,   // options/goals/params/chain invalid; params untouched, see message
};
const char* to_string(TerminationReason reason);

struct SolveResult {
  TerminationReason reason = TerminationReason::kInvalidInput;
  int iterations = 0;
  // Combined error sqrt(sum_g weight_g |e_g|^2): for a single position goal, the distance (m).
  // "Initial" is the pose the solver starts from: the given one (warm start) or the rest pose,
  // after projection onto the limits.
  double initial_error = 0.0;
  double final_error = 0.0;
  // Worst goal of each kind (m, rad); 0 when there is no goal of that kind.
  double initial_position_error = 0.0;
  double final_position_error = 0.0;
  double initial_orientation_error = 0.0;
  double final_orientation_error = 0.0;
  double elapsed_us = 0.0;  // wall-clock time of the whole solve call (microseconds)
  // True when the solver stopped because SolverOptions::time_budget_usec ran out (reason is then
  // kMaxIterations, or kUnreachable when the pose it stopped at is provably a best reach; for a
  // tree with a posture task, kConverged when every goal was met and the posture's settle was cut).
  bool budget_exhausted = false;
  int restarts = 0;  // restarts run (SolverOptions::max_restarts); iterations include theirs
  // Escapes from stuck poses inside the solver runs (at most 5 per run, 21 for a query, restarts' included;
  // docs/solvers.md, "When a solve is stuck"). Deterministic, like everything else here.
  int escapes = 0;
  // Joints resting on a limit at the returned pose (a hinge or slide at a bound, a ball on its cone
  // or a twist bound; 0 for kInvalidInput). With kStalled (or kMaxIterations) it says what holds
  // the pose: the limits, when the goals lie within the bones' reach - out of reach because of the
  // limits, where more iterations give the same pose (docs/solvers.md, "When a solve is stuck").
  int joints_at_limit = 0;
  // How far SolverOptions::soft_reach pulled a position goal's target toward the root (m; the
  // largest pull over the goals; 0 when soft_reach is off or no target came near full reach).
  // The errors above refer to the pulled targets.
  double soft_pull = 0.0;
  Message message;          // why, for kInvalidInput (names the bad field); empty otherwise

  // Derived from the reason, so the two can never disagree (Ceres' IsSolutionUsable()): false only
  // for kInvalidInput, where params were left untouched.
  bool usable() const { return reason != TerminationReason::kInvalidInput; }
};

}  // namespace ikchain
