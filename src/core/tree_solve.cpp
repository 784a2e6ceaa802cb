#include "ikchain/tree_solve.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/kinematics_internal.hpp"
#include "ikchain/so3.hpp"
#include "ikchain/solve.hpp"
#include "core/solvers/tree_solvers.hpp"

namespace ikchain {

void TreeWorkspace::reset(const Tree& tree, int goals) {
  joints = tree.joint_count();
  dofs = tree.dof_count();
  max_goals = std::max(goals, 1);
  const int rows = 3 * max_goals;
  joint_origins.assign(joints, glm::dvec3(0.0));
  joint_orientations.assign(joints, glm::dquat(1.0, 0.0, 0.0, 0.0));
  joint_pre_rotations.assign(joints, glm::dquat(1.0, 0.0, 0.0, 0.0));
  dof_axes.assign(dofs, glm::dvec3(0.0));
  jacobian.setZero(rows, dofs);
  row_square.setZero(rows, rows);
  row_factor.setZero(rows, rows);
  gram_factor.setZero(rows, rows);
  coupling.setZero(rows, rows);
  residual.setZero(rows);
  residual_trial.setZero(rows);
  goal_error.setZero(max_goals);
  goal_error_trial.setZero(max_goals);
  goal_error_best.setZero(max_goals);
  row_vec_a.setZero(rows);
  row_vec_b.setZero(rows);
  step.setZero(dofs);
  dof_vec_a.setZero(dofs);
  dof_vec_b.setZero(dofs);
  dof_scale.setZero(dofs);
  params_trial.setZero(dofs);
  params_best.setZero(dofs);
  params_backup.setZero(dofs);
  params_start.setZero(dofs);
  goal_order.assign(max_goals, 0);
  active_dofs.assign(dofs, 0);
  dof_column.assign(dofs, -1);
  dof_joint.assign(dofs, -1);
  support_runs.assign(2 * max_goals * (joints + 1), 0);
  run_begin.assign(max_goals + 1, 0);
  shared_columns.assign(max_goals * max_goals, 0);
  setup_tree = 0;
  setup_goals.assign(2 * max_goals, -1);
  dof_square.setZero(dofs, dofs);
  gradient.setZero(dofs);
  gradient_trial.setZero(dofs);
  gradient_kept.setZero(dofs);
  params_kept.setZero(dofs);
  const int points = joints + tree.effector_count();
  points_current.assign(points, glm::dvec3(0.0));
  points_forward.assign(points, glm::dvec3(0.0));
  points_backward.assign(points, glm::dvec3(0.0));
  point_weight.assign(points, 0.0);
  for (int j = 0; j < joints; ++j)
    for (int d = 0; d < tree.dof_count_of(j); ++d) dof_joint[tree.dof_offset(j) + d] = j;
}

bool TreeWorkspace::fits(const Tree& tree, int goal_count) const {
  return joints == tree.joint_count() && dofs == tree.dof_count() && goal_count <= max_goals &&
         points_current.size() == static_cast<size_t>(joints + tree.effector_count());
}

void tree_forward_kinematics(const Tree& tree, const double* params, TreeWorkspace& ws) {
  const int n = tree.joint_count();
  for (int i = 0; i < n; ++i) {
    const int p = tree.parent(i);
    const glm::dquat parent_q = p < 0 ? glm::dquat(1.0, 0.0, 0.0, 0.0) : ws.joint_orientations[p];
    glm::dvec3 origin = p < 0 ? tree.offset_in_parent(i) : ws.joint_origins[p] + parent_q * tree.offset_in_parent(i);
    if (i == 0 && tree.floating_root()) origin += glm::dvec3(params[0], params[1], params[2]);
    const glm::dquat pre = parent_q * tree.rest_rotation(i);
    const double* q = params + tree.dof_offset(i);
    glm::dquat orientation = pre;
    if (turns(tree.joint_type(i)))
      orientation = pre * joint_rotation(tree.joint_type(i), tree.axis(i), q);
    else  // the slide shifts this joint's frame, so its children and effectors (tree.hpp)
      origin += pre * (tree.axis(i) * q[0]);
    ws.joint_origins[i] = origin;
    ws.joint_pre_rotations[i] = pre;
    ws.joint_orientations[i] = orientation;
  }
  ws.deadline.charge(Deadline::kFlopsPerJoint * n);
}

glm::dvec3 tree_effector_position(const Tree& tree, const TreeWorkspace& ws, int effector) {
  const TreeEffectorDesc& e = tree.effector(effector);
  return ws.joint_origins[e.joint] + ws.joint_orientations[e.joint] * e.offset;
}

glm::dquat tree_effector_orientation(const Tree& tree, const TreeWorkspace& ws, int effector) {
  const TreeEffectorDesc& e = tree.effector(effector);
  return ws.joint_orientations[e.joint] * e.rotation;
}

double tree_aim_at_on_point(const Tree& tree, const Goal& g) {
  return g.kind == GoalKind::kAimAt ? kAimAtOnPoint * (tree.total_length() + glm::length(g.target_position)) : 0.0;
}

namespace {
const auto on_point_radius = tree_aim_at_on_point;
}  // namespace

glm::dvec3 tree_goal_error(const Tree& tree, const TreeWorkspace& ws, const Goal& g) {
  // Only what the goal's kind reads (goal_error_at): a position goal no orientation, an
  // orientation or aim goal no position.
  const bool position = g.kind == GoalKind::kPosition || g.kind == GoalKind::kAimAt;
  const bool orientation = g.kind != GoalKind::kPosition;
  return goal_error_at(g, position ? tree_effector_position(tree, ws, g.effector) : glm::dvec3(0.0),
                       orientation ? tree_effector_orientation(tree, ws, g.effector) : glm::dquat(1.0, 0.0, 0.0, 0.0),
                       on_point_radius(tree, g));
}

void tree_dof_axes(const Tree& tree, const double* params, TreeWorkspace& ws, bool active_only) {
  if (tree.floating_root()) {
    ws.dof_axes[0] = glm::dvec3(1.0, 0.0, 0.0);
    ws.dof_axes[1] = glm::dvec3(0.0, 1.0, 0.0);
    ws.dof_axes[2] = glm::dvec3(0.0, 0.0, 1.0);
  }
  for (int i = 0; i < tree.joint_count(); ++i) {
    const int o = tree.dof_offset(i);
    if (active_only && (tree.dof_count_of(i) == 0 || ws.dof_column[o] < 0)) continue;
    const glm::dquat& pre = ws.joint_pre_rotations[i];
    if (is_one_dof(tree.joint_type(i))) {
      ws.dof_axes[o] = pre * tree.axis(i);
    } else {
      const glm::dmat3 jl = so3::left_jacobian(glm::dvec3(params[o], params[o + 1], params[o + 2]));
      for (int k = 0; k < 3; ++k) ws.dof_axes[o + k] = pre * jl[k];
    }
  }
}

GoalLinearization tree_linearize_goal(const Tree& tree, const TreeWorkspace& ws, const Goal& g) {
  GoalLinearization lin;
  lin.point = tree_effector_position(tree, ws, g.effector);
  if (g.kind == GoalKind::kAim || g.kind == GoalKind::kAimAt)
    lin.aim_axis = glm::normalize(tree_effector_orientation(tree, ws, g.effector) * g.aim_axis);
  if (g.kind == GoalKind::kAimAt) {
    const glm::dvec3 d = g.target_position - lin.point;
    lin.distance = glm::length(d);
    lin.aim_at_defined = lin.distance > on_point_radius(tree, g);
    if (lin.aim_at_defined) lin.direction = d / lin.distance;
  }
  return lin;
}

glm::dvec3 tree_jacobian_column(const Tree& tree, const TreeWorkspace& ws, const Goal& g, const GoalLinearization& lin,
                                int dof) {
  const bool root_translation = tree.floating_root() && dof < 3;
  const int j = root_translation ? 0 : ws.dof_joint[dof];
  if (!tree.supports(g.effector, j)) return glm::dvec3(0.0);
  if (root_translation || !turns(tree.joint_type(j)))
    return translation_column(g.kind, ws.dof_axes[dof], lin);
  return rotation_column(g.kind, ws.dof_axes[dof], lin.point - ws.joint_origins[j], lin);
}

TreeErrors tree_measure(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                        const TreeWorkspace& ws, const int* goal_order, double* residual, double* goal_error) {
  TreeErrors out;
  out.level_met.fill(true);
  for (int k = 0; k < problem.goals.size; ++k) {
    const int gi = goal_order ? goal_order[k] : k;
    const TreeGoal& tg = problem.goals[gi];
    const glm::dvec3 e = tree_goal_error(tree, ws, tg.goal);
    const double len2 = glm::dot(e, e);
    const double len = std::sqrt(len2);
    const bool position = tg.goal.kind == GoalKind::kPosition;
    double& worst = position ? out.max_position : out.max_orientation;
    if (len > worst || std::isnan(len)) worst = len;  // a NaN must never read as met
    const double tolerance = position ? options.position_tolerance : options.orientation_tolerance;
    if (!(len <= tolerance)) out.level_met[tg.level - 1] = false;
    out.level_cost[tg.level - 1] += 0.5 * tg.goal.weight * len2;
    if (residual) {
      const double sw = std::sqrt(tg.goal.weight);
      residual[3 * k] = sw * e.x;
      residual[3 * k + 1] = sw * e.y;
      residual[3 * k + 2] = sw * e.z;
    }
    if (goal_error) goal_error[gi] = len;
  }
  for (double c : out.level_cost) out.cost += c;
  return out;
}

bool ball_surely_inside(const JointLimits& l, const double* p) {
  const double angle = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  return (!l.has_cone_limit || angle < l.cone_angle) &&
         (!l.has_twist_limit || (angle < l.twist_max && -angle > l.twist_min));
}

void project_tree_to_limits(const Tree& tree, double* params) {
  for (int i = 0; i < tree.joint_count(); ++i) {
    if (!tree.has_limits(i)) continue;
    const JointLimits& l = tree.limits(i);
    double* p = params + tree.dof_offset(i);
    // Most joints are surely inside: they skip the projection's exp, swing-twist and log.
    if (tree.joint_type(i) == JointType::kBall && ball_surely_inside(l, p)) continue;
    project_joint_params(tree.joint_type(i), l, p);
  }
}

bool within_tree_limits(const Tree& tree, const double* params, double slack) {
  for (int i = 0; i < tree.joint_count(); ++i)
    if (!joint_within_limits(tree.joint_type(i), tree.limits(i), params + tree.dof_offset(i), slack)) return false;
  return true;
}

SolverKind auto_tree_solver(const Tree&, const TreeProblem&) { return SolverKind::kDLS; }

Message validate_tree_inputs(SolverKind kind, const Tree& tree, const TreeProblem& problem,
                             const SolverOptions& options, const TreeWorkspace& ws,
                             const Eigen::Ref<const Eigen::VectorXd>& params) {
  if (!tree.valid()) return Message::format("tree is not built (TreeBuilder::build failed or was not called)");
  const int solver = static_cast<int>(kind);
  if (solver < 0 || solver >= kSolverKindCount) return Message::format("unknown solver kind %d", solver);
  const SolverInfo& info = solver_info(kind);
  if (!info.trees)
    return Message::format("solver %s does not solve trees; use %s", to_string(kind), to_string(SolverKind::kDLS));
  if (!info.prismatic_joints)
    for (int j = 0; j < tree.joint_count(); ++j)
      if (!turns(tree.joint_type(j)))
        return Message::format("%s turns joints only; joint %d is prismatic: use dls or bfgs", info.id, j);
  Message m = options.validate();
  if (!m.empty()) return m;
  if (options.max_restarts > 0)
    return Message::format("max_restarts (%d): tree solves take no restarts yet; set it to 0", options.max_restarts);
  if (options.use_pole)
    return Message::format("use_pole: tree solves take no pole; aim a goal (kAimAt) at the pole instead");
  if (problem.goals.size > kMaxTreeGoals)
    return Message::format("%d goals: a tree solve takes at most %d", problem.goals.size, kMaxTreeGoals);
  if (params.size() != tree.dof_count())
    return Message::format("params has %d entries, the tree has %d DOFs", static_cast<int>(params.size()),
                           tree.dof_count());
  if (!ws.fits(tree, problem.goals.size))
    return Message::format("workspace does not fit this tree and %d goals: call TreeWorkspace::reset(tree, %d)",
                           problem.goals.size, problem.goals.size);
  for (int i = 0; i < params.size(); ++i)
    if (!(std::abs(params[i]) <= kMaxMagnitude))
      return Message::format("params[%d] (%g) must be finite, within +-%g", i, params[i], kMaxMagnitude);
  for (int i = 0; i < problem.goals.size; ++i) {
    const TreeGoal& tg = problem.goals[i];
    const Goal& g = tg.goal;
    if (tg.level < 1 || tg.level > kMaxPriorityLevels)
      return Message::format("goal %d: level (%d) must be in [1, %d] (1 = highest priority)", i, tg.level,
                             kMaxPriorityLevels);
    if (g.effector < 0 || g.effector >= tree.effector_count())
      return Message::format("goal %d: effector (%d) must be in [0, %d)", i, g.effector, tree.effector_count());
    Message goal = validate_goal(g, i);
    if (!goal.empty()) return goal;
  }
  const int n = tree.dof_count();
  if (problem.posture_iterations < 0)
    return Message::format("posture_iterations must be >= 0 (0 = until the posture settles), got %d",
                           problem.posture_iterations);
  if (!problem.posture.empty() && problem.posture.size != n)
    return Message::format("posture has %d entries, the tree has %d DOFs (or leave it empty)", problem.posture.size, n);
  if (!problem.posture_stiffness.empty()) {
    if (problem.posture.empty())
      return Message::format("posture_stiffness is set without a posture: set posture too");
    if (problem.posture_stiffness.size != n)
      return Message::format("posture_stiffness has %d entries, the tree has %d DOFs", problem.posture_stiffness.size,
                             n);
  }
  for (int i = 0; i < problem.posture.size; ++i)
    if (!(std::abs(problem.posture[i]) <= kMaxMagnitude))
      return Message::format("posture[%d] (%g) must be finite, within +-%g", i, problem.posture[i], kMaxMagnitude);
  for (int i = 0; i < problem.posture_stiffness.size; ++i)
    if (!(problem.posture_stiffness[i] >= 0.0 && problem.posture_stiffness[i] <= 1.0))
      return Message::format("posture_stiffness[%d] must be in [0, 1], got %g", i, problem.posture_stiffness[i]);
  return Message();
}

namespace {

// The tree solvers, by kind (the rows of the solver table whose `trees` column is true; the
// validation refused every other kind by name).
TreeSolverStatus run_tree_solver(SolverKind kind, const Tree& tree, const TreeProblem& problem,
                                 const SolverOptions& options, TreeWorkspace& ws, double* params,
                                 const TreeErrors& start) {
  switch (kind) {
    case SolverKind::kBFGS: return solve_tree_bfgs(tree, problem, options, ws, params);
    case SolverKind::kCCD: return solve_tree_ccd(tree, problem, options, ws, params);
    case SolverKind::kFABRIK: return solve_tree_fabrik(tree, problem, options, ws, params);
    default: return solve_tree_dls(tree, problem, options, ws, params, start);
  }
}

}  // namespace

TreeSolveResult solve_tree(SolverKind kind, const Tree& tree, const TreeProblem& problem,
                           const SolverOptions& options, TreeWorkspace& ws, Eigen::Ref<Eigen::VectorXd> params) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  TreeSolveResult result;
  SolveResult& summary = result.summary;
  auto finish = [&]() -> TreeSolveResult {
    summary.elapsed_us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
    return result;
  };
  summary.message = validate_tree_inputs(kind, tree, problem, options, ws, params);
  if (!summary.message.empty()) {
    summary.reason = TerminationReason::kInvalidInput;
    return finish();
  }
  result.goal_count = problem.goals.size;
  ws.params_backup = params;
  // The budget and the safety cap (SolverOptions::time_cap_usec), as solve() arms them.
  const bool budgeted = options.time_budget_usec > 0.0;
  ws.deadline.start(options.time_budget_usec, budgeted ? ws.deadline.now_us() : 0.0, options.time_cap_usec);
  if (!options.warm_start) params.setZero();
  project_tree_to_limits(tree, params.data());

