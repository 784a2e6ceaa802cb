// Solving a whole tree in one coupled problem, with strict priority levels.
//
// Goals are the chain's Goal kinds (goal.hpp) on tree effectors (Goal::effector = the index
// TreeBuilder::add_effector returned), each at a priority level: 1 is the highest. Level k is
// solved in the null space of levels 1..k-1 (recursive null-space projection, Siciliano & Slotine
// 1991; Baerlocher & Boulic 2004): a lower level never gives up accuracy of a higher one to serve
// itself. Within a level, goal weights trade goals off as in a chain solve. Below every level an
// optional posture task pulls the redundant DOFs toward a preferred pose. Joint limits hold at
// every level (the active set of the Jacobian solvers).
// That is the tree DLS (SolverKind::kDLS). BFGS, CCD and FABRIK also take trees (the solver table's
// `trees` column) but have no null space: they weigh each level 1e3 times the one below it
// (solvers/tree_common.hpp), and CCD and FABRIK ignore the posture. auto_tree_solver() picks.
#pragma once
#include <array>
#include <vector>

#include <Eigen/Dense>

#include "ikchain/deadline.hpp"
#include "ikchain/goal.hpp"
#include "ikchain/options.hpp"
#include "ikchain/result.hpp"
#include "ikchain/span.hpp"
#include "ikchain/tree.hpp"

namespace ikchain {

constexpr int kMaxPriorityLevels = 4;
constexpr int kMaxTreeGoals = 64;

struct TreeGoal {
  Goal goal;      // goal.effector: a tree effector index (0..effector_count-1)
  int level = 1;  // 1 (highest) .. kMaxPriorityLevels
};

struct TreeProblem {
  Span<const TreeGoal> goals;
  // Posture task, below every level: the preferred params (dof_count entries; empty = none) and
  // per DOF the share (in [0, 1]) of the remaining distance to them that one iteration closes
  // inside the null space of every goal level (empty = 1 for every DOF; 0 = this DOF has no
  // preference). It only uses the freedom the goals leave, so it never costs a goal accuracy.
  Span<const double> posture;
  Span<const double> posture_stiffness;
  // The posture converges linearly (a share of the remaining distance a step): a solve that waits
  // for it to settle (its gain below 1e-3; posture_iterations 0) spends most of its iterations on
  // it. Such a solve scales the stiffnesses so the largest is 1 once the goals are near (the
  // settled pose, where no stiffness-weighted pull is left in the goals' null space, is the same at
  // any common scale). A DOF no goal depends on takes its whole share every posture step.
  // A tracking caller, whose next frame starts from this one's pose and goes on toward the
  // posture, can give it this many steps instead: the posture rides on the solve's steps, and
  // once this many of them have carried it from or to a pose near the goals (every level within
  // 100 tolerances) the steps serve the goals alone, and the solve stops when they are met. With
  // 1, a tracking frame's first step both follows the targets and pulls toward the posture, and
  // the next one polishes: often the whole frame. Ignored without a posture; the goals are met
  // either way.
  int posture_iterations = 0;
};

struct TreeSolveResult {
  // Reason, iterations, worst errors of the whole problem, time, restarts, budget: as for chains.
  // Converged means every goal of every level is within tolerance.
  SolveResult summary;
  int goal_count = 0;
  // Per goal, in the problem's order: its error after the solve (m for kPosition, rad otherwise).
  std::array<double, kMaxTreeGoals> goal_error{};
  // Per level 1..kMaxPriorityLevels (index level - 1): true when every goal of that level is
  // within tolerance (a level with no goal is met).
  std::array<bool, kMaxPriorityLevels> level_met{};
  bool usable() const { return summary.usable(); }
};

// Caller-owned scratch memory: sized once by reset() (allocates); a solve that fits() allocates
// nothing.
struct TreeWorkspace {
  TreeWorkspace() = default;
  explicit TreeWorkspace(const Tree& tree, int max_goals = 16) { reset(tree, max_goals); }
  void reset(const Tree& tree, int max_goals = 16);
  bool fits(const Tree& tree, int goal_count) const;

  int joints = 0, dofs = 0, max_goals = 0;
  Deadline deadline;

  // Forward kinematics (tree_forward_kinematics() fills these), base space.
  std::vector<glm::dvec3> joint_origins;        // o_i
  std::vector<glm::dquat> joint_orientations;   // Q_i
  std::vector<glm::dquat> joint_pre_rotations;  // pre_i
  std::vector<glm::dvec3> dof_axes;             // per DOF: base-frame rotation axis (or slide direction)

