#include "core/solve.hpp"

#include <chrono>
#include <cmath>

#include "core/kinematics.hpp"
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
  const bool trust_final = status.final_measured && !restored && status.final.within(options);
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
