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
// by the nearest reachable point (see solve_jacobian_pinv). Singular saddles: where the path ends
// at a singular pose with the residual along the lost direction and the steps only creep, one
// null-space step toward the rest pose changes the configuration (escape_singular_saddle).
//
// Iterations count accepted (or final failed) steps and escapes; each costs one FK per halving
// tried. Stops: converged; "stalled" when no halving decreases the cost, or when kStallCount
// accepted steps in a row improve the cost by less than stall_tolerance (relative), and no escape
// is left.
#include <algorithm>
#include <cmath>

#include "core/kinematics.hpp"
#include "core/solvers/jacobian_common.hpp"
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

// Singular saddles (see escape_singular_saddle). An accepted step "creeps" when it lowers the cost
// by less than kCreepGain of it; kCreepCount creeping steps in a row are a trap. Measured on the
// benchmark hinge chains (bench/core_bench.cpp's targets and options), n = 3 / 7 / 10, 350000
// targets each (seeds 11-80), unreached: kCreepGain 1e-3 and 1e-2: 0 / 0 / 0, 1e-1: 1 / 0 / 0;
// kCreepCount 2, 3 and 5: 0 / 0 / 0.
constexpr double kCreepGain = 1e-2;
constexpr int kCreepCount = 3;
// Escapes per solve. The trap attracts the pseudo-inverse's path, so the solve may fall back into
// it after one escape; same measurement, 0 / 1 / 2 / 3 / 4 escapes: 8 / 69 / 27, 6 / 10 / 3,
// 5 / 1 / 1, 1 / 0 / 0, 0 / 0 / 0 unreached (and 0 at n = 2, 3, 7, 10, 30 on the unseen seeds
// 81-130).
constexpr int kEscapes = 4;
// The escape's pseudo-inverse drops singular values below this fraction of |J| (kTruncation[2]),
// so the nearly singular direction the residual is stuck in counts as free (at n = 3 it is the
// only free one). Same measurement: 1e-3 and 1e-1 also 0 / 0 / 0; pinv_singular_threshold alone
// (0 here) 2 / 0 / 0.
constexpr double kEscapeTruncation = 1e-2;
// A centring step whose largest DOF turn is below this (rad) means the pose is already at rest in
// every free direction (typically the straight rest pose itself, stuck at the start on a target
// almost in its plane); the escape kicks instead (jacobian::kick). Without it 1 of 600000 targets
// at n = 3 and 2 at n = 30 (seeds 11-130) end at the rest pose; 1e-9 to 0.3 all reach them.
constexpr double kMinEscapeAngle = 1e-3;

