// Jacobian pseudo-inverse with a residual check and step halving.
//
// Each iteration linearises the goals at the current pose, e(theta + dtheta) ~= e - J dtheta, and
// asks for a change de of the residual; the minimum-norm joint step achieving it is
// dtheta = J+ de (Moore-Penrose; Whitney 1969, Buss 2004 sec. 4). J+ comes from the eigen-
// decomposition of the small Gram matrix: J+ = J^T (J J^T)^+ for m < n rows (3 for a position goal,
// so no n x n matrix appears), (J^T J)^+ J^T for m >= n; singular values below
// pinv_singular_threshold count as 0 (jacobian_common.hpp).
//
// Residual check (as in the lecture): the linear model is trusted only for small de. The part of
// de that J can represent at all, J J+ de, is what the step promises; the part it cannot,
// (I - J J+) de, stays unachieved at any step length, so halving cannot change its ratio to |de|
// and it is not the test. What halving does control is the nonlinear miss: the trial pose's
// achieved change vs the promised J J+ de. While |J J+ de - achieved| > pinv_residual_tolerance *
// |J J+ de|, de is halved (at most pinv_max_halvings times). A step is also accepted only if it
// decreases the cost (else halve further), so the method converges instead of oscillating; with
// every check passed at full length, the step is Newton's (Gauss-Newton) and converges
// quadratically. Each new iteration starts from 4x the last accepted fraction of e (capped at
// all of it; see kGrowth).
//
// Additions that make it reach tolerance rather than approach it. Truncation: when the full step
// passes the check only after heavy halving, rank-reduced pseudo-inverses (smallest singular
// directions dropped) are tried too, then the full step once more on the cost alone, and the
// lowest cost wins (see run_pinv). Target clamping: a single tip target beyond reach is replaced
// by the nearest reachable point (see solve_jacobian_pinv).
//
// Singular saddles. Halved pseudo-inverse steps follow the Newton flow, which moves the effector
// along the straight line to the target; when the joint path meets a singular pose on the way, it
// stops there: a hinge folded to +-pi or a straight segment, with the residual along the one
// direction the pose cannot move the effector in to first order (typically a target nearly behind
// the root, the chain folded back over a twisted joint 1). The cost has a saddle there whose way
// down needs a large move (e.g. untwisting joint 1 by ~1 rad). Truncated steps promise nothing,
// the full step passes the residual check only at a tiny fraction of its length, and every
// iteration gains a little more than stall_tolerance: the solve creeps to max_iterations. So
// besides the stall rule, creeping (the shared stall rule's creeping(): kStallIterations accepted
// steps in a row that each lower the cost by less than stuck::kCreepGain of it) also counts as
// stuck, with or without limits and restarts (DLS and BFGS, whose steps do not follow that flow,
// escape a creep only in a minimum the limits hold, stuck::Escapes::creep_is_stuck); the shared
// escape's null-space step toward rest (stuck.hpp) then changes the configuration.
//
// Iterations count accepted (or final failed) steps and escapes; each costs one FK per halving
// tried. Stuck (stuck.hpp): no halving decreases the cost, the stall rule, creeping (above), or a
// vanishing gradient with error left; each calls the shared escape, and with none left the solve
// stops as "stalled" at the best pose seen.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/jacobian_common.hpp"
#include "core/solvers/stuck.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {
namespace {

// Each iteration first tries kGrowth times the last accepted fraction of e (at most all of it):
// a long approach does not repeat the same failed halvings every iteration, and near the goal the
// full (Newton) step is back after a few iterations.
constexpr double kGrowth = 4.0;
// ... and never a step turning a DOF by more than this (rad): near a singularity J+ e is huge (for
// an unreachable target, unbounded), and pinv_max_halvings halvings of it may not get down to the
// fraction of a radian where the linear model holds.
constexpr double kFirstTryAngle = 1.0;
// Singular values below this fraction of |J| (Frobenius) are dropped on the retries after a failed
// full step; 0 = the full pseudo-inverse (only pinv_singular_threshold applies).
// The last entry repeats the full step with the lenient acceptance (cost alone, see run_pinv).
constexpr double kTruncation[] = {0.0, 1e-3, 1e-2, 1e-1, 0.3, 0.0};
constexpr int kTruncationLevels = sizeof(kTruncation) / sizeof(kTruncation[0]);
// A step accepted at this fraction of the full one or more is good enough: no truncation tried.
constexpr double kGoodFraction = 1.0 / 8.0;

template <class Model>
SolverStatus run_pinv(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, Workspace& ws,
                      Model& model, double* params, bool target_clamped) {
  SolverStatus status;
  const int n = chain.dof_count();
  const int active = model.active_dofs();
  ws.step.setZero();            // the full step J+ e (DOFs beyond the farthest effector stay 0)
  ws.gradient_trial.setZero();  // the halved step actually tried

  model.evaluate_start(params);
  model.accept();
  if (model.converged(o)) {
    status.reason = TerminationReason::kConverged;
    return status;
  }
  // The time budget before the first linearisation too (dls.cpp's reason).
  if (ws.deadline.spent()) {
    status.reason = TerminationReason::kMaxIterations;
    return status;
  }
  model.linearize(params);
  double fraction = 1.0;  // the last accepted de / e
  // After an escape (or a query's crossing of a full-turn bound) the full step is tried first again.
  stuck::JacobianLoop loop(chain, goals, o, ws, model, params, [&]() { fraction = 1.0; });
  using stuck::Verdict;
  // Clamped, the target is the best reach of a goal beyond it: being stuck there is no trap.
  if (target_clamped) loop.escapes().disable();
  loop.escape_if_stationary();

  status.reason = TerminationReason::kMaxIterations;
  for (int it = 1; it <= o.max_iterations; ++it) {
    if (ws.deadline.spent()) break;  // the time budget, checked before every iteration: kMaxIterations
    if (model.converged(o)) {  // an escape landed there
      status.reason = TerminationReason::kConverged;
      break;
    }
    status.iterations = it;
    const double cost = model.cost();
    // The full pseudo-inverse first; when no halving of it is accepted, the same with the smallest
    // singular directions truncated (rank-reduced J+, Golub & Van Loan sec. 5.5.4). Near a
    // singular pose (a straight chain, the best reach of an unreachable target) the full step is
    // dominated by the nearly singular direction, and halving can only shrink it, never turn it;
    // the truncated step moves in the directions J can still serve.
    // Each level's step is halved until it passes the residual check. A step that passes only
    // after heavy halving (below kGoodFraction) is what the nearly singular direction does to the
    // full pseudo-inverse, so the next truncation level is tried too, and the candidate with the
    // lowest cost wins. When no level passes at kGoodFraction or more, the full step is tried once
    // more on the cost alone (the lenient final entry of kTruncation): halved from kFirstTryAngle
    // until it beats the best candidate so far, if it does. This is for nearly singular solutions
    // (targets within ~1e-4 L of the workspace boundary): the last 1e-4 of distance needs joint
    // turns ~1/sigma_min times larger, whose second-order motion outgrows the residual, so the
    // check passes only at ~1/16 of the step although longer steps lower the cost more, and the
    // solve converges linearly, a few per cent of the distance per iteration, past max_iterations
    // (the rule's measurement: docs/solvers.md, "Why these constants").
    // Joints on a limit the full step pushes outward leave J for this iteration, at every level
    // (the active set, jacobian::limit_aware_step).
    jacobian::limit_aware_step(chain, model, params, ws.step.data(), [&](double* step) {
      model.pinv_step(o.pinv_singular_threshold, step);
      return 0.0;
    });
    double best_trial_cost = cost, best_s = 0.0, best_threshold = 0.0;
    bool evaluated_is_best = false;
    double last_threshold = -1.0;
    int trials = 0;
    for (int level = 0; level < kTruncationLevels; ++level) {
      const bool lenient = level == kTruncationLevels - 1;
      const double threshold = std::max(o.pinv_singular_threshold, kTruncation[level] * model.jacobian_norm());
      if (!lenient && threshold <= last_threshold) continue;
      last_threshold = threshold;
      model.pinv_step(threshold, ws.step.data());
      const double promised = model.predicted_change_norm();
      double largest = 0.0;
      for (int j = 0; j < active; ++j) largest = std::max(largest, std::abs(ws.step[j]));
      double s = lenient ? 1.0 : std::min(1.0, kGrowth * fraction);
      if (s * largest > kFirstTryAngle) s = kFirstTryAngle / largest;
      evaluated_is_best = false;
      for (int halvings = 0; promised > 0.0; ++halvings) {
        // One iteration can try kTruncationLevels x pinv_max_halvings trials, each an FK pass (15-20
        // us on 180 limited joints): the time budget is read before each but the first, the first
        // of a later level included, or the last iteration overruns it by that many passes.
        if (trials++ > 0 && ws.deadline.spent()) break;
        for (int j = 0; j < active; ++j) ws.gradient_trial[j] = s * ws.step[j];
        jacobian::make_trial(chain, o, params, ws.gradient_trial.data(), ws);
        const double trial_cost = model.evaluate(ws.params_trial.data());
        const bool passes = lenient ? trial_cost < best_trial_cost
                                    : trial_cost < cost &&
                                          model.missed_change(s) / (s * promised) <= o.pinv_residual_tolerance;
        if (passes) {
          if (trial_cost < best_trial_cost) {
            best_trial_cost = trial_cost;
            best_s = s;
            best_threshold = threshold;
            evaluated_is_best = true;
          }
          break;
        }
        if (halvings >= o.pinv_max_halvings) break;
        s *= 0.5;
      }
      if (best_s >= kGoodFraction || ws.deadline.hit) break;
    }
    const bool accepted = best_s > 0.0;
    if (!accepted && ws.deadline.hit) break;  // the time budget: kMaxIterations
    if (!accepted) {  // no halving decreases the cost: stuck
      if (loop.escape()) continue;
      status.reason = TerminationReason::kStalled;
      break;
    }
    if (!evaluated_is_best) {
      // The winner was an earlier level: rebuild its trial (the model holds the latest one).
      model.pinv_step(best_threshold, ws.step.data());
      for (int j = 0; j < active; ++j) ws.gradient_trial[j] = best_s * ws.step[j];
      jacobian::make_trial(chain, o, params, ws.gradient_trial.data(), ws);
      model.evaluate(ws.params_trial.data());
    }
    fraction = best_s;
    std::copy(ws.params_trial.data(), ws.params_trial.data() + n, params);
    model.accept();
    if (model.converged(o)) {
      status.reason = TerminationReason::kConverged;
      break;
    }
    // Every creep escapes (the file comment's singular saddles).
    const Verdict verdict = loop.after_accepted(model.cost(), stuck::Creeps::kEvery);
    if (verdict == Verdict::kMoved) continue;
    if (verdict == Verdict::kStalled) {
      status.reason = TerminationReason::kStalled;
      break;
    }
    if (ws.deadline.spent()) break;  // before the next linearisation, as before the first
    model.linearize(params);
    loop.escape_if_stationary();
  }
  loop.finish(status);
  return status;
}

}  // namespace