  // A budget can stop a solve before it moves: then the start pose comes back, already measured
  // (its per-goal errors too), and the exit work measures it no second time (below).
  if (budgeted) ws.params_start = params;
  tree_forward_kinematics(tree, params.data(), ws);
  // With the residual rows and the goals' errors: the DLS takes this measure over (and with no
  // solver to run, it is the result's).
  const TreeErrors start_errors =
      tree_measure(tree, problem, options, ws, nullptr, ws.residual_trial.data(), ws.goal_error.data());
  if (budgeted) std::copy(ws.goal_error.data(), ws.goal_error.data() + problem.goals.size, result.goal_error.data());
  summary.initial_error = std::sqrt(2.0 * start_errors.cost);
  summary.initial_position_error = start_errors.max_position;
  summary.initial_orientation_error = start_errors.max_orientation;

  TreeSolverStatus status;
  status.reason = TerminationReason::kConverged;
  status.fk_of_params = true;  // when no solver runs: the start pose's FK and measure above
  status.measured = true;
  status.errors = start_errors;
  // The budget after the set-up, as solve() reads it: gone, or the solver's own set-up would take
  // it past the bound, the start pose comes back, measured (issue 16, item 6).
  if ((!start_errors.all_met() || !problem.posture.empty()) && !ws.deadline.spent_before_solver())
    status = run_tree_solver(kind, tree, problem, options, ws, params.data(), start_errors);
  else if (ws.deadline.hit)
    status.reason = TerminationReason::kMaxIterations;
  summary.iterations = status.iterations;
  summary.escapes = status.escapes;
  summary.reason = status.reason;
  if (!params.allFinite()) {
    status.fk_of_params = false;
    status.measured = false;
    params = ws.params_backup;
    if (!options.warm_start) params.setZero();
    project_tree_to_limits(tree, params.data());
    summary.message = Message::format("%s produced a non-finite pose; the start pose was kept", to_string(kind));
    summary.reason = TerminationReason::kStalled;
  }
  summary.budget_exhausted = ws.deadline.hit;

