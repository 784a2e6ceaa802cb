// BFGS: quasi-Newton descent on f(theta) = 0.5 * sum_g w_g |e_g(theta)|^2 with a strong-Wolfe
// line search.
//
// Sources (Nocedal & Wright, Numerical Optimization, 2nd ed.):
//  - inverse-Hessian update, eq. (6.17): H+ = (I - rho s y^T) H (I - rho y s^T) + rho s s^T,
//    rho = 1 / (y^T s); skipped when the curvature y^T s <= 0 (H stays positive definite);
//  - initial scaling before the first update, eq. (6.20): H0 = (y^T s / y^T y) I;
//  - line search, Alg. 3.5 (bracketing) with zoom, Alg. 3.6, cubic interpolation eq. (3.59).
//
// Gradient. evaluate_goals() gives r = sqrt(w) * (desired - current) and compute_jacobian() gives
// J = d(current)/d(params) (kinematics.hpp), so d r / d theta = -J and grad f = -J^T r. This is exact
// for all three goal kinds, even far from the goal: for orientation, f_g = 0.5 |log(T Q^-1)|^2 is
// half the squared geodesic distance whose gradient w.r.t. a base-frame rotation is -log(T Q^-1); for
// aim, d(0.5 angle^2) = -e . omega with e perpendicular to the aim axis. (Only J's rows are
// approximate away from zero error, which matters for Gauss-Newton steps but not for the gradient.)
//
// What makes it competitive (the lecture rates plain BFGS "not great" per iteration):
//  - Every BFGS cycle starts with a damped minimum-norm Gauss-Newton step
//    d = J^T (J J^T + mu I)^-1 r instead of steepest descent: one m x m solve (m = 3 * goals,
//    usually 3), O(m^2 n). Then H0 is scaled by eq. (6.20) from that first step.
//  - The hybrid of Fletcher & Xu ("Hybrid methods for nonlinear least squares", IMA J. Numer.
//    Anal. 7, 1987; Nocedal & Wright sec. 10.3): after a step that lowered f by at least
//    kHybridGain of it (the problem behaves as a small-residual one, where Gauss-Newton converges
//    quadratically), the next direction is Gauss-Newton's again; after a slower one, BFGS's. H
//    keeps its secant updates from both kinds of step. Far from the goals a full pose (6 rows, 6 or 7
//    DOF) took plain BFGS ~40 iterations; the Gauss-Newton steps halve that, which is what lets the
//    shared far escapes (stuck.hpp) fit in a solve's iterations (issue 16, item 20:
//    docs/robots-bench.md).
//  - alpha = 1 is tried first (N&W §3.5: quasi-Newton steps are well scaled), capped so that no
//    joint turns more than kFirstTrialRotation; f and grad f are evaluated together (one FK pass,
//    the Jacobian is O(n m)), so the cubic zoom uses both ends' slopes.
//  - O(n^2) per iteration: one H g product and the rank-2 update, both in place on the lower
//    triangle of ws.dof_square (H is symmetric; halving the memory traffic is what counts for long
//    chains); no allocation.
//  Timings and success rates: docs/benchmarks.md (scripts/bench), not here, where they go stale.
//
// Parameters. Trial points are params + alpha d with no wrapping (FK and the Jacobian accept any
// rotation vector), so phi(alpha) is smooth. Ball rotation vectors are wrapped to angle <= pi only
// when a point is accepted (apply_step); a wrap changes the chart, so H is reset then.
//
// Stuck (stuck.hpp). A straight chain with the target on its axis (ahead, behind, or on the root)
// has grad f = 0 exactly: no gradient method moves. These points are saddles: bending in the null
// space of J pulls the tip toward the root at second order. A stationary point with error left,
// the shared stall rule, or a line search that fails even from a fresh Gauss-Newton step call the
// shared escape, and the descent goes on from the moved pose with a new H; with no escape left the
// solve stops as stalled at the best pose seen. Steps that creep (the stall rule's creeping()) call
// the escape too when no restart follows, and with none left the descent goes on. The verdict after
// an accepted step is stuck::Loop's, shared with DLS (Creeps::kStuckOrLong) and the pseudo-inverse.
//
// Limits (a bounded variant of projection, documented choice). Hinge DOFs sitting on a bound with
// the gradient pushing outward are frozen (removed from the direction, and from J for the
// Gauss-Newton step), and so is the outward normal direction of a ball joint on its cone or twist
// boundary (ball_blocked; the joint then moves along the boundary) -- the active-set idea of
// projected quasi-Newton methods (Bertsekas 1982, "Projected Newton methods for optimization
// problems with simple constraints"). Every trial point
// is projected with project_to_limits(); on a projected (kinked) path the curvature condition is
// waived and only sufficient decrease measured along the projected displacement is asked for
// (Bertsekas' Armijo rule along the projection arc). When an accepted step was projected, the
// inverse Hessian is reset (its secant information mixes free and clipped coordinates), and so it
// is whenever the frozen set changes; the secant pairs are restricted to the free DOFs, so H's free
// block is the BFGS matrix of the reduced problem (a plain masked -H g zig-zags for hundreds of
// iterations along a bound).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/kinematics_internal.hpp"
#include "core/solvers/bfgs_common.hpp"
#include "core/solvers/solvers.hpp"
#include "core/solvers/stuck.hpp"

