// BFGS on a tree: quasi-Newton descent on one weighted sum,
//   f(q) = sum_g level_weight(level_g) * 0.5 * w_g |e_g(q)|^2  +  level_weight(L + 1) * posture(q),
// L the lowest level in use, posture(q) = 0.5 sum_d s_d (q_d - posture_d)^2 (when a posture is set).
//
// Priorities. BFGS minimises one function: it has no null space in which to solve a lower level.
// Levels become weight ratios (tree_common.hpp, kLevelWeightRatio = 1e3 per level): a lower level
// gives way where it conflicts with a higher one, up to about 1/1e3 of the conflict, and when every
// goal is reachable the weights do not matter. Strict priorities: the tree DLS. The posture weighs
// one level below the lowest goal's; the descent stops when every goal is met (as the chain BFGS),
// so the posture shapes the path rather than being polished to a minimum.
//
// Everything else is the chain BFGS's (bfgs.cpp, whose comment gives the sources): the strong-Wolfe
// line search and the inverse-Hessian update are the same code (bfgs_common.hpp); every cycle starts
// with a damped minimum-norm Gauss-Newton step d = D J^T (J D J^T + mu I)^-1 r, D = 1/motion_cost
// per DOF, so the first step moves costly joints least; the limits are the same active set (a
// limited hinge on a bound the descent pushes out of is frozen, a ball loses the outward normals of
// the cone or twist bound it rests on: the one joint-level mechanism, one_dof_blocked /
// ball_params_blocked) with every trial projected onto the limits, and H reset when the frozen set
// changes or a step was projected; stuck poses (the stall rule, a stationary point, a failed search
// from a fresh Gauss-Newton step) take the tree escapes (tree_common.hpp).
// One difference: a quasi-Newton step that keeps more than kSlowStep of the cost restarts the cycle
// from a Gauss-Newton step. With tens of DOFs and levels weighted 1e3 apart, H needs many pairs
// before it knows the curvature, and a warm-started tracking frame crept for 60-100 iterations at
// 1e-5 m; with the restart it converges in 3-9 (a hybrid, as Fletcher & Xu's for least squares).
// Not the chain BFGS's Fletcher & Xu switch (a Gauss-Newton step again after one that removed a
// share of the cost, H kept): at 0.9 it cut the body bench's iterations by a third, but IKBody's
// humanoid from straight legs with position-only feet then crept for 64 iterations where it
// converges in 14 (test_ik_body::every_tree_solver_bends_the_straight_legs_of_the_set_up_humanoid).
//
// Structure. The gradient and J come from tree_jacobian_column over each goal's supports only (an
// effector depends on its ancestors alone): O(goals x depth) columns per evaluation, and the
// Gauss-Newton step's Gram matrix couples goals only through shared supports' entries.
#include <cmath>
#include <cstdint>

#include "core/math/linalg.hpp"
#include "core/solvers/bfgs_common.hpp"
#include "core/solvers/tree_common.hpp"

namespace ikchain {
namespace {

constexpr double kFirstTrialRotation = 1.0;  // rad, as bfgs.cpp
constexpr double kMaxIterationRotation = 3.14159265358979323846;
constexpr double kSlowStep = 0.25;           // a quasi-Newton step keeping more of the cost is slow

using Trial = bfgs::Trial<TreeErrors>;

class TreeBfgs {
 public:
  TreeBfgs(const Tree& tree, const TreeProblem& problem, const SolverOptions& options, TreeWorkspace& ws,
           double* params)
      : tree_(tree), problem_(problem), o_(options), ws_(ws), n_(tree.dof_count()), rows_(3 * problem.goals.size),
        x_(params, tree.dof_count()) {
    active_ = tree_common::goal_dofs(tree, problem, ws);
    int lowest = 1;
    for (int g = 0; g < problem.goals.size; ++g) {
      const TreeGoal& tg = problem.goals[g];
      goal_weight_[g] = tree_common::level_weight(tg.level) * tg.goal.weight;
      lowest = std::max(lowest, tg.level);
    }
    posture_weight_ = problem.posture.empty() ? 0.0 : tree_common::level_weight(lowest + 1);
  }