SolverStatus solve_jacobian_pinv(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                                 Workspace& ws, double* params) {
  if (goals.size == 1 && goals[0].kind == GoalKind::kPosition) {
    // Target clamping (Buss 2004, sec. 6): a tip target beyond reach is replaced by the nearest
    // point of the reach sphere. Unclamped, the minimum keeps a residual as long as the chain
    // (|e| ~ the overshoot) while straightening the chain moves the tip only to second order, so
    // the halved Gauss-Newton steps creep (2.01 after 100 iterations on the precision case); the
    // clamped problem has a zero residual and converges to the straight pose. solve() measures
    // the real target afterwards and reports "unreachable".
    // The real distance exceeds the best reach by at most the clamped problem's error, so that
    // one is solved 100x tighter than asked.
    Goal goal = goals[0];
    SolverOptions o = options;
    // No margin: only a target at or beyond full reach is clamped onto the full-reach sphere
    // (clamping one inside it would move the target).
    constexpr double kClampMargin = 0.0;
    const bool clamped = stuck::tip_beyond_full_reach(chain, goals, kClampMargin);
    if (clamped) {
      const glm::dvec3 root = chain.root_in_base();
      goal.target_position = root + glm::normalize(goal.target_position - root) * chain.total_length();
      o.position_tolerance *= 1e-2;
    }
    jacobian::SinglePositionModel model(chain, goal, ws);
    return run_pinv(chain, Span<const Goal>(&goal, 1), o, ws, model, params, clamped);
  }
  return jacobian::solve_jacobian_pinv_generic(chain, goals, options, ws, params);
}

namespace jacobian {
SolverStatus solve_jacobian_pinv_generic(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                                         Workspace& ws, double* params) {
  GoalModel model(chain, goals, ws);
  return run_pinv(chain, goals, options, ws, model, params, false);
}
}  // namespace jacobian

}  // namespace ikchain