namespace ikchain {
namespace {

// First trial step: no joint turns more than this (rad) at alpha's first try; extrapolation may go
// further, up to kMaxIterationRotation (or options.max_step_angle when set).
constexpr double kFirstTrialRotation = 1.0;
constexpr double kMaxIterationRotation = 3.14159265358979323846;
// Fletcher & Xu's switch (their epsilon, 0.2 in the paper): a step that lowered f by at least this
// fraction of it makes the next direction Gauss-Newton's (see the file comment).
constexpr double kHybridGain = 0.2;

using bfgs::symmetric_product;
using Trial = bfgs::Trial<GoalErrors>;

class Bfgs {
 public:
  Bfgs(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
       double* params)
      : chain_(chain),
        goals_(goals),
        options_(options),
        ws_(ws),
        n_(chain.dof_count()),
        rows_(3 * goals.size),
        x_(params, chain.dof_count()),
        loop_(chain, goals, options, ws, params, Restart{this}) {}

  SolverStatus run();

  // The line search (bfgs_common.hpp) evaluates and keeps trial points through these.
  Trial try_step(double alpha);
  void keep(const Trial& t);

 private:
  // f, residual, J and grad f at `x` (gradient into `g`).
  GoalErrors evaluate(const double* x, Eigen::Ref<Eigen::VectorXd> g) {
    forward_kinematics(chain_, x, ws_);
    compute_dof_axes(chain_, x, ws_);
    auto r = ws_.residual.head(rows_);
    const GoalErrors err = evaluate_goals(chain_, goals_, ws_, r);
    auto J = ws_.jacobian.topRows(rows_);
    compute_jacobian(chain_, goals_, ws_, J);
    g.noalias() = -J.transpose() * r;
    return err;
  }

  // Projects `x` onto the limits; true when that moved it.
  bool project(double* x) const {
    if (!chain_.any_limits() || within_limits(chain_, x, 0.0)) return false;
    project_to_limits(chain_, x);
    return true;
  }

  // Joint `joint` sits on a limit and descent (-g) would push it out: for a hinge returns 1 (its
  // DOF is frozen), for a ball the number of normals written to `normals` (their directions are
  // frozen); 0 when free.
  int frozen(int joint, const Eigen::VectorXd& g, glm::dvec3 normals[2]) const {
    const int o = chain_.dof_offset(joint);
    double descent[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < chain_.dof_count_of(joint); ++k) descent[k] = -g[o + k];
    return joint_params_blocked(chain_.joint_type(joint), chain_.limits(joint), x_.data() + o, descent, normals);
  }

  // Whether any joint is frozen at x (ball joints' test is not free, and most poses have none):
  // worked out once per x and grad f; moved_x() forgets it.
  bool none_frozen() const {
    if (none_frozen_ < 0) {
      glm::dvec3 normals[2];
      none_frozen_ = 1;
      for (int i = 0; i < chain_.joint_count() && none_frozen_; ++i)
        if (frozen(i, ws_.gradient, normals) > 0) none_frozen_ = 0;
    }
    return none_frozen_ == 1;
  }
  void moved_x() { none_frozen_ = -1; }

  // Removes the frozen entries and directions from `v` (given grad f at x in ws.gradient).
  void zero_frozen(Eigen::Ref<Eigen::VectorXd> v) const {
    if (!chain_.any_limits() || none_frozen()) return;
    glm::dvec3 normals[2];
    for (int i = 0; i < chain_.joint_count(); ++i) {
      const int count = frozen(i, ws_.gradient, normals);
      const int o = chain_.dof_offset(i);
      const bool one_dof = is_one_dof(chain_.joint_type(i));
      if (count > 0 && one_dof) v[o] = 0.0;
      for (int k = 0; k < count && !one_dof; ++k) {
        const double along = v[o] * normals[k].x + v[o + 1] * normals[k].y + v[o + 2] * normals[k].z;
        for (int d = 0; d < 3; ++d) v[o + d] -= along * normals[k][d];
      }
    }
  }