  TreeSolverStatus run();

  // The line search (bfgs_common.hpp) evaluates and keeps trial points through these.
  Trial try_step(double alpha) {
    Trial t;
    t.alpha = alpha;
    ws_.params_trial = x_ + alpha * ws_.step;
    t.projected = project(ws_.params_trial.data());
    t.err = evaluate(ws_.params_trial.data(), ws_.gradient_trial, t.f);
    t.dphi = ws_.gradient_trial.dot(ws_.step);
    t.decrease = t.projected ? ws_.gradient.dot(ws_.params_trial - x_) : alpha * dphi0_;
    return t;
  }
  void keep(const Trial& t) {
    ws_.params_kept = ws_.params_trial;
    ws_.gradient_kept = ws_.gradient_trial;
    kept_ = t;
  }

 private:
  // The errors, f, the weighted residual and Jacobian rows (ws.residual, ws.jacobian) and grad f
  // (into g) at x.
  TreeErrors evaluate(const double* x, Eigen::VectorXd& g, double& f) {
    tree_forward_kinematics(tree_, x, ws_);
    tree_dof_axes(tree_, x, ws_);
    const TreeErrors err = tree_measure(tree_, problem_, o_, ws_, nullptr, nullptr, nullptr);
    f = tree_common::weighted_cost(err);
    g.setZero();
    auto J = ws_.jacobian.topRows(rows_);
    // Every evaluation writes the same entries (each goal's rows at its support columns) and the
    // rest stays zero: zeroed once per solve (10 % of a warm solve when zeroed every time).
    if (!jacobian_zeroed_) J.setZero();
    jacobian_zeroed_ = true;
    for (int k = 0; k < problem_.goals.size; ++k) {
      const Goal& goal = problem_.goals[k].goal;
      const glm::dvec3 e = tree_goal_error(tree_, ws_, goal);
      const double sw = std::sqrt(goal_weight_[k]);
      for (int r = 0; r < 3; ++r) ws_.residual[3 * k + r] = sw * e[r];
      const GoalLinearization lin = tree_linearize_goal(tree_, ws_, goal);
      const int* support = tree_.support_list(goal.effector);
      auto column = [&](int d) {
        const glm::dvec3 c = tree_jacobian_column(tree_, ws_, goal, lin, d);
        for (int r = 0; r < 3; ++r) J(3 * k + r, d) = sw * c[r];
        g[d] -= goal_weight_[k] * glm::dot(c, e);  // d(0.5 w |e|^2) = -w e . d(current)
      };
      if (tree_.floating_root())
        for (int d = 0; d < 3; ++d) column(d);
      for (int s = 0; s < tree_.support_count(goal.effector); ++s) {
        const int j = support[s];
        for (int d = 0; d < tree_.dof_count_of(j); ++d) column(tree_.dof_offset(j) + d);
      }
    }
    if (posture_weight_ > 0.0) {
      for (int d = 0; d < n_; ++d) {
        const double s = problem_.posture_stiffness.empty() ? 1.0 : problem_.posture_stiffness[d];
        const double diff = x[d] - problem_.posture[d];
        f += posture_weight_ * 0.5 * s * diff * diff;
        g[d] += posture_weight_ * s * diff;
      }
    }
    return err;
  }

  bool project(double* x) const {
    if (within_tree_limits(tree_, x, 0.0)) return false;
    project_tree_to_limits(tree_, x);
    return true;
  }

  // Joint j sits on a limit and descent (-g) pushes it out: 1 for a 1-DOF joint (frozen), for a
  // ball the number of normals written (their directions frozen); 0 when free.
  int frozen(int j, glm::dvec3 normals[2]) const {
    if (!tree_.has_limits(j)) return 0;
    const int o = tree_.dof_offset(j);
    const Eigen::VectorXd& g = ws_.gradient;
    double descent[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < tree_.dof_count_of(j); ++k) descent[k] = -g[o + k];
    return joint_params_blocked(tree_.joint_type(j), tree_.limits(j), x_.data() + o, descent, normals);
  }