  // The coupled solvers' linear algebra. Rows: 3 per goal, in level order (goal_order); columns:
  // the DOFs that move any goal's effector (active_dofs), each scaled by 1 / sqrt(motion cost).
  Eigen::MatrixXd jacobian;       // (3 * max_goals) x dofs, weighted rows
  Eigen::MatrixXd row_square;     // (3 * max_goals)^2: the Gram matrix J J^T of every row
  Eigen::MatrixXd row_factor;     // (3 * max_goals)^2: each level's damped matrix, factored in place
  Eigen::MatrixXd gram_factor;    // (3 * max_goals)^2: the rows above a level, factored in place
  Eigen::MatrixXd coupling;       // (3 * max_goals)^2: G^-1 A Jl^T
  Eigen::VectorXd residual;       // 3 * max_goals, weighted, level order
  Eigen::VectorXd residual_trial;
  // max_goals, by goal index: each goal's error (tree_measure's goal_error) at the pose of
  // `residual` and of `residual_trial`, and at the best pose (the tree DLS's, returned measured).
  Eigen::VectorXd goal_error, goal_error_trial, goal_error_best;
  Eigen::VectorXd row_vec_a, row_vec_b;
  Eigen::VectorXd step;           // dofs
  Eigen::VectorXd dof_vec_a, dof_vec_b, dof_scale;
  Eigen::VectorXd params_trial, params_best, params_backup;
  Eigen::VectorXd params_start;   // dofs: a budget-bound solve's start pose, as measured (tree_solve.cpp)
  std::vector<int> goal_order;    // max_goals: goal indices by level
  std::vector<int> active_dofs;   // the DOF of each column
  std::vector<int> dof_column;    // dofs: the column of each DOF, or -1
  std::vector<int> dof_joint;     // dofs: the joint each DOF belongs to (-1: a floating root's translation)
  // Each goal's support columns (row k / 3 in level order) as runs of adjacent columns, root first:
  // goal k's runs are (support_runs[2 r], support_runs[2 r + 1]) = (first column, width) for r in
  // [run_begin[k], run_begin[k + 1]); shared_columns[a * goals + b] (b <= a): how many of goal a's
  // columns, from its first, goals a and b share.
  std::vector<int> support_runs;  // 2 * max_goals * (joints + 1)
  std::vector<int> run_begin;     // max_goals + 1
  std::vector<int> shared_columns;  // max_goals^2
  // What the tree DLS's set-up in goal_order, active_dofs, dof_column, dof_scale, support_runs,
  // run_begin and shared_columns was derived from: the tree's build (Tree::serial; 0: nothing
  // holds, after reset() or another tree solver's use of dof_column and active_dofs), and each
  // goal's effector and level (setup_goals[2 g], [2 g + 1]); setup_columns is its column count.
  // A tracking solve of the same tree and goals skips that set-up.
  uint64_t setup_tree = 0;
  int setup_goal_count = 0, setup_columns = 0;
  std::vector<int> setup_goals;   // 2 * max_goals

  // The weighted-sum solvers (BFGS, CCD, FABRIK; solvers/tree_common.hpp).
  Eigen::MatrixXd dof_square;     // dofs x dofs: BFGS's inverse Hessian (lower triangle)
  Eigen::VectorXd gradient, gradient_trial, gradient_kept, params_kept;  // dofs
  // FABRIK's points, joints + effectors: forward kinematics of the current params, the forward
  // stage (toward the root) and the backward stage (from the root; what the joints are turned to).
  std::vector<glm::dvec3> points_current, points_forward, points_backward;
  std::vector<double> point_weight;                      // joints + effectors
};

// Moves `params` (tree.dof_count() entries) toward the goals. On kInvalidInput params are untouched
// and summary.message names the bad field. Never allocates when workspace.fits(tree, goals.size);
// never throws; never writes a non-finite value to params.
TreeSolveResult solve_tree(SolverKind kind, const Tree& tree, const TreeProblem& problem,
                           const SolverOptions& options, TreeWorkspace& workspace,
                           Eigen::Ref<Eigen::VectorXd> params);

// Auto for trees: the solver to hand solve_tree() for this problem (what an engine layer's "Auto"
// resolves to). The rule (docs/full-body.md, "Which solver"): DLS whenever the problem uses more
// than one priority level or a posture (the only solver with strict priorities and a null-space
// posture); with one level and no posture too, since no other tree solver converges more often on
// the test humanoid (tree_solvers_test.cpp) and DLS is the fastest and most accurate on the body
// benchmark.
SolverKind auto_tree_solver(const Tree& tree, const TreeProblem& problem);

// The checks solve_tree() makes first; empty when all is well.
Message validate_tree_inputs(SolverKind kind, const Tree& tree, const TreeProblem& problem,
                             const SolverOptions& options, const TreeWorkspace& workspace,
                             const Eigen::Ref<const Eigen::VectorXd>& params);

// Forward kinematics of a tree: fills ws.joint_origins, joint_orientations, joint_pre_rotations.
void tree_forward_kinematics(const Tree& tree, const double* params, TreeWorkspace& ws);
glm::dvec3 tree_effector_position(const Tree& tree, const TreeWorkspace& ws, int effector);
glm::dquat tree_effector_orientation(const Tree& tree, const TreeWorkspace& ws, int effector);
// One goal's error vector (desired - current, unweighted) after tree_forward_kinematics().
glm::dvec3 tree_goal_error(const Tree& tree, const TreeWorkspace& ws, const Goal& goal);
// Joint-space limits on every joint of the tree; within_tree_limits: within `slack` (rad, m).
void project_tree_to_limits(const Tree& tree, double* params);
bool within_tree_limits(const Tree& tree, const double* params, double slack = 1e-9);

}  // namespace ikchain