  // Identifies the frozen set (0 = none): a change of active set restarts the BFGS cycle.
  uint64_t frozen_signature() const {
    if (!chain_.any_limits() || none_frozen()) return 0;
    uint64_t sig = 0;
    glm::dvec3 normals[2];
    for (int i = 0; i < chain_.joint_count(); ++i)
      if (const int count = frozen(i, ws_.gradient, normals))
        sig = sig * 1000003u + static_cast<uint64_t>(3 * i + count);
    return sig;
  }

  // Largest joint rotation of a step (rad): |d| for a hinge, |d_xyz| for a ball.
  double max_rotation(const Eigen::VectorXd& d) const {
    double m = 0.0;
    for (int i = 0; i < chain_.joint_count(); ++i) {
      const int o = chain_.dof_offset(i);
      const double rot = is_one_dof(chain_.joint_type(i))  // a slide counts metres as radians
                             ? std::abs(d[o])
                             : std::sqrt(d[o] * d[o] + d[o + 1] * d[o + 1] + d[o + 2] * d[o + 2]);
      m = std::max(m, rot);
    }
    return m;
  }

  // Makes ws.jacobian hold J at x (frozen columns zeroed).
  void jacobian_at_x() {
    if (!jacobian_current_) {
      evaluate(x_.data(), ws_.gradient_trial);  // same gradient as ws.gradient; only J is wanted
      jacobian_current_ = true;
    }
    if (!chain_.any_limits() || none_frozen()) return;
    glm::dvec3 normals[2];
    for (int i = 0; i < chain_.joint_count(); ++i) {
      const int count = frozen(i, ws_.gradient, normals);
      const int o = chain_.dof_offset(i);
      const bool one_dof = is_one_dof(chain_.joint_type(i));
      if (count > 0 && one_dof) ws_.jacobian.col(o).head(rows_).setZero();
      for (int k = 0; k < count && !one_dof; ++k)
        remove_ball_direction(ws_.jacobian, rows_, o, normals[k]);
    }
  }

  // w = (J J^T + mu I)^-1 b for J = ws.jacobian's rows, b = ws.goal_vec (solved in place) by a
  // plain Cholesky factorisation of ws.goal_square (core/math/linalg.hpp): m <= 3 * max_goals is
  // tiny, and Eigen's decompositions would allocate their own storage.
  // False when the time budget stopped it (checked once per row of J J^T: tree_bfgs.cpp's reason).
  bool solve_normal_equations() {
    auto J = ws_.jacobian.topRows(rows_);
    auto A = ws_.goal_square.topLeftCorner(rows_, rows_);
    double trace = 0.0;
    for (int a = 0; a < rows_; ++a) {
      if (a > 0 && ws_.deadline.spent()) return false;
      ws_.deadline.charge(static_cast<double>(a + 1) * J.cols());
      for (int b = 0; b <= a; ++b) A(a, b) = J.row(a).dot(J.row(b));
      trace += A(a, a);
    }
    // Damping relative to J's scale keeps the step finite at singular poses (rank-deficient J).
    const double mu = 1e-9 * trace / rows_ + 1e-300;
    for (int a = 0; a < rows_; ++a) A(a, a) += mu;
    linalg::cholesky_factor(A, rows_, mu);
    auto b = ws_.goal_vec.head(rows_);
    linalg::cholesky_solve(A, b, rows_);
    return true;
  }

  // ws.step = J^T (J J^T + mu I)^-1 r at x: the damped minimum-norm Gauss-Newton step.
  // False when the time budget stopped it (then there is no step).
  bool gauss_newton_direction() {
    jacobian_at_x();
    // ws.residual belongs to the last evaluated point, which is x after jacobian_at_x().
    ws_.goal_vec.head(rows_) = ws_.residual.head(rows_);
    if (!solve_normal_equations()) return false;
    ws_.step.noalias() = ws_.jacobian.topRows(rows_).transpose() * ws_.goal_vec.head(rows_);
    zero_frozen(ws_.step);
    return true;
  }

  // ws.step = -H g with frozen DOFs removed from g and from the step. False when the time budget
  // stopped the product (then there is no step).
  bool quasi_newton_direction() {
    ws_.dof_vec_b = ws_.gradient;
    zero_frozen(ws_.dof_vec_b);
    if (!symmetric_product(ws_.dof_square, ws_.dof_vec_b, ws_.step, &ws_.deadline)) return false;
    ws_.step = -ws_.step;
    zero_frozen(ws_.step);
    return true;
  }