  // Calls visit(j, count, normals) for every frozen joint the goals depend on.
  template <class Visit>
  void each_frozen(Visit&& visit) const {
    glm::dvec3 normals[2];
    for (int c = 0; c < active_; ++c) {
      const int d = ws_.active_dofs[c];
      const int j = ws_.dof_joint[d];
      if (j < 0 || d != tree_.dof_offset(j)) continue;
      if (const int count = frozen(j, normals)) visit(j, count, normals);
    }
  }

  // Removes the frozen entries and directions from v.
  void zero_frozen(Eigen::VectorXd& v) const {
    each_frozen([&](int j, int count, const glm::dvec3* normals) {
      const int o = tree_.dof_offset(j);
      if (is_one_dof(tree_.joint_type(j))) {
        v[o] = 0.0;
        return;
      }
      for (int k = 0; k < count; ++k) {
        const double along = v[o] * normals[k].x + v[o + 1] * normals[k].y + v[o + 2] * normals[k].z;
        for (int d = 0; d < 3; ++d) v[o + d] -= along * normals[k][d];
      }
    });
  }

  uint64_t frozen_signature() const {
    uint64_t sig = 0;
    each_frozen([&](int j, int count, const glm::dvec3*) { sig = sig * 1000003u + static_cast<uint64_t>(3 * j + count); });
    return sig;
  }

  // Largest joint rotation of a step (rad; the root's translation and slides count metres).
  double max_rotation(const Eigen::VectorXd& d) const {
    double m = 0.0;
    if (tree_.floating_root()) m = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int j = 0; j < tree_.joint_count(); ++j) {
      const int o = tree_.dof_offset(j);
      const double rot = is_one_dof(tree_.joint_type(j))
                             ? std::abs(d[o])
                             : std::sqrt(d[o] * d[o] + d[o + 1] * d[o + 1] + d[o + 2] * d[o + 2]);
      m = std::max(m, rot);
    }
    return m;
  }

  // ws.step = D J^T (J D J^T + mu I)^-1 r at x (J, r: of x, evaluated last), frozen parts removed
  // from J first and from the step after. False when the time budget stopped it (no step then).
  bool gauss_newton_direction() {
    double f = 0.0;
    err_ = evaluate(x_.data(), ws_.gradient, f);  // J and r of x (a trial may have been evaluated since)
    auto J = ws_.jacobian.topRows(rows_);
    each_frozen([&](int j, int count, const glm::dvec3* normals) {
      const int o = tree_.dof_offset(j);
      if (is_one_dof(tree_.joint_type(j))) {
        J.col(o).setZero();
        return;
      }
      for (int k = 0; k < count; ++k) remove_ball_direction(ws_.jacobian, rows_, o, normals[k]);
    });
    for (int d = 0; d < n_; ++d) {
      const int j = ws_.dof_joint[d];
      ws_.dof_scale[d] = 1.0 / (j < 0 ? tree_.translation_motion_cost() : tree_.motion_cost(j));
    }
    auto A = ws_.row_square.topLeftCorner(rows_, rows_);
    double trace = 0.0;
    for (int a = 0; a < rows_; ++a) {
      // The time budget once per row of J J^T (up to 190 dot products over 250 DOFs: 100 us in
      // all for 12 goals, past the 20 us the bound allows).
      if (a > 0 && ws_.deadline.spent()) return false;
      const int ea = problem_.goals[a / 3].goal.effector;
      const int* support = tree_.support_list(ea);
      // Row a against the three rows of each goal kb up to a's own: they share only the DOFs of
      // both effectors' common ancestors, a prefix of either support list (root first); every other
      // product has a zero factor. Each entry sums the same products in the same (ascending) order
      // as over every active DOF: the same bits, a third of the loads of J(a, d).
      for (int kb = 0; kb <= a / 3; ++kb) {
        const int eb = problem_.goals[kb].goal.effector, b0 = 3 * kb;
        double sum[3] = {0.0, 0.0, 0.0};
        auto add = [&](int d) {
          const double x = J(a, d) * ws_.dof_scale[d];
          for (int c = 0; c < 3; ++c) sum[c] += x * J(b0 + c, d);
        };
        if (tree_.floating_root())
          for (int d = 0; d < 3; ++d) add(d);
        for (int k = 0; k < tree_.support_count(ea) && tree_.supports(eb, support[k]); ++k) {
          const int o = tree_.dof_offset(support[k]);
          for (int d = o; d < o + tree_.dof_count_of(support[k]); ++d) add(d);
        }
        for (int c = 0; c < 3 && b0 + c <= a; ++c) A(a, b0 + c) = sum[c];
      }
      trace += A(a, a);
    }
    const double mu = 1e-9 * trace / rows_ + 1e-300;
    for (int a = 0; a < rows_; ++a) A(a, a) += mu;
    // The column-at-a-time factor and substitutions the tree DLS uses (36 rows for six pose goals:
    // cholesky_factor's strided left-looking dot products cost three times as many instructions).
    const linalg::Cols L = linalg::cols_of(A);
    linalg::cholesky_lower(L, rows_, mu);
    auto w = ws_.row_vec_a.head(rows_);
    w = ws_.residual.head(rows_);
    linalg::lower_solve(L, rows_, w.data());
    linalg::lower_transpose_solve(L, rows_, w.data());
    ws_.step.noalias() = J.transpose() * w;
    ws_.step.array() *= ws_.dof_scale.array();
    zero_frozen(ws_.step);
    return true;
  }

