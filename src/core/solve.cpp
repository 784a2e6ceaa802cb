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

// Every component finite and within +-kMaxMagnitude (false for NaN).
bool bounded3(const glm::dvec3& v) {
  return std::abs(v.x) <= kMaxMagnitude && std::abs(v.y) <= kMaxMagnitude && std::abs(v.z) <= kMaxMagnitude;
}

// The start pose solve() defines: the caller's params (warm start) or the rest pose, projected onto
// the limits. Recomputed from the backup when a solve must fall back to it.
void make_start_pose(const Chain& chain, const SolverOptions& options, Eigen::Ref<Eigen::VectorXd> params) {
  if (!options.warm_start) params.setZero();
  project_to_limits(chain, params.data());
}

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
  if (!params.allFinite()) return Message::format("params contain NaN or inf");
  for (int i = 0; i < params.size(); ++i) {
    // A ball joint's rotation vector beyond ~1e154 has an infinite squared angle: NaN in FK.
    if (!(std::abs(params[i]) <= kMaxMagnitude))
      return Message::format("params[%d] is %g: joint parameters must be within +-%g rad", i, params[i],
                             kMaxMagnitude);
  }
  for (int i = 0; i < goals.size; ++i) {
    const Goal& g = goals[i];
    if (!(g.weight > 0.0 && g.weight <= kMaxWeight))
      return Message::format("goal %d: weight must be > 0 and <= %g, got %g", i, kMaxWeight, g.weight);
    if (g.effector < 0 || g.effector > chain.joint_count())
      return Message::format("goal %d: effector must be in 0..%d, got %d", i, chain.joint_count(), g.effector);
    switch (g.kind) {
      case GoalKind::kPosition:
        if (!bounded3(g.target_position))
          return Message::format("goal %d: target_position (%g, %g, %g) must be finite, each component within "
                                 "+-%g m", i, g.target_position.x, g.target_position.y, g.target_position.z,
                                 kMaxMagnitude);
        break;
      case GoalKind::kOrientation: {
        const glm::dquat& q = g.target_orientation;
        const double len = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
        if (!std::isfinite(len) || len < 1e-9)
          return Message::format("goal %d: target_orientation must be a finite non-zero quaternion", i);
        break;
      }
      case GoalKind::kAim:
        // Bounded: normalising (1e200, 0, 0) divides by an infinite length and gives the zero vector,
        // which would read as "aim met".
        if (!bounded3(g.aim_axis) || glm::length(g.aim_axis) < 1e-9)
          return Message::format("goal %d: aim_axis must be a non-zero vector, each component within +-%g", i,
                                 kMaxMagnitude);
        if (!bounded3(g.aim_direction) || glm::length(g.aim_direction) < 1e-9)
          return Message::format("goal %d: aim_direction must be a non-zero vector, each component within +-%g", i,
                                 kMaxMagnitude);
        break;
      default:
        return Message::format("goal %d: unknown kind", i);
    }
  }
  return Message();
}

Message validate_inputs(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        const Workspace& ws, const Eigen::Ref<const Eigen::VectorXd>& params) {
  Message m = validate_inputs(chain, goals, options, ws, params);
  if (!m.empty()) return m;
  switch (kind) {
    case SolverKind::kTwoBone:
      if (chain.joint_count() != 2)
        return Message::format("two_bone needs a chain of exactly 2 joints, got %d", chain.joint_count());
      if (goals.size != 1 || goals[0].kind != GoalKind::kPosition || resolve_effector(chain, goals[0].effector) != 2)
        return Message::format(
            "two_bone takes exactly 1 goal, a position goal on the tip (effector 0 or 2); got %d goal(s)",
            goals.size);
      break;
    case SolverKind::kCCD:
      if (goals.size > kCcdMaxGoals)
        return Message::format("ccd supports at most %d goals, got %d", kCcdMaxGoals, goals.size);
      break;
    case SolverKind::kJacobianPinv:
    case SolverKind::kDLS:
    case SolverKind::kBFGS:
    case SolverKind::kFABRIK:
      break;
    default:
      return Message::format("solver kind %d is unknown (0..%d)", static_cast<int>(kind), kSolverKindCount - 1);
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

  result.message = validate_inputs(kind, chain, goals, options, ws, params);
  if (!result.message.empty()) {
    result.reason = TerminationReason::kInvalidInput;
    return finish();
  }
  ws.params_backup = params;
  double* p = params.data();

  // The start pose: the current one (warm start) or the rest pose, made feasible. It is measured
  // here unless the solver measures it itself (solver_measures_start).
  make_start_pose(chain, options, params);
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
  const GoalErrors start_err = self_measured ? status.start : err;
  result.initial_error = start_err.combined;
  result.initial_position_error = start_err.max_position;
  result.initial_orientation_error = start_err.max_orientation;
  result.iterations = status.iterations;
  result.reason = status.reason;
  result.message = status.message;

  bool restored = false;
  if (status.reason == TerminationReason::kInvalidInput) {
    params = ws.params_backup;  // untouched, as promised for invalid input
    restored = true;
  } else if (!params.allFinite()) {
    // Nothing non-finite ever reaches the caller: back to the start pose (finite and within the
    // limits; the caller's own pose may violate them).
    params = ws.params_backup;
    make_start_pose(chain, options, params);
    restored = true;
    result.reason = TerminationReason::kStalled;
    result.message = Message::format("%s produced a non-finite pose; the start pose was kept", to_string(kind));
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
  if (!restored && !(err.cost <= start_err.cost)) {
    // Never worse than the start by the solve's own objective (or non-finite): a solver that ends
    // above it (the pseudo-inverse stalling on an unreachable target with a limited root did) gives
    // the start pose back.
    params = ws.params_backup;
    make_start_pose(chain, options, params);
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