// Null-space step toward the rest pose, the pseudo-inverse's classic secondary task (Liegeois,
// "Automatic supervisory control of the configuration and behavior of multibody mechanisms", 1977;
// Buss 2004 sec. 4):  step = (I - J+ J) z,  z = rest - params over the active DOFs (hinge angles
// modulo 2 pi, ball rotation vectors toward 0), J+ truncated below kEscapeTruncation |J|. J is the
// Jacobian at params, as linearize() left it in the top m rows of ws.jacobian. To first order the
// step does not move the goals' effectors; it changes the configuration (e.g. untwists the chain)
// so that the direction the residual lies along becomes one J can serve again.
// Writes the step into ws.dof_vec_b (zero beyond the active DOFs). Uses goal_square, dof_square,
// goal_vec and dof_vec_a as scratch (the caller re-linearises afterwards); allocates nothing.
void null_space_centering(const Chain& chain, const SolverOptions& o, int m, int active, const double* params,
                          Workspace& ws) {
  double* z = ws.dof_vec_b.data();
  std::fill(z, z + chain.dof_count(), 0.0);
  for (int i = 0; i < chain.joint_count() && chain.dof_offset(i) < active; ++i) {
    const int d0 = chain.dof_offset(i);
    if (chain.joint_type(i) == JointType::kHinge) {
      z[d0] = -std::remainder(params[d0], 2.0 * so3::kPi);
    } else {
      for (int d = d0; d < d0 + 3; ++d) z[d] = -params[d];
    }
  }
  const auto J = ws.jacobian.topLeftCorner(m, active);
  Eigen::Map<Eigen::VectorXd> zv(z, active);
  // Same two forms as the models' pseudo-inverse: the Gram matrix of the smaller side.
  if (m < active) {  // z -= J^T V diag(1/lambda) V^T J z   (J J^T = V diag(lambda) V^T)
    auto A = ws.goal_square.topLeftCorner(m, m);
    auto V = ws.dof_square.topLeftCorner(m, m);
    A.noalias() = J * J.transpose();
    const double tr = A.trace();
    const double floor = jacobian::gram_rank_floor(
        std::max(o.pinv_singular_threshold, kEscapeTruncation * std::sqrt(std::max(tr, 0.0))), tr);
    jacobian::jacobi_eigen(A, V, m);
    auto y = ws.goal_vec.head(m);
    auto t = ws.dof_vec_a.head(m);
    y.noalias() = J * zv;
    t.noalias() = V.transpose() * y;
    for (int i = 0; i < m; ++i) t[i] = A(i, i) > floor ? t[i] / A(i, i) : 0.0;
    y.noalias() = V * t;
    zv.noalias() -= J.transpose() * y;
  } else {  // z -= W W^T z over the kept eigenvectors W of J^T J
    auto A = ws.dof_square.topLeftCorner(active, active);
    auto W = ws.goal_square.topLeftCorner(active, active);
    A.noalias() = J.transpose() * J;
    const double tr = A.trace();
    const double floor = jacobian::gram_rank_floor(
        std::max(o.pinv_singular_threshold, kEscapeTruncation * std::sqrt(std::max(tr, 0.0))), tr);
    jacobian::jacobi_eigen(A, W, active);
    auto t = ws.dof_vec_a.head(active);
    t.noalias() = W.transpose() * zv;
    for (int i = 0; i < active; ++i) t[i] = A(i, i) > floor ? t[i] : 0.0;
    zv.noalias() -= W * t;
  }
}

// Escape from a singular saddle. Halved pseudo-inverse steps follow the Newton flow, which moves the
// effector along the straight line to the target; when the joint path meets a singular pose on
// the way, it stops there: a hinge folded to +-pi or a straight segment, with the residual along
// the one direction the pose cannot move the effector in to first order. Typical on these chains:
// a target nearly behind the root, the chain folded back at joint 2 over a twisted joint 1, its
// tip short of the target. The cost has a saddle there whose way down needs a large move (e.g.
// untwisting joint 1 by ~1 rad, after which the solve converges in 5 iterations). Measured at the
// 43 poses the old solver ended at (seeds 11-13): sigma_min / sigma_max 1e-6..4e-2, and in most
// of them over 99 % of the residual along the smallest singular direction. Truncated steps then
// promise nothing, the full step passes the residual check only at ~1e-6 of its length, and every
// iteration gains a little more than stall_tolerance: the solve creeps to max_iterations (most of
// the 0.1-0.2 % of targets the old solver missed at n = 3 / 7 / 10). At such a trap, with escapes
// left and a target within reach (beyond it, the straight best reach is a singular optimum, not a
// trap), this takes one null-space step toward the rest pose (null_space_centering); it remembers
// the pose in params_best / best_cost first, like the kick, so the solver can return that pose if
// the escape ends worse. Returns true when it moved the pose.
template <class Model>
bool escape_singular_saddle(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, Workspace& ws,
                            Model& model, double* params, int& escapes_left, double& best_cost) {
  if (escapes_left <= 0 || jacobian::target_beyond_reach(chain, goals)) return false;
  --escapes_left;
  if (model.cost() < best_cost) {
    best_cost = model.cost();
    std::copy(params, params + chain.dof_count(), ws.params_best.data());
  }
  // J at params: the last evaluate() may have been a rejected trial (linearize() needs the pose's FK).
  model.evaluate(params);
  model.accept();
  model.linearize(params);
  const int active = model.active_dofs();
  null_space_centering(chain, o, 3 * goals.size, active, params, ws);
  double largest = 0.0;
  for (int j = 0; j < active; ++j) largest = std::max(largest, std::abs(ws.dof_vec_b[j]));
  if (largest > kMinEscapeAngle) {
    apply_step(chain, ws.dof_vec_b.data(), 0.0, params);
    project_to_limits(chain, params);
  } else {
    jacobian::kick(chain, active, ws, params);
  }
  model.evaluate(params);
  model.accept();
  model.linearize(params);
  return true;
}