  // False when the time budget stopped the O(n^2) product (bfgs.cpp's reason).
  bool quasi_newton_direction() {
    ws_.dof_vec_b = ws_.gradient;
    zero_frozen(ws_.dof_vec_b);
    if (!bfgs::symmetric_product(ws_.dof_square, ws_.dof_vec_b, ws_.step, &ws_.deadline)) return false;
    ws_.step = -ws_.step;
    zero_frozen(ws_.step);
    return true;
  }

  bool escape() {
    if (escapes_ >= stuck::kMaxEscapes || !tree_common::escape(tree_, ws_, active_, ++escapes_, x_.data()))
      return false;
    err_ = evaluate(x_.data(), ws_.gradient, f_);
    fresh_ = true;
    stall_.reset(f_);
    return true;
  }

  // x <- the kept point; H updated with (s, y) unless the step was projected or a ball wrapped.
  void accept() {
    ws_.step = ws_.params_kept - x_;
    ws_.gradient_trial = ws_.gradient_kept - ws_.gradient;
    zero_frozen(ws_.gradient_trial);
    x_ = ws_.params_kept;
    bool wrapped = false;
    for (int j = 0; j < tree_.joint_count(); ++j) {
      if (is_one_dof(tree_.joint_type(j))) continue;  // only rotation vectors wrap
      const int o = tree_.dof_offset(j);
      const glm::dvec3 r(x_[o], x_[o + 1], x_[o + 2]);
      const glm::dvec3 w = so3::wrap_rotation_vector(r);
      if (w != r) {
        wrapped = true;
        x_[o] = w.x, x_[o + 1] = w.y, x_[o + 2] = w.z;
      }
    }
    err_ = kept_.err;
    f_ = kept_.f;
    ws_.gradient = ws_.gradient_kept;
    if (wrapped) {  // the chart changed: a new cycle from there
      err_ = evaluate(x_.data(), ws_.gradient, f_);
      fresh_ = true;
      return;
    }
    if (kept_.projected || ws_.deadline.spent()) {  // spent: the loop stops next (bfgs.cpp's reason)
      fresh_ = true;
      return;
    }
    bfgs::update_inverse_hessian(ws_.dof_square, ws_.step, ws_.gradient_trial, ws_.dof_vec_b, fresh_, &ws_.deadline);
  }