  bool line_search(double alpha_init, double alpha_max);
  bool escape() { return loop_.escape(err_.cost); }
  double restart_after_escape();
  void accept(bool allow_update);
  void update_inverse_hessian();

  const Chain& chain_;
  Span<const Goal> goals_;
  const SolverOptions& options_;
  Workspace& ws_;
  const int n_;
  const int rows_;
  Eigen::Map<Eigen::VectorXd> x_;
  // The shared stall rule and escapes (stuck.hpp); after an escape, restart_after_escape().
  struct Restart {
    Bfgs* bfgs;
    double operator()() const { return bfgs->restart_after_escape(); }
  };
  stuck::Loop<Restart> loop_;

  GoalErrors err_;          // at x
  double f0_ = 0.0;         // f(x) at the start of the line search
  double dphi0_ = 0.0;      // grad f(x) . d
  Trial kept_;
  bool jacobian_current_ = false;  // ws.jacobian / ws.residual are of x or of the kept point
  bool fresh_ = true;              // H must be (re)initialised: next direction is Gauss-Newton
  bool gauss_newton_next_ = false; // the last step gained kHybridGain: next direction is Gauss-Newton, H kept
  uint64_t active_set_ = 0;        // frozen_signature() of the current BFGS cycle
  mutable int none_frozen_ = -1;   // none_frozen() at x: 1, 0, or -1 = not worked out yet
};

// Evaluates x + alpha * step, projected onto the limits, into params_trial / gradient_trial.
Trial Bfgs::try_step(double alpha) {
  Trial t;
  t.alpha = alpha;
  ws_.params_trial = x_ + alpha * ws_.step;
  t.projected = project(ws_.params_trial.data());
  t.err = evaluate(ws_.params_trial.data(), ws_.gradient_trial);
  jacobian_current_ = false;
  t.f = t.err.cost;
  t.dphi = ws_.gradient_trial.dot(ws_.step);
  t.decrease = t.projected ? ws_.gradient.dot(ws_.params_trial - x_) : alpha * dphi0_;
  return t;
}

// Remembers `t` (just evaluated by try_step) as the best acceptable point so far.
void Bfgs::keep(const Trial& t) {
  ws_.params_kept = ws_.params_trial;
  ws_.dof_vec_a = ws_.gradient_trial;
  kept_ = t;
  jacobian_current_ = true;  // J, residual: of the point just evaluated, now kept
}

// The shared strong-Wolfe search (bfgs_common.hpp) along ws.step.
bool Bfgs::line_search(double alpha_init, double alpha_max) {
  bfgs::WolfeSearch<Bfgs, GoalErrors> search(*this, options_, ws_.deadline, f0_, dphi0_);
  return search.run(alpha_init, alpha_max);
}

// The shared escape moved x: a new BFGS cycle starts there. Returns the cost there.
double Bfgs::restart_after_escape() {
  err_ = evaluate(x_.data(), ws_.gradient);
  jacobian_current_ = true;
  fresh_ = true;
  return err_.cost;
}

// x <- the kept point; grad f <- its gradient; H updated with (s, y) when allowed.
void Bfgs::accept(bool allow_update) {
  const double cost_before = err_.cost;
  // s = x+ - x into ws.step, y = g+ - g into ws.gradient_trial.
  ws_.step = ws_.params_kept - x_;
  ws_.gradient_trial = ws_.dof_vec_a - ws_.gradient;
  // The pair lives on the free DOFs (s is 0 on frozen ones): with H reset at every active-set
  // change, H stays block diagonal and its free block is the BFGS matrix of the reduced problem.
  zero_frozen(ws_.gradient_trial);
  apply_step(chain_, ws_.step.data(), 0.0, x_.data());  // wraps ball rotation vectors to <= pi
  err_ = kept_.err;
  gauss_newton_next_ = cost_before - err_.cost >= kHybridGain * cost_before;
  ws_.gradient = ws_.dof_vec_a;
  moved_x();
  bool wrapped = false;
  for (int i = 0; i < n_; ++i)
    if (x_[i] != ws_.params_kept[i]) wrapped = true;
  if (wrapped) {
    // The chart changed (and with it the gradient's coordinates): start a new BFGS cycle there.
    // After a slow step (Fletcher & Xu: not a Gauss-Newton step next) the cycle starts from eq.
    // (6.20)'s scaled identity of the pair just measured (in the old chart; a multiple of I does
    // not depend on it): a Gauss-Newton step after every wrap crawled, 0.1 % a step, toward a
    // ball chain's fold (Reasons.InsideTheInnerReachIsUnreachable).
    err_ = evaluate(x_.data(), ws_.gradient);
    moved_x();
    jacobian_current_ = true;
    fresh_ = gauss_newton_next_ || !allow_update ||
             !bfgs::scaled_identity(ws_.dof_square, ws_.step, ws_.gradient_trial);
    return;
  }
  // The O(n^2) update is skipped once the budget is spent (the loop stops at its next check): on
  // hundreds of DOFs it alone costs as much as the line search before it.
  if (!allow_update || kept_.projected || ws_.deadline.spent()) {
    fresh_ = true;
    return;
  }
  update_inverse_hessian();
}

// Eq. (6.17) (bfgs_common.hpp) with the pair in ws.step, ws.gradient_trial.
void Bfgs::update_inverse_hessian() {
  bfgs::update_inverse_hessian(ws_.dof_square, ws_.step, ws_.gradient_trial, ws_.dof_vec_b, fresh_, &ws_.deadline);
}

SolverStatus Bfgs::run() {
  SolverStatus status;
  const double length = chain_.total_length();
  err_ = evaluate(x_.data(), ws_.gradient);
  jacobian_current_ = true;
  fresh_ = true;
  loop_.start(err_.cost);
  int it = 0;
  for (; it < options_.max_iterations; ++it) {
    if (ws_.deadline.spent()) break;  // the time budget, checked before every iteration: kMaxIterations
    if (err_.within(options_)) {
      status.reason = TerminationReason::kConverged;
      status.iterations = it;
      status.escapes = loop_.escapes().used();
      return status;
    }
    ws_.dof_vec_b = ws_.gradient;
    zero_frozen(ws_.dof_vec_b);
    const double gnorm2 = ws_.dof_vec_b.squaredNorm();
    const double gnorm = std::sqrt(gnorm2);
    if (stuck::is_stationary(gnorm2, length, err_.combined, stuck::kQuasiNewtonStationary)) {  // error left
      if (escape()) continue;
      break;
    }

    const uint64_t signature = frozen_signature();
    if (signature != active_set_) fresh_ = true;
    active_set_ = signature;
    bool gauss_newton = fresh_ || gauss_newton_next_;
    gauss_newton_next_ = false;
    if (!gauss_newton) {
      if (!quasi_newton_direction()) break;  // the time budget: kMaxIterations
      // H can lose positive definiteness numerically; a non-descent direction restarts the cycle.
      if (!(ws_.gradient.dot(ws_.step) < -1e-12 * gnorm * ws_.step.norm())) fresh_ = gauss_newton = true;
    }
    if (gauss_newton && !gauss_newton_direction()) break;  // the time budget: kMaxIterations
    f0_ = err_.cost;
    dphi0_ = ws_.gradient.dot(ws_.step);
    const double rot = max_rotation(ws_.step);
    if (!(dphi0_ < 0.0) || !(rot > 0.0)) {
      if (escape()) continue;
      break;
    }
    const double cap = options_.max_step_angle > 0.0 ? options_.max_step_angle : kMaxIterationRotation;
    const double alpha_max = cap / rot;
    const double alpha_init = std::min({1.0, kFirstTrialRotation / rot, alpha_max});

    if (!line_search(alpha_init, alpha_max)) {
      if (!gauss_newton) {
        fresh_ = true;  // retry from a Gauss-Newton step with a new H
        continue;
      }
      if (escape()) continue;
      break;
    }
    accept(true);
    // The stall rule, a creep the limits hold (no escape left: stalled) or a long one, as DLS's.
    const stuck::Verdict verdict = loop_.after_accepted(err_.cost, stuck::Creeps::kStuckOrLong);
    if (verdict == stuck::Verdict::kMoved) continue;
    if (verdict == stuck::Verdict::kStalled) break;
  }
  status.iterations = it;
  if (err_.within(options_)) {
    status.reason = TerminationReason::kConverged;
  } else {
    status.reason = it >= options_.max_iterations || ws_.deadline.hit ? TerminationReason::kMaxIterations
                                                                      : TerminationReason::kStalled;
  }
  loop_.finish(status, err_.cost);  // an escape that ended worse costs nothing
  return status;
}

}  // namespace

SolverStatus solve_bfgs(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        Workspace& ws, double* params) {
  Bfgs bfgs(chain, goals, options, ws, params);
  return bfgs.run();
}

}  // namespace ikchain
