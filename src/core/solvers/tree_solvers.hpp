// The tree solvers (internal): called by solve_tree() (tree_solve.cpp), which has validated every
// input, made the start pose feasible, sized the workspace and left the start pose's forward
// kinematics in it (tree_forward_kinematics(tree, params, ws)); each solver allocates nothing,
// throws nothing, keeps params within the limits and leaves them at the best pose it reached.
#pragma once
#include "core/kinematics_internal.hpp"
#include "ikchain/result.hpp"
#include "ikchain/tree_solve.hpp"

namespace ikchain {

// The errors of one pose, per level and in total.
struct TreeErrors {
  std::array<double, kMaxPriorityLevels> level_cost{};  // 0.5 sum_g w_g |e_g|^2 of each level
  std::array<bool, kMaxPriorityLevels> level_met{};     // every goal of the level within tolerance
  double cost = 0.0;             // all levels
  double max_position = 0.0;     // worst position goal (m)
  double max_orientation = 0.0;  // worst orientation / aim goal (rad)
  bool all_met() const {
    for (bool m : level_met)
      if (!m) return false;
    return true;
  }
};

// Measures every goal at the pose ws holds (after tree_forward_kinematics); when `residual` is
// given, also writes its weighted rows (3 per goal, in the order `goal_order` lists the goals).
TreeErrors tree_measure(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                        const TreeWorkspace& ws, const int* goal_order, double* residual, double* goal_error);

// True when ball params `p` are inside limits `l` for sure, without trigonometry: neither the
// swing nor |twist| exceeds the rotation angle |p| (cos(angle / 2) = cos(swing / 2) cos(twist / 2);
// kinematics.cpp's ball_bounds makes the same test). False says nothing.
bool ball_surely_inside(const JointLimits& l, const double* p);

// Base-frame axis of every DOF (ws.dof_axes), after tree_forward_kinematics.
// active_only: only the joints whose DOFs have a column in ws.dof_column (the tree DLS's; the
// others' axes are left as they were).
void tree_dof_axes(const Tree& tree, const double* params, TreeWorkspace& ws, bool active_only = false);

// What goal's Jacobian columns need of the pose ws holds, and the column of DOF `dof` (unweighted:
// the change of the goal's "current" side per unit of the DOF; zero where the DOF does not move
// the goal's effector). Needs tree_forward_kinematics and tree_dof_axes.
GoalLinearization tree_linearize_goal(const Tree& tree, const TreeWorkspace& ws, const Goal& goal);
glm::dvec3 tree_jacobian_column(const Tree& tree, const TreeWorkspace& ws, const Goal& goal,
                                const GoalLinearization& lin, int dof);

// An aim-at goal's effector this close to its point counts as on it (kAimAtOnPoint of the tree's
// scale; 0 for other kinds): the rule every tree solver measures by.
double tree_aim_at_on_point(const Tree& tree, const Goal& goal);

struct TreeSolverStatus {
  TerminationReason reason = TerminationReason::kStalled;
  int iterations = 0;
  int escapes = 0;  // stuck -> escape moves made (at most stuck::kMaxEscapes)
  // ws holds the forward kinematics of the params returned: solve_tree() measures the result
  // without a pass of its own (a warm frame's last trial is usually the pose returned).
  bool fk_of_params = false;
  // `errors` are the measure of the params returned, ws.goal_error their goals' errors (what
  // tree_measure() gives there, bit for bit): solve_tree() measures the result no second time.
  bool measured = false;
  TreeErrors errors;
};

// `start`: tree_measure() of params (the FK ws holds) with the weighted residual rows in goal
// order in ws.residual_trial and the goals' errors in ws.goal_error (solve_tree() measured them):
// the solver takes them over instead of measuring the start pose again.
TreeSolverStatus solve_tree_dls(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                TreeWorkspace& ws, double* params, const TreeErrors& start);
// The weighted-sum solvers: priority levels as weight ratios (solvers/tree_common.hpp), no posture
// for CCD and FABRIK; BFGS takes the posture as the lowest-weight term.
TreeSolverStatus solve_tree_bfgs(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                 TreeWorkspace& ws, double* params);
TreeSolverStatus solve_tree_ccd(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                TreeWorkspace& ws, double* params);
TreeSolverStatus solve_tree_fabrik(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                   TreeWorkspace& ws, double* params);

}  // namespace ikchain
