#include "core/solve.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/kinematics.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {

const char* to_string(TerminationReason reason) {
  switch (reason) {
    case TerminationReason::kConverged: return "converged";
    case TerminationReason::kMaxIterations: return "max_iterations";
    case TerminationReason::kStalled: return "stalled";
    case TerminationReason::kUnreachable: return "unreachable";
    case TerminationReason::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

namespace {

bool finite3(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

bool params_finite(const Eigen::Ref<const Eigen::VectorXd>& p) { return p.allFinite(); }

// A non-converged stop is "unreachable" when the pose is a best reach: either the only goal is a
// tip position beyond the chain's length and the tip is as close as the chain's length allows
// (within position_tolerance), or the objective's gradient J^T e vanishes (a stationary point with
// error left). Limits make constrained optima non-stationary: those stay "stalled".
// Needs ws to hold the forward kinematics of params, and `err` their measured errors (solve() has
// both at hand for the final pose).
bool is_best_reach(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                   Workspace& ws, const double* params, const GoalErrors& err) {
  if (goals.size == 1 && goals[0].kind == GoalKind::kPosition &&
      resolve_effector(chain, goals[0].effector) == chain.joint_count()) {
    const double dist = glm::length(goals[0].target_position - chain.root_in_base());
    const double best = dist - chain.total_length();
    if (best > options.position_tolerance) return err.max_position <= best + options.position_tolerance;
  }
  if (chain.any_limits()) return false;
  const int rows = 3 * goals.size;
  compute_dof_axes(chain, params, ws);
  auto J = ws.jacobian.topRows(rows);
  auto e = ws.residual.head(rows);
  evaluate_goals(chain, goals, ws, e);
  compute_jacobian(chain, goals, ws, J);
  ws.gradient.noalias() = J.transpose() * e;
  const double scale = chain.total_length() * err.combined;
  return ws.gradient.norm() <= 1e-6 * scale;
}

// The pole as a soft preference (SolverOptions::use_pole), for every solver but two-bone (which
// builds its bend plane from the pole). After the solve the chain is swivelled about an axis
// through the root joint's origin o_0 so that its middle joints turn toward the pole, with a move
// that leaves the goals' effectors where they are:
//  - goals only on the tip, all of them positions: the root joint turns about the root -> tip axis
//    (the tip is on the axis, so it stays put);
//  - goals only on the tip, some of them orientations or aims, and a ball last joint: the root
//    joint turns about the root -> o_{n-1} axis (the "wrist" stays put) and the last joint turns
//    back by the inverse, so the tip frame keeps its position and orientation (the elbow swivel
//    of 7-DOF arms).
// The angle is the one taking the middle joints' (1 .. n-2) mean offset from the axis onto the
// pole's direction from it. Nothing happens when the root is a hinge (it can only turn about its own
// axis, which fixes the plane the chain bends in: the solver's pose stays), when a goal sits on an
// intermediate effector (the swivel would move it), when the chain or the pole lies on the axis,
// or when the swivelled pose is worse than the solver's (a limit clipped the turn): the pole never
// costs accuracy. Returns true when params changed (ws then holds their forward kinematics).
bool apply_pole(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, Workspace& ws, double* params) {
  const int n = chain.joint_count();
  if (!o.use_pole || n < 2 || chain.joint_type(0) != JointType::kBall) return false;
  bool positions_only = true;
  for (int i = 0; i < goals.size; ++i) {
    if (resolve_effector(chain, goals[i].effector) != n) return false;
    positions_only = positions_only && goals[i].kind == GoalKind::kPosition;
  }
  const bool wrist_pivot = !positions_only;
  if (wrist_pivot && (n < 3 || chain.joint_type(n - 1) != JointType::kBall)) return false;
  forward_kinematics(chain, params, ws);
  const GoalErrors before = measure_goals(chain, goals, ws);
  const double length = chain.total_length();
  const glm::dvec3 root = ws.joint_origins[0];
  const glm::dvec3 pivot = wrist_pivot ? ws.joint_origins[n - 1] : ws.tip;
  const double axis_length = glm::length(pivot - root);
  if (!(axis_length > 1e-9 * length)) return false;
  const glm::dvec3 axis = (pivot - root) / axis_length;
  // The middle: joints 1 .. n-2 (the last joint is the wrist or sits next to the tip), or joint 1
  // of a two-joint chain.
  const int middle_end = std::max(n - 1, 2);
  glm::dvec3 middle(0.0);
  for (int k = 1; k < middle_end; ++k) {
    const glm::dvec3 d = ws.joint_origins[k] - root;
    middle += d - axis * glm::dot(d, axis);
  }
  glm::dvec3 middle_side, pole_side;
  if (!geometric::perpendicular_part(middle, axis, 1e-9 * length, middle_side) ||
      !geometric::perpendicular_part(o.pole_in_base - root, axis, 1e-9 * length, pole_side))
    return false;
  const double angle = std::atan2(glm::dot(axis, glm::cross(middle_side, pole_side)), glm::dot(middle_side, pole_side));
  if (std::abs(angle) < 1e-12) return false;
  const int dofs = chain.dof_count();
  std::copy(params, params + dofs, ws.params_trial.data());
  const glm::dquat last_frame = ws.joint_orientations[n - 1];
  geometric::turn_ball(chain, 0, ws.joint_pre_rotations[0], glm::angleAxis(angle, axis), 0.0, params);
  if (wrist_pivot) {
    forward_kinematics(chain, params, ws);
    // Q_{n-1} = pre_{n-1} R_{n-1}: the local rotation that gives the last joint its old frame back.
    const glm::dquat local = glm::normalize(glm::conjugate(ws.joint_pre_rotations[n - 1]) * last_frame);
    geometric::set_ball_param(params, chain.dof_offset(n - 1), so3::log(local));
    project_joint_to_limits(chain, n - 1, params);
  }
  forward_kinematics(chain, params, ws);
  const GoalErrors after = measure_goals(chain, goals, ws);
  const bool kept_tolerance = after.within(o) || !before.within(o);
  if (kept_tolerance && after.max_position <= before.max_position + 1e-12 * length &&
      after.max_orientation <= before.max_orientation + 1e-12)
    return true;
  std::copy(ws.params_trial.data(), ws.params_trial.data() + dofs, params);
  forward_kinematics(chain, params, ws);
  return false;
}

}  // namespace

Message validate_inputs(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        const Workspace& ws, const Eigen::Ref<const Eigen::VectorXd>& params) {
  if (!chain.valid()) return Message::format("chain is not built (0 joints or a failed build)");
  Message m = options.validate();
  if (!m.empty()) return m;
  if (goals.size <= 0 || goals.data == nullptr) return Message::format("goals: at least one goal is required");
  if (!ws.fits(chain, goals.size))
    return Message::format("workspace was sized for %d joints/%d goals; reset it for this chain (%d joints) "
                           "and %d goals", ws.joints, ws.max_goals, chain.joint_count(), goals.size);
  if (params.size() != chain.dof_count())
    return Message::format("params has %d entries, the chain has %d DOF", static_cast<int>(params.size()),
                           chain.dof_count());
  if (!params_finite(params)) return Message::format("params contain NaN or inf");
  for (int i = 0; i < goals.size; ++i) {
    const Goal& g = goals[i];
    if (!(std::isfinite(g.weight) && g.weight > 0.0))
      return Message::format("goal %d: weight must be > 0, got %g", i, g.weight);
    if (g.effector < 0 || g.effector > chain.joint_count())
      return Message::format("goal %d: effector must be in 0..%d, got %d", i, chain.joint_count(), g.effector);
    switch (g.kind) {
      case GoalKind::kPosition:
        if (!finite3(g.target_position)) return Message::format("goal %d: target_position is not finite", i);
        break;
      case GoalKind::kOrientation: {
        const glm::dquat& q = g.target_orientation;
        const double len = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
        if (!std::isfinite(len) || len < 1e-9)
          return Message::format("goal %d: target_orientation must be a finite non-zero quaternion", i);
        break;
      }
      case GoalKind::kAim:
        if (!finite3(g.aim_axis) || glm::length(g.aim_axis) < 1e-9)
          return Message::format("goal %d: aim_axis must be a finite non-zero vector", i);
        if (!finite3(g.aim_direction) || glm::length(g.aim_direction) < 1e-9)
          return Message::format("goal %d: aim_direction must be a finite non-zero vector", i);
        break;
      case GoalKind::kAimAt:
        if (!finite3(g.aim_axis) || glm::length(g.aim_axis) < 1e-9)
          return Message::format("goal %d: aim_axis must be a finite non-zero vector", i);
        if (!finite3(g.target_position))
          return Message::format("goal %d: target_position (the point to aim at) is not finite", i);
        break;
      default:
        return Message::format("goal %d: unknown kind", i);
    }
  }
  return Message();
}

SolveResult solve(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                  Workspace& ws, Eigen::Ref<Eigen::VectorXd> params) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  SolveResult result;
  auto finish = [&]() -> SolveResult {
    result.elapsed_us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
    return result;
  };

  result.message = validate_inputs(chain, goals, options, ws, params);
  if (!result.message.empty()) {
    result.reason = TerminationReason::kInvalidInput;
    return finish();
  }
  ws.params_backup = params;
  ws.deadline.start(options.time_budget_usec, ws.deadline.now_us());
  double* p = params.data();

  // The start pose: the current one (warm start) or the rest pose, made feasible. It is measured
  // here unless the solver measures it itself (solver_measures_start).
  if (!options.warm_start) params.setZero();
  project_to_limits(chain, p);
  GoalErrors err;
  SolverStatus status;
  const bool self_measured = solver_measures_start(kind);
  if (!self_measured) {
    forward_kinematics(chain, p, ws);
    err = measure_goals(chain, goals, ws);
  }

  if (!self_measured && err.within(options)) {
    status.reason = TerminationReason::kConverged;
  } else {
    switch (kind) {
      case SolverKind::kTwoBone: status = solve_two_bone(chain, goals, options, ws, p); break;
      case SolverKind::kCCD: status = solve_ccd(chain, goals, options, ws, p); break;
      case SolverKind::kJacobianPinv: status = solve_jacobian_pinv(chain, goals, options, ws, p); break;
      case SolverKind::kDLS: status = solve_dls(chain, goals, options, ws, p); break;
      case SolverKind::kBFGS: status = solve_bfgs(chain, goals, options, ws, p); break;
      case SolverKind::kFABRIK: status = solve_fabrik(chain, goals, options, ws, p); break;
      default:
        status.reason = TerminationReason::kInvalidInput;
        status.message = Message::format("solver kind %d is unknown", static_cast<int>(kind));
    }
  }
  const GoalErrors& start_err = self_measured ? status.start : err;
  result.initial_error = start_err.combined;
  result.initial_position_error = start_err.max_position;
  result.initial_orientation_error = start_err.max_orientation;
  result.iterations = status.iterations;
  result.reason = status.reason;
  result.message = status.message;

  bool restored = false;
  if (status.reason == TerminationReason::kInvalidInput || !params.allFinite()) {
    // Nothing non-finite ever reaches the caller: the pose goes back to what it was.
    params = ws.params_backup;
    restored = true;
    if (status.reason != TerminationReason::kInvalidInput) {
      result.reason = TerminationReason::kStalled;
      result.message = Message::format("%s produced a non-finite pose; the input pose was kept",
                                       to_string(kind));
    }
  }

  // The final pose's errors: the solver's own measurement when it is of exactly these params and
  // within tolerance (nothing more to classify), else measured here.
  bool posed = false;
  if (!restored && status.reason != TerminationReason::kInvalidInput && kind != SolverKind::kTwoBone)
    posed = apply_pole(chain, goals, options, ws, p);
  result.budget_exhausted = ws.deadline.hit;

  const bool trust_final = status.final_measured && !restored && !posed && status.final.within(options);
  if (trust_final) {
    err = status.final;
  } else {
    forward_kinematics(chain, p, ws);
    err = measure_goals(chain, goals, ws);
  }
  result.final_error = err.combined;
  result.final_position_error = err.max_position;
  result.final_orientation_error = err.max_orientation;
  if (result.reason != TerminationReason::kInvalidInput) {
    if (err.within(options))
      result.reason = TerminationReason::kConverged;
    else if (is_best_reach(chain, goals, options, ws, p, err))
      result.reason = TerminationReason::kUnreachable;
    else if (result.reason == TerminationReason::kConverged)
      result.reason = TerminationReason::kStalled;  // a claim the measurement does not confirm
  }
  return finish();
}

}  // namespace ikchain
