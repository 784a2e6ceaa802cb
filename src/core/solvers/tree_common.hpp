// What the weighted-sum tree solvers (BFGS, CCD, FABRIK on trees) share (internal): priority
// levels as weights, the DOFs the goals depend on, the escape from a stuck pose and the best-pose
// bookkeeping of the geometric ones.
//
// Priorities without strict levels. Only the tree DLS solves level k in the null space of the
// levels above it. BFGS, CCD and FABRIK have no null space to work in: they minimise one weighted
// sum, in which a goal of level l weighs level_weight(l) = kLevelWeightRatio^-(l-1) times its own
// weight (level 1: x1, level 2: x1e-3, ...). A lower level then gives way wherever it conflicts with
// a higher one, but not exactly: at the optimum a level-2 goal still pulls a level-1 goal by about
// 1/kLevelWeightRatio of their conflict. When every goal is reachable at once the weights do not
// matter (the sum's minimum is 0).
#pragma once
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "ikchain/so3.hpp"
#include "core/solvers/stuck.hpp"
#include "core/solvers/tree_solvers.hpp"

namespace ikchain {
namespace tree_common {

// How much more a goal of level l weighs than the same goal one level lower (see above). 1e3: a
// higher level wins by three orders of magnitude, while the lowest level (4) still weighs 1e-9,
// well above the rounding of the sum (the stall rule measures relative gains of 1e-10).
constexpr double kLevelWeightRatio = 1e3;

inline double level_weight(int level) {
  double w = 1.0;
  for (int l = 1; l < level; ++l) w /= kLevelWeightRatio;
  return w;
}

// The weighted sum of the level costs tree_measure() returns.
inline double weighted_cost(const TreeErrors& e) {
  double c = 0.0;
  for (int l = 0; l < kMaxPriorityLevels; ++l) c += level_weight(l + 1) * e.level_cost[l];
  return c;
}

// True when joint `a` is joint `j` or one of its ancestors.
inline bool is_ancestor_or_self(const Tree& tree, int a, int j) {
  while (j > a) j = tree.parent(j);
  return j == a;
}

// Lists in ws.active_dofs the DOFs that move any goal's effector (the union of their supports;
// the floating root's translation included), ascending; returns their count.
inline int goal_dofs(const Tree& tree, const TreeProblem& problem, TreeWorkspace& ws) {
  ws.setup_tree = 0;  // the tree DLS's set-up no longer holds
  std::fill(ws.dof_column.begin(), ws.dof_column.end(), -1);
  for (int g = 0; g < problem.goals.size; ++g) {
    const int e = problem.goals[g].goal.effector;
    const int* s = tree.support_list(e);
    for (int k = 0; k < tree.support_count(e); ++k) {
      const int j = s[k];
      for (int d = 0; d < tree.dof_count_of(j); ++d) ws.dof_column[tree.dof_offset(j) + d] = 0;
      if (j == 0 && tree.floating_root())
        for (int d = 0; d < 3; ++d) ws.dof_column[d] = 0;
    }
  }
  int count = 0;
  for (int d = 0; d < tree.dof_count(); ++d)
    if (ws.dof_column[d] == 0) {
      ws.dof_column[d] = count;
      ws.active_dofs[count++] = d;
    }
  return count;
}

// Escape `number` (1..stuck::kMaxEscapes) from a stuck pose, every tree solver's (DLS, BFGS, CCD,
// FABRIK), the chain solvers' (stuck.hpp) in simpler form: odd escapes move every joint among the
// first `active` of ws.active_dofs that rests on a bound off it (a hinge half way into its range,
// then kSecondUnpinFraction; a ball half way back from its cone); even escapes (and odd ones with
// nothing pinned) kick every such rotation DOF by the fixed golden-angle pattern of
// stuck::kKickAmplitude. Needs ws.active_dofs listing each joint's DOFs together (goal_dofs() or
// the tree DLS's columns). False when nothing moved.
inline bool escape(const Tree& tree, const TreeWorkspace& ws, int active, int number, double* params) {
  bool moved = false;
  if (number % 2 == 1) {
    const double toward_other_end = number >= 3 ? stuck::kSecondUnpinFraction : 0.5;
    for (int c = 0; c < active; ++c) {
      const int d = ws.active_dofs[c];
      const int j = ws.dof_joint[d];
      if (j < 0 || d != tree.dof_offset(j) || !tree.has_limits(j)) continue;  // each joint once
      const JointLimits& l = tree.limits(j);
      const JointType type = tree.joint_type(j);
      const ParamRange range = param_range(type, l);
      if (!is_one_dof(type)) {
        if (ball_params_on_boundary(l, params + d)) {
          for (int k = 0; k < 3; ++k) params[d + k] *= 0.5;
          moved = true;
        }
      } else if (one_dof_blocked(type, l, params[d], -1.0)) {
        params[d] = range.min + toward_other_end * (range.max - range.min);
        moved = true;
      } else if (one_dof_blocked(type, l, params[d], 1.0)) {
        params[d] = range.max - toward_other_end * (range.max - range.min);
        moved = true;
      }
    }
  }
  if (!moved) {
    for (int c = 0; c < active; ++c) {
      const int d = ws.active_dofs[c];
      if (ws.dof_joint[d] < 0) continue;  // the root's translation stays
      params[d] += stuck::kKickAmplitude * std::sin(2.399963 * (c + 1) + (number - 1));
    }
    moved = active > 0;
  }
  project_tree_to_limits(tree, params);
  return moved;
}

// The bookkeeping CCD and FABRIK on trees do around their iterations, as geometric::Progress does
// for chains: the best pose seen by the weighted cost (in ws.params_best, returned at the end) and
// the shared stuck rules (stuck.hpp). Stuck: the stall rule, or an iteration that turned no
// parameter by more than kStillAngle; either escapes, and with none left the solve stops as stalled.
class Progress {
 public:
  static constexpr double kStillAngle = 1e-12;  // rad