template <class Model>
SolverStatus run_pinv(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, Workspace& ws,
                      Model& model, double* params) {
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
  model.linearize(params);
  int kicks_left = 2;
  int escapes_left = kEscapes;
  double best_cost = INFINITY;
  jacobian::kick_if_stuck(chain, goals, model, ws, params, kicks_left, best_cost);

  double fraction = 1.0;  // the last accepted de / e
  int small_improvements = 0;
  int creeping = 0;
  status.reason = TerminationReason::kMaxIterations;
  for (int it = 1; it <= o.max_iterations; ++it) {
    if (it > 1 && ws.deadline.spent()) break;  // the time budget: kMaxIterations
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
    // solve converges linearly, ~6 % of the distance per iteration, past max_iterations. Measured
    // on the benchmark chains (seeds 11-80, with the escapes): taking the lenient step only when nothing passes, and
    // only at the last halving, misses 76 of 350000 targets at n = 3 (this rule: 0) and needs a
    // median of 10 iterations at n = 3 / 7 / 10 (this rule: 9).
    // Joints on a limit the full step pushes outward leave J for this iteration, at every level
    // (the active set, jacobian::limit_aware_step).
    jacobian::limit_aware_step(chain, model, params, ws.step.data(), [&](double* step) {
      model.pinv_step(o.pinv_singular_threshold, step);
      return 0.0;
    });
    double best_trial_cost = cost, best_s = 0.0, best_threshold = 0.0;
    bool evaluated_is_best = false;
    double last_threshold = -1.0;
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
      if (best_s >= kGoodFraction) break;
    }
    const bool accepted = best_s > 0.0;
    if (!accepted) {
      if (escape_singular_saddle(chain, goals, o, ws, model, params, escapes_left, best_cost)) {
        fraction = 1.0;
        creeping = small_improvements = 0;
        continue;
      }
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
    const double gain = cost - model.cost();
    small_improvements = gain <= o.stall_tolerance * cost ? small_improvements + 1 : 0;
    creeping = gain <= kCreepGain * cost ? creeping + 1 : 0;
    const bool stalled = small_improvements >= jacobian::kStallCount;
    if ((stalled || creeping >= kCreepCount) &&
        escape_singular_saddle(chain, goals, o, ws, model, params, escapes_left, best_cost)) {
      fraction = 1.0;
      creeping = small_improvements = 0;
      continue;
    }
    if (stalled) {
      status.reason = TerminationReason::kStalled;
      break;
    }
    model.linearize(params);
    jacobian::kick_if_stuck(chain, goals, model, ws, params, kicks_left, best_cost);
  }
  if (status.reason != TerminationReason::kConverged) jacobian::keep_best(chain, model, ws, best_cost, params);
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
    if (jacobian::target_beyond_reach(chain, goals)) {
      const glm::dvec3 root = chain.root_in_base();
      goal.target_position = root + glm::normalize(goal.target_position - root) * chain.total_length();
      o.position_tolerance *= 1e-2;
    }
    jacobian::SinglePositionModel model(chain, goal, ws);
    return run_pinv(chain, Span<const Goal>(&goal, 1), o, ws, model, params);
  }
  return jacobian::solve_jacobian_pinv_generic(chain, goals, options, ws, params);
}

namespace jacobian {
SolverStatus solve_jacobian_pinv_generic(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                                         Workspace& ws, double* params) {
  GoalModel model(chain, goals, ws);
  return run_pinv(chain, goals, options, ws, model, params);
}
}  // namespace jacobian

}  // namespace ikchain