  // The verdict from the pose returned, measured here: it cannot disagree with the pose. The start
  // pose, bit for bit, was measured at the start by the same code; a solver whose last FK pass was
  // of the pose returned leaves nothing to recompute but the measure, and one that measured the
  // pose returned (the DLS, by the same code) not even that.
  const bool unchanged =
      budgeted && std::memcmp(params.data(), ws.params_start.data(), sizeof(double) * tree.dof_count()) == 0;
  if (!unchanged && !status.fk_of_params) tree_forward_kinematics(tree, params.data(), ws);
  if (!unchanged && status.measured)
    std::copy(ws.goal_error.data(), ws.goal_error.data() + problem.goals.size, result.goal_error.data());
  const TreeErrors final_errors =
      unchanged         ? start_errors
      : status.measured ? status.errors
                        : tree_measure(tree, problem, options, ws, nullptr, nullptr, result.goal_error.data());
  summary.final_error = std::sqrt(2.0 * final_errors.cost);
  summary.final_position_error = final_errors.max_position;
  summary.final_orientation_error = final_errors.max_orientation;
  result.level_met = final_errors.level_met;
  if (final_errors.all_met()) {
    summary.reason = TerminationReason::kConverged;
  } else if (summary.reason == TerminationReason::kConverged) {
    summary.reason = TerminationReason::kStalled;
  }
  if (summary.budget_exhausted && summary.reason == TerminationReason::kStalled)
    summary.reason = TerminationReason::kMaxIterations;
  ws.deadline.finish();  // the exit work's stretch
  return finish();
}

}  // namespace ikchain