  // Measures the start pose (FK into ws).
  Progress(const Tree& tree, const TreeProblem& problem, const SolverOptions& options, TreeWorkspace& ws,
           const double* params)
      : tree_(tree), problem_(problem), options_(options), ws_(ws) {
    active_ = goal_dofs(tree, problem, ws);
    measure(params);
    best_ = cost_;
    std::copy(params, params + tree.dof_count(), ws.params_best.data());
    stall_.reset(cost_);
  }

  int escapes() const { return escapes_; }
  bool met() const { return errors_.all_met(); }

  // After an iteration that changed no parameter by more than `moved`: measures the pose (FK into
  // ws), keeps it if best, escapes when stuck; returns true when the solve stops, with `reason` set
  // to kConverged, kStalled or (time budget) kMaxIterations.
  bool stop_after_iteration(double* params, double moved, TerminationReason& reason) {
    measure(params);
    if (errors_.all_met()) {
      reason = TerminationReason::kConverged;
      return true;
    }
    const bool stalled = stall_.stalled_after(cost_, options_.stall_tolerance);
    if (moved <= kStillAngle || stalled) {
      if (escapes_ >= stuck::kMaxEscapes || !escape(tree_, ws_, active_, ++escapes_, params)) {
        reason = TerminationReason::kStalled;
        return true;
      }
      measure(params);
      stall_.reset(cost_);
    }
    if (ws_.deadline.spent()) {
      reason = TerminationReason::kMaxIterations;
      return true;
    }
    return false;
  }

  // A converged pose stays as it is; otherwise params go to the best pose seen (FK into ws).
  void finish(TerminationReason reason, double* params) {
    if (reason == TerminationReason::kConverged || !(best_ < cost_)) return;
    std::copy(ws_.params_best.data(), ws_.params_best.data() + tree_.dof_count(), params);
    tree_forward_kinematics(tree_, params, ws_);
  }

 private:
  void measure(const double* params) {
    tree_forward_kinematics(tree_, params, ws_);
    errors_ = tree_measure(tree_, problem_, options_, ws_, nullptr, nullptr, nullptr);
    cost_ = weighted_cost(errors_);
    if (cost_ < best_) {  // NaN compares false
      best_ = cost_;
      std::copy(params, params + tree_.dof_count(), ws_.params_best.data());
    }
  }

  const Tree& tree_;
  const TreeProblem& problem_;
  const SolverOptions& options_;
  TreeWorkspace& ws_;
  stuck::StallRule stall_;
  TreeErrors errors_;
  double cost_ = 0.0, best_ = INFINITY;
  int escapes_ = 0;
  int active_ = 0;
};

}  // namespace tree_common
}  // namespace ikchain