  const Tree& tree_;
  const TreeProblem& problem_;
  const SolverOptions& o_;
  TreeWorkspace& ws_;
  const int n_, rows_;
  Eigen::Map<Eigen::VectorXd> x_;
  int active_ = 0;
  std::array<double, kMaxTreeGoals> goal_weight_{};
  double posture_weight_ = 0.0;
  stuck::StallRule stall_;
  int escapes_ = 0;
  TreeErrors err_;
  double f_ = 0.0;
  double dphi0_ = 0.0;
  Trial kept_;
  bool fresh_ = true;
  bool jacobian_zeroed_ = false;    // ws.jacobian's top rows zeroed in this solve
  uint64_t active_set_ = 0;
};

TreeSolverStatus TreeBfgs::run() {
  TreeSolverStatus status;
  err_ = evaluate(x_.data(), ws_.gradient, f_);
  double best = f_;
  ws_.params_best = x_;
  fresh_ = true;
  stall_.reset(f_);
  int it = 0;
  for (; it < o_.max_iterations; ++it) {
    if (ws_.deadline.spent()) break;
    if (err_.all_met()) break;
    ws_.dof_vec_b = ws_.gradient;
    zero_frozen(ws_.dof_vec_b);
    const double gnorm2 = ws_.dof_vec_b.squaredNorm();
    const double gnorm = std::sqrt(gnorm2);
    if (stuck::is_stationary(gnorm2, tree_.total_length(), std::sqrt(2.0 * f_), stuck::kQuasiNewtonStationary)) {
      if (escape()) continue;
      break;
    }
    const uint64_t signature = frozen_signature();
    if (signature != active_set_) fresh_ = true;
    active_set_ = signature;
    if (!fresh_) {
      if (!quasi_newton_direction()) break;  // the time budget: kMaxIterations
      if (!(ws_.gradient.dot(ws_.step) < -1e-12 * gnorm * ws_.step.norm())) fresh_ = true;
    }
    const bool was_fresh = fresh_;  // accept() clears fresh_ with H's first update
    const double f_before = f_;
    if (fresh_ && !gauss_newton_direction()) break;  // the time budget: kMaxIterations
    dphi0_ = ws_.gradient.dot(ws_.step);
    const double rot = max_rotation(ws_.step);
    if (!(dphi0_ < 0.0) || !(rot > 0.0)) {
      if (escape()) continue;
      break;
    }
    const double cap = o_.max_step_angle > 0.0 ? o_.max_step_angle : kMaxIterationRotation;
    const double alpha_max = cap / rot;
    const double alpha_init = std::min({1.0, kFirstTrialRotation / rot, alpha_max});
    bfgs::WolfeSearch<TreeBfgs, TreeErrors> search(*this, o_, ws_.deadline, f_, dphi0_);
    if (!search.run(alpha_init, alpha_max)) {
      if (!fresh_) {
        fresh_ = true;
        continue;
      }
      if (escape()) continue;
      break;
    }
    accept();
    if (f_ < best) {
      best = f_;
      ws_.params_best = x_;
    }
    if (stall_.stalled_after(f_, o_.stall_tolerance)) {
      if (escape()) continue;
      break;
    }
    // A quasi-Newton step that did not cut the cost by kSlowStep: H has not caught the curvature
    // yet (tens of DOFs, goals weighted 1e3 apart: from the warm start of a tracked frame, plain
    // BFGS crept for 60-100 iterations at 1e-5 m); the next cycle starts again from a Gauss-Newton
    // step, which near a solution converges in one or two.
    if (!was_fresh && !(f_ <= kSlowStep * f_before)) fresh_ = true;
  }
  status.iterations = it;
  status.escapes = escapes_;
  if (err_.all_met()) {
    status.reason = TerminationReason::kConverged;
    return status;
  }
  status.reason = it >= o_.max_iterations || ws_.deadline.hit ? TerminationReason::kMaxIterations
                                                               : TerminationReason::kStalled;
  if (best < f_) x_ = ws_.params_best;  // an escape that ended worse costs nothing
  return status;
}

}  // namespace

TreeSolverStatus solve_tree_bfgs(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                 TreeWorkspace& ws, double* params) {
  TreeBfgs bfgs(tree, problem, options, ws, params);
  return bfgs.run();
}

}  // namespace ikchain
