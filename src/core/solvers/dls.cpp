// Damped least squares / Levenberg-Marquardt.
//
// Step: dtheta = J^T (J J^T + mu I)^-1 e  (mu = lambda^2, m^2): the minimiser of
// |e - J dtheta|^2 + mu |dtheta|^2, which stays bounded where J loses rank (a straight chain, a
// target behind the root) instead of blowing up like the pseudo-inverse (Wampler 1986; Nakamura &
// Hanafusa 1986; Buss 2004, sec. 5). The damping adapts with Nielsen's rule (Madsen, Nielsen &
// Tingleff, "Methods for Non-Linear Least Squares Problems", 2nd ed. 2004, sec. 3.2, Alg. 3.16):
// a step is accepted only if the cost decreases; then mu *= max(1/3, 1 - (2 rho - 1)^3), where
// rho = actual / predicted decrease, and nu = 2; else mu *= nu (but at least 1% of trace(J J^T),
// see kRejectedMinDamping), nu *= 2 and the step is retried from the same linearisation. Good
// steps drive mu to dls_min_damping, i.e. to Gauss-Newton steps and their quadratic convergence
// near the solution; bad ones shrink the step towards a short gradient step. So one solve needs
// few iterations, and each costs one FK (plus one Jacobian when accepted): for one position goal
// both fused in O(n) with 3x3 algebra (jacobian_common.hpp). On a chain with limits, a step asking
// any DOF to turn more than kMaxStepTurn raises mu until it does not (a trust region in the
// damping's own terms).
//
// Iterations count trials: every evaluated step, accepted or not, is one of max_iterations.
// Stuck (stuck.hpp): the stall rule over the accepted steps, mu reaching dls_max_damping without an
// acceptable step, or a vanishing gradient with error left (a singular stationary point, where
// every damped step is zero). Each calls the shared escape; with none left the solve stops as
// "stalled" at the best pose seen - solve() turns a stall at a best reach into kUnreachable.
// Accepted steps that creep (the stall rule's creeping()) call the escape too when no restart
// follows; with none left the solve goes on.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/jacobian_common.hpp"
#include "core/solvers/stuck.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {
namespace {

// On a rejected trial the damping grows at least to this fraction of trace(J J^T) (the sum of the
// Gram eigenvalues): after a run of good steps mu is orders of magnitude below the eigenvalues, and
// doubling it from there (Nielsen's rule alone) only rejects the next trials too (docs/solvers.md,
// "Why these constants").
constexpr double kRejectedMinDamping = 1e-2;

// Largest |second-order correction| / |step| applied (Transtrum & Sethna 2012 use a ratio test
// too; the value: docs/solvers.md, "Why these constants").
constexpr double kMaxAccelerationRatio = 3.0;

// On a chain with limits, the largest turn of one DOF a step may ask for (rad; metres for a
// slide): a trust region kept by the damping itself (mu grows by kTrustDampingGrowth until the
// step fits), so the predicted decrease stays the model's. Far from the target the undamped step
// swings joints by radians onto their limits, where the solve then crawls along a bound to a local
// minimum. Without limits a long step costs nothing: the cost test rejects a bad one
// (docs/solvers.md, "Why these constants").
constexpr double kMaxStepTurn = 0.5;
constexpr double kTrustDampingGrowth = 4.0;

template <class Model>
SolverStatus run_dls(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, Workspace& ws,
                     Model& model, double* params) {
  SolverStatus status;
  const int n = chain.dof_count();
  ws.step.setZero();  // DOFs beyond the farthest effector never move

  // solve() leaves the start pose's measurement to this first evaluation (solver_measures_start).
  model.evaluate_start(params);
  model.accept();
  status.start = model.errors();
  status.start_measured = true;
  if (model.converged(o)) {
    status.reason = TerminationReason::kConverged;
    status.final = status.start;
    status.final_measured = true;
    return status;
  }
  // The time budget before the first linearisation too, not only before the first step: J, its
  // Gram matrix and the eigen-decomposition cost 50 us on 600 DOF with 7 goals, past the 20 us the
  // budget's bound allows (issue 16, item 6).
  if (ws.deadline.spent()) {
    status.reason = TerminationReason::kMaxIterations;
    return status;
  }
  model.linearize(params);
  const double initial_mu = std::clamp(o.dls_initial_damping, o.dls_min_damping, o.dls_max_damping);
  double mu = initial_mu;
  double nu = 2.0;
  // After an escape (or a query's crossing of a full-turn bound: stuck::Loop) the damping starts again.
  stuck::JacobianLoop loop(chain, goals, o, ws, model, params, [&]() {
    mu = initial_mu;
    nu = 2.0;
  });
  using stuck::Verdict;
  loop.escape_if_stationary();

  status.reason = TerminationReason::kMaxIterations;
  for (int it = 1; it <= o.max_iterations; ++it) {
    if (ws.deadline.spent()) break;  // the time budget, checked before every iteration: kMaxIterations
    status.iterations = it;
    if (model.converged(o)) {  // an escape landed there
      status.iterations = it - 1;
      status.reason = TerminationReason::kConverged;
      status.final = model.errors();
      status.final_measured = true;
      break;
    }
    const double cost = model.cost();
    const double predicted = jacobian::limit_aware_step(
        chain, model, params, ws.step.data(), [&](double* step) {
          const int active = model.active_dofs();
          double predicted_decrease = model.damped_step(mu, step);
          auto largest_turn = [&]() {
            return Eigen::Map<const Eigen::VectorXd>(step, active).lpNorm<Eigen::Infinity>();
          };
          // Each retry is a step of O(k n): the time budget is read between them.
          while (chain.any_limits() && mu < o.dls_max_damping && largest_turn() > kMaxStepTurn &&
                 !ws.deadline.spent()) {
            mu = std::min(mu * kTrustDampingGrowth, o.dls_max_damping);
            predicted_decrease = model.damped_step(mu, step);
          }
          return predicted_decrease;
        });
    if (model.has_acceleration() && nu == 2.0) {
      // Geodesic acceleration (see SinglePositionModel::acceleration), skipped when the correction
      // dwarfs the step itself: the quadratic model is not to be trusted that far. Also skipped on
      // a retry after a rejected trial (nu > 2): the model just failed at that radius, so its
      // curvature is not trusted either.
      const int active = model.active_dofs();
      const double correction = model.acceleration(ws.step.data(), ws.dof_vec_a.data());
      if (correction <= kMaxAccelerationRatio * ws.step.head(active).norm())
        ws.step.head(active) += ws.dof_vec_a.head(active);
    }
    jacobian::make_trial(chain, o, params, ws.step.data(), ws);
    const double trial_cost = model.evaluate(ws.params_trial.data());
    if (trial_cost < cost) {  // NaN compares false: rejected
      std::copy(ws.params_trial.data(), ws.params_trial.data() + n, params);
      model.accept();
      if (model.converged(o)) {
        status.reason = TerminationReason::kConverged;
        status.final = model.errors();  // of params, just accepted
        status.final_measured = true;
        break;
      }
      const double gain = cost - trial_cost;
      // A creep the limits hold, or a long one, escapes (DLS's steps do not follow the Newton
      // flow into singular saddles as the pseudo-inverse's do).
      const Verdict verdict = loop.after_accepted(trial_cost, stuck::Creeps::kStuckOrLong);
      if (verdict == Verdict::kMoved) continue;
      if (verdict == Verdict::kStalled) {
        status.reason = TerminationReason::kStalled;
        break;
      }
      if (ws.deadline.spent()) break;  // before the next linearisation, as before the first
      model.linearize(params);
      const double rho = predicted > 0.0 ? gain / predicted : 0.0;
      const double r = 2.0 * rho - 1.0;
      mu = std::max(mu * std::max(1.0 / 3.0, 1.0 - r * r * r), o.dls_min_damping);
      nu = 2.0;
      loop.escape_if_stationary();
    } else {
      if (mu >= o.dls_max_damping) {
        // No acceptable step at any damping: stuck as surely as by the stall rule.
        if (loop.escape()) continue;
        status.reason = TerminationReason::kStalled;
        break;
      }
      mu = std::min(std::max(mu * nu, kRejectedMinDamping * model.jacobian_norm() * model.jacobian_norm()),
                    o.dls_max_damping);
      nu *= 2.0;
    }
  }
  loop.finish(status);
  return status;
}

}  // namespace

SolverStatus solve_dls(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
                       double* params) {
  if (goals.size == 1 && goals[0].kind == GoalKind::kPosition) {
    jacobian::SinglePositionModel model(chain, goals[0], ws);
    return run_dls(chain, goals, options, ws, model, params);
  }
  return jacobian::solve_dls_generic(chain, goals, options, ws, params);
}

namespace jacobian {
SolverStatus solve_dls_generic(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                               Workspace& ws, double* params) {
  GoalModel model(chain, goals, ws);
  return run_dls(chain, goals, options, ws, model, params);
}
}  // namespace jacobian

}  // namespace ikchain
