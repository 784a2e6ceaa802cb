// Damped least squares on a tree, with strict priority levels.
//
// One step. Rows are ordered by level (ws.goal_order); J holds every goal's weighted rows over the
// DOFs that move any goal's effector (the union of their supports: the rest never enter the
// matrices), each column scaled by 1 / sqrt(motion_cost), so the minimum-norm step is the one that
// moves costly joints least. Level 1 gets the damped step y1 = J1^T (J1 J1^T + mu I)^-1 e1. Level
// k then works in the null space of the rows A above it (recursive null-space projection,
// Siciliano & Slotine 1991; Baerlocher & Boulic 2004):
//   J~k = Jk (I - A^T G^-1 A),  G = A A^T (+ a tiny ridge),
//   y  += J~k^T (J~k J~k^T + mu I)^-1 (ek - Jk y),
// so it never disturbs a higher level to first order. Both products are formed from the Gram
// matrix M = J J^T of all rows (its blocks are A A^T, Jk A^T and Jk Jk^T), so a level costs
// O(rows^2 * dofs), never an n x n projector. Below every level, the posture task's step is
// projected into the null space of every goal row the same way.
//
// Acceptance compares poses level by level (lexicographically): a trial is better when the first
// level that differs - not met in both, and changed by more than rounding - is lower; then the
// posture. Damping adapts as in the chain DLS (dls.cpp): down after an accepted step, up after a
// rejected one. Joint limits are hard at every level: the active set of the chain's Jacobian
// solvers (a DOF pushing out of a bound it rests on loses its column, a ball its outward
// directions) and a projection of each trial onto the limits.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/math/linalg.hpp"
#include "ikchain/so3.hpp"
#include "core/solvers/stuck.hpp"
#include "core/solvers/tree_common.hpp"
#include "core/solvers/tree_solvers.hpp"

namespace ikchain {
namespace {

// The ridge added to the Gram matrix of the rows above a level, relative to its largest diagonal
// entry: enough for a Cholesky factor of a rank-deficient set of rows (a straight leg), far below
// any direction a level really uses.
constexpr double kProjectorRidge = 1e-10;
// A level's cost counts as unchanged within this relative band (rounding of the cost, and the
// second-order change a lower level's null-space step makes).
constexpr double kSameCost = 1e-9;
constexpr int kLimitPasses = 3;
// The first damping's share of the squared weighted residual |e|^2 (m^2) when that is below
// dls_initial_damping (solve_tree_dls): 0.1 made the body bench's median warm frame two
// iterations instead of three (|e|^2 itself did not) and leaves cold starts (|e|^2 ~ 0.1-10) at
// dls_initial_damping.
constexpr double kResidualDamping = 0.1;
// Lexicographic progress: the relative gain of the first level `before` has not met whose cost
// the step changed (beyond kSameCost); `otherwise` when it changed none (the posture's gain).
double lexicographic_gain(const TreeErrors& after, const TreeErrors& before, double otherwise) {
  for (int l = 0; l < kMaxPriorityLevels; ++l) {
    const double b = before.level_cost[l];
    if (before.level_met[l] || !(b > 0.0)) continue;
    const double gain = (b - after.level_cost[l]) / b;
    if (std::abs(gain) > kSameCost) return gain;
  }
  return otherwise;
}

// A step whose progress() (the largest relative gain of a level not met, or of the posture) is at
// least this shows the linear model holds: the next step reuses its Jacobian and factors (a chord
// step). 0.99 and 0.9 cost the body bench the same instructions; 0.99 takes fewer, surer chord
// steps. Requiring the gain of every level instead cost 5 % more warm (fewer chord steps).
constexpr double kChordGain = 0.99;
// A posture step from a pose whose goals are all met, that kept them met, moved the joints by a
// share (the stiffness) of their distance to the posture: the Jacobian hardly changed, so the next
// posture step reuses it and the factors too (a chord step: two triangular solves instead of a
// linearisation, Gram matrix and factorisation) - at most this many in a row, so the null space
// the posture moves in never lags the pose by more than a few small steps. A chord step the
// comparison refuses gets the second-order correction, then falls back to a fresh linearisation,
// as every chord step does.
constexpr int kMaxPostureChords = 3;
// A refused posture step from a pose meeting every goal that moved no param by more than this (rad;
// m for a translation) finds the posture settled: no shorter one is tried (a still body's tracking
// frame spent three iterations on those).
constexpr double kPostureSettledStep = 1e-3;
// After the capped posture's last step (posture_iterations) a chord step contracts the goals'
// error only to about a quarter or a fifth (the step moved the pose off the Jacobian): from within this
// many tolerances one such step meets them, from farther a fresh linearisation is cheaper than the
// several chord steps. The body bench's warm frames (0.01 mm tolerance) take 2 iterations, not 4;
// IKBody's (0.1 mm), mostly within it, keep their chord polish (4: 9k fewer instructions a
// character-frame, but a third iteration on half the bench's frames; a fresh J always: 40k more).
constexpr double kChordPolishTolerances = 2.0;
// The shortest share of the posture step tried once every goal is met (each refused step quarters it).
constexpr double kMinPostureGain = 1.0 / 64.0;
// The smallest squared pivot the Cholesky factors keep (both matrices have a positive ridge or
// damping added first, so this only catches rounding).
constexpr double kMinPivot2 = 1e-200;
// While a lower level still makes progress, a higher one met within this many tolerances counts as
// met: a step that serves the lower level drifts the higher ones by its square, and the next
// step's Gauss-Newton part takes that back (quadratically). A strict phase (factor 1) polishes
// the higher levels at the end.
constexpr double kRelaxedTolerances = 100.0;
// The chain solvers' stall and creep rules (stuck.hpp): one notion of "stuck".
using stuck::kMaxEscapes;

struct Levels {
  int count = 0;                                   // levels with goals
  std::array<int, kMaxPriorityLevels> begin{}, end{};  // row ranges, in level order
};

double posture_cost(const Tree& tree, const TreeProblem& problem, const double* params) {
  if (problem.posture.empty()) return 0.0;
  double c = 0.0;
  for (int d = 0; d < tree.dof_count(); ++d) {
    const double s = problem.posture_stiffness.empty() ? 1.0 : problem.posture_stiffness[d];
    const double e = params[d] - problem.posture[d];
    c += 0.5 * s * e * e;
  }
  return c;
}

// Level costs at or below `met_cost` count as met (equal), whatever their value.
using LevelCosts = std::array<double, kMaxPriorityLevels>;

// +1 when `trial` is better than `current` level by level, -1 when worse, 0 when no level tells
// them apart. Level costs at or below `met_cost` count as met (equal).
int compare_levels(const TreeErrors& trial, const TreeErrors& current, const LevelCosts& met_cost) {
  for (int l = 0; l < kMaxPriorityLevels; ++l) {
    const double a = trial.level_cost[l], b = current.level_cost[l];
    const bool trial_met = trial.level_met[l] || a <= met_cost[l];
    const bool current_met = current.level_met[l] || b <= met_cost[l];
    if (trial_met && current_met) continue;
    if (!(a <= b * (1.0 + kSameCost))) return -1;  // worse (or NaN)
    if (a < b * (1.0 - kSameCost)) return 1;
  }
  return 0;
}

// Better with levels met within `met_cost` counted as met; where that ties, better strictly (each
// goal within its tolerance), so progress inside the band still counts; only where the levels
// tie strictly, a lower posture cost. The posture never buys its progress with a goal's accuracy,
// not even inside the relaxed band: there it would undo what the strict phase must then redo.
bool better(const TreeErrors& trial, double trial_posture, const TreeErrors& current, double current_posture,
            const LevelCosts& met_cost) {
  const int relaxed = compare_levels(trial, current, met_cost);
  if (relaxed != 0) return relaxed > 0;
  const int strict = compare_levels(trial, current, LevelCosts{});
  if (strict != 0) return strict > 0;
  return trial_posture < current_posture * (1.0 - kSameCost);
}

// True when every level is met or costs at most `met_cost`.
bool within(const TreeErrors& errors, const LevelCosts& met_cost) {
  for (int l = 0; l < kMaxPriorityLevels; ++l)
    if (!errors.level_met[l] && errors.level_cost[l] > met_cost[l]) return false;
  return true;
}

// The cost each level has when every one of its goals is `factor` times its tolerance off.
LevelCosts met_costs(const TreeProblem& problem, const SolverOptions& o, double factor) {
  LevelCosts c{};
  for (int g = 0; g < problem.goals.size; ++g) {
    const Goal& goal = problem.goals[g].goal;
    const double t = factor * (goal.kind == GoalKind::kPosition ? o.position_tolerance : o.orientation_tolerance);
    c[problem.goals[g].level - 1] += 0.5 * goal.weight * t * t;
  }
  return c;
}

// The largest relative gain of any level not met (or of the posture) from `before` to `after`.
double progress(const TreeErrors& after, double after_posture, const TreeErrors& before, double before_posture) {
  double gain = 0.0;
  for (int l = 0; l < kMaxPriorityLevels; ++l)
    if (!before.level_met[l] && before.level_cost[l] > 0.0)
      gain = std::max(gain, (before.level_cost[l] - after.level_cost[l]) / before.level_cost[l]);
  if (before_posture > 0.0) gain = std::max(gain, (before_posture - after_posture) / before_posture);
  return gain;
}

// How far (rad) ball params `p` are outside limits `l`: the largest of swing - cone, twist - max and
// min - twist (<= 0 inside); the measure joint_within_limits tests.
double ball_excess(const JointLimits& l, const double* p) {
  const glm::dquat q = so3::exp(glm::dvec3(p[0], p[1], p[2]));
  glm::dquat swing;
  double twist = 0.0;
  so3::swing_twist(q, l.twist_axis, swing, twist);
  double excess = -so3::kPi;
  if (l.has_twist_limit) excess = std::max({excess, twist - l.twist_max, l.twist_min - twist});
  if (l.has_cone_limit) excess = std::max(excess, glm::length(so3::log(swing)) - l.cone_angle);
  return excess;
}

// Calls visit(joint, first_dof, column) for every limited joint among the active columns, once
// per joint (a ball's three columns together); stops early when visit returns true, and returns
// whether it did.
template <class Visit>
bool any_limited_joint(const Tree& tree, const TreeWorkspace& ws, int columns, Visit&& visit) {
  for (int c = 0; c < columns;) {
    const int d = ws.active_dofs[c];
    const int j = ws.dof_joint[d];
    const int width = j >= 0 ? tree.dof_count_of(j) : 1;
    if (j >= 0 && tree.has_limits(j) && visit(j, d, c)) return true;
    c += width;
  }
  return false;
}

// The column-block kernels (Cols, the right-looking Cholesky, the triangular solves, the Gram
// update) are core/math/linalg.hpp's.
using linalg::Cols;
using linalg::Pair;
using linalg::cols_of;
using linalg::cholesky_lower;
using linalg::lower_solve;
using linalg::lower_transpose_solve;
using linalg::subtract_gram_of_columns;

class HierarchicalStep {
 public:
  HierarchicalStep(const Tree& tree, const TreeProblem& problem, TreeWorkspace& ws)
      : tree_(tree), problem_(problem), ws_(ws) {
    // A settling solve (posture_iterations 0) wants the posture's settled pose, where no DOF's
    // stiffness-weighted pull is left in the goals' null space: N S (posture - q) = 0. Scaling S
    // leaves that pose where it is, so its steps take the stiffest DOF's whole way and the others
    // their shares of it: at IKBody's 0.1 the settle took 10 % a step and stopped (its gain below
    // 1e-3 of a cost the goals mostly hold) with centimetres left, which the next frames crept.
    if (!problem.posture.empty() && problem.posture_iterations <= 0 && !problem.posture_stiffness.empty()) {
      double stiffest = 0.0;
      for (int d = 0; d < problem.posture_stiffness.size; ++d)
        stiffest = std::max(stiffest, problem.posture_stiffness[d]);
      if (stiffest > 0.0) stiffness_scale_ = 1.0 / stiffest;
    }
    // Rows by level.
    int k = 0;
    for (int l = 1; l <= kMaxPriorityLevels; ++l) {
      const int first = k;
      for (int g = 0; g < problem.goals.size; ++g)
        if (problem.goals[g].level == l) ws.goal_order[k++] = g;
      if (k > first) {
        levels_.begin[levels_.count] = 3 * first;
        levels_.end[levels_.count] = 3 * k;
        ++levels_.count;
      }
    }
    rows_ = 3 * problem.goals.size;
    // The rest depends on the tree and the goals' effectors and levels alone: a tracking solve
    // finds it in ws from the frame before (4 % of a warm body solve's instructions).
    if (setup_holds()) {
      cols_ = ws.setup_columns;
      return;
    }
    // Active DOFs: those that move any goal's effector, in DOF order (a ball's three stay together).
    std::fill(ws.dof_column.begin(), ws.dof_column.end(), -1);
    for (int g = 0; g < problem.goals.size; ++g) {
      const int e = problem.goals[g].goal.effector;
      if (g > 0 && problem.goals[g - 1].goal.effector == e) continue;  // marked just now
      const int* support = tree.support_list(e);
      for (int s = 0; s < tree.support_count(e); ++s) {
        const int j = support[s];
        for (int d = 0; d < tree.dof_count_of(j); ++d) ws.dof_column[tree.dof_offset(j) + d] = 0;
        if (j == 0 && tree.floating_root())
          for (int d = 0; d < 3; ++d) ws.dof_column[d] = 0;
      }
    }
    cols_ = 0;
    for (int d = 0; d < tree.dof_count(); ++d) {
      if (ws.dof_column[d] < 0) continue;
      ws.dof_column[d] = cols_;
      ws.active_dofs[cols_] = d;
      const double cost = ws.dof_joint[d] < 0 ? tree.translation_motion_cost() : tree.motion_cost(ws.dof_joint[d]);
      ws.dof_scale[cols_] = 1.0 / std::sqrt(cost);
      ++cols_;
    }
    // Each goal's support columns as runs of adjacent columns (for_each_support_run()'s runs, the
    // adjacent ones joined: the same columns in the same order), and the columns each pair of goals
    // shares (their supports' common prefix): what gram(), rows_times() and add_rows_transpose()
    // walk, so they do not look up the tree's support lists at every call.
    const int goals = problem.goals.size;
    int* runs = ws.support_runs.data();
    int r = 0;
    for (int k = 0; k < goals; ++k) {
      ws.run_begin[k] = r;
      for_each_support_run(k, [&](int c0, int width) {
        if (r > ws.run_begin[k] && runs[2 * r - 2] + runs[2 * r - 1] == c0) {
          runs[2 * r - 1] += width;
        } else {
          runs[2 * r] = c0;
          runs[2 * r + 1] = width;
          ++r;
        }
      });
    }
    ws.run_begin[goals] = r;
    for (int a = 0; a < goals; ++a) {
      const int ea = problem.goals[ws.goal_order[a]].goal.effector;
      const int* sa = tree.support_list(ea);
      const int na = tree.support_count(ea);
      for (int b = 0; b <= a; ++b) {
        // A goal on the effector of the one before it shares what that one shares.
        if (b > 0 && same_effector(b - 1, b)) {
          ws.shared_columns[a * goals + b] = ws.shared_columns[a * goals + b - 1];
          continue;
        }
        if (a > b && same_effector(a - 1, a)) {
          ws.shared_columns[a * goals + b] = ws.shared_columns[(a - 1) * goals + b];
          continue;
        }
        const int eb = problem.goals[ws.goal_order[b]].goal.effector;
        const int* sb = tree.support_list(eb);
        const int common_end = std::min(na, tree.support_count(eb));
        int shared = 0;
        for (int s = 0; s < common_end && sa[s] == sb[s]; ++s)
          for_each_joint_run(sa[s], [&](int, int width) { shared += width; });
        ws.shared_columns[a * goals + b] = shared;
      }
    }
    ws.setup_tree = tree.serial();
    ws.setup_goal_count = goals;
    ws.setup_columns = cols_;
    for (int g = 0; g < goals; ++g) {
      ws.setup_goals[2 * g] = problem.goals[g].goal.effector;
      ws.setup_goals[2 * g + 1] = problem.goals[g].level;
    }
  }

  int columns() const { return cols_; }

 private:
  // ws holds the set-up for this tree's build and these goals' effectors and levels.
  bool setup_holds() const {
    if (tree_.serial() == 0 || ws_.setup_tree != tree_.serial() || ws_.setup_goal_count != problem_.goals.size)
      return false;
    for (int g = 0; g < problem_.goals.size; ++g)
      if (ws_.setup_goals[2 * g] != problem_.goals[g].goal.effector ||
          ws_.setup_goals[2 * g + 1] != problem_.goals[g].level)
        return false;
    return true;
  }

 public:

  // J at the pose ws holds (FK and DOF axes), scaled columns, rows in level order. Only a goal's
  // support columns are written, so an effector costs its path from the root, not the whole tree;
  // the rest of J is never read (rows_times, add_rows_transpose and gram() walk the supports,
  // column_moves() the rows of the goals a joint moves) and holds whatever it held: zeroing it
  // for every solve cost 4 % of a warm body solve's instructions.
  void linearize() {
    Eigen::MatrixXd& J = ws_.jacobian;
    for (int k = 0; k < problem_.goals.size; ++k) {
      const Goal& g = problem_.goals[ws_.goal_order[k]].goal;
      const double sw = std::sqrt(g.weight);
      const GoalLinearization lin = tree_linearize_goal(tree_, ws_, g);
      auto put = [&](int c, const glm::dvec3& col) {
        const double s = sw * ws_.dof_scale[c];
        J(3 * k, c) = s * col.x;
        J(3 * k + 1, c) = s * col.y;
        J(3 * k + 2, c) = s * col.z;
      };
      const int* support = tree_.support_list(g.effector);
      for (int i = 0; i < tree_.support_count(g.effector); ++i) {
        const int j = support[i];
        const int d0 = tree_.dof_offset(j);
        if (j == 0 && tree_.floating_root())
          for (int d = 0; d < 3; ++d) put(ws_.dof_column[d], translation_column(g.kind, ws_.dof_axes[d], lin));
        if (!turns(tree_.joint_type(j))) {
          put(ws_.dof_column[d0], translation_column(g.kind, ws_.dof_axes[d0], lin));
          continue;
        }
        const glm::dvec3 lever = lin.point - ws_.joint_origins[j];
        for (int d = d0; d < d0 + tree_.dof_count_of(j); ++d)
          put(ws_.dof_column[d], rotation_column(g.kind, ws_.dof_axes[d], lever, lin));
      }
    }
  }

  // The step (ws.step, every DOF) at damping mu from the residual rows in ws.residual, with the
  // active set of the limits; false when a factorisation failed (raise mu).
  // `served`: how many levels (in order) the step serves; the posture only when it is all of them.
  bool compute(const double* params, double mu, double posture_gain, int served) {
    served_ = served;
    // Factored for the posture whenever it serves every level, even for a step without it (a
    // polishing step, posture_gain 0): the chord step after it can then take the posture step.
    const bool posture = served == levels_.count && !problem_.posture.empty();
    for (int pass = 0; pass <= kLimitPasses; ++pass) {
      // An active-set pass repeats the Gram product and the factorisations: the budget is read
      // before it (issue 16, item 6); spent, there is no step (the caller stops).
      if (pass > 0 && ws_.deadline.spent()) return false;
      gram();  // of J as the limits leave it (correct() and chord() reuse it: the same J)
      factor(mu, posture);
      if (!solve(params, ws_.residual, posture ? posture_gain : 0.0)) return false;
      if (pass == kLimitPasses || !block_limits(params)) break;
    }
    const double fraction = fraction_to_bounds(params);
    cut_ = fraction < 1.0;
    if (cut_) ws_.step *= fraction;
    return true;
  }

  // A second-order correction (Nocedal & Wright, sec. 18.3) from a trial pose whose residual rows
  // are `trial_residual`: the same step with the Jacobian of the pose it came from. A step that
  // serves a lower level, or the posture, drifts the levels above it by its square (the null space
  // is flat only to first order); this takes the drift back without a new linearisation. Without
  // it (and the shorter posture steps of solve_tree_dls), a posture step from a pose whose goals
  // are just met pushes them out of tolerance, is refused, and the solve ends there: the posture
  // never gets back (TreeSolve.PostureMovesOnFromAStartThatAlreadyMeetsTheGoals, test_ik_body::
  // reach_and_return_leaves_no_bend_behind).
  bool correct(const double* trial_params, const Eigen::VectorXd& trial_residual) {
    return solve(trial_params, trial_residual, 0.0);
  }

  // A chord step (simplified Newton: Deuflhard, "Newton Methods for Nonlinear Problems", sec.
  // 2.1.4): the next step from `params` with the Jacobian and factors of the last compute(), for the
  // residual in ws.residual. Near a solution the Jacobian hardly changes over one step, so this
  // converges almost as fast for the price of two triangular solves per level instead of a new
  // linearisation, Gram matrix and factorisation. False (take a full step) when it would need a
  // new active set (a joint pushed out of its bound, or one reaching a bound on the way).
  bool chord(const double* params, double posture_gain) {
    if (!solve(params, ws_.residual, posture_gain) || would_block(params)) return false;
    return !(fraction_to_bounds(params) < 1.0);
  }
  // The last compute() cut its step short at a bound (a new joint joins the active set: the next
  // step needs a new J).
  bool cut() const { return cut_; }
  int served() const { return served_; }
  int level_count() const { return levels_.count; }
  double settle_scale() const { return stiffness_scale_; }  // 1 unless a settling solve's
  // The level (0-based among those with goals) that the first unmet one of `errors` is, or the
  // level count when all are met.
  int first_unmet(const TreeErrors& errors) const {
    for (int l = 0; l < levels_.count; ++l)
      if (!errors.level_met[problem_.goals[ws_.goal_order[levels_.begin[l] / 3]].level - 1]) return l;
    return levels_.count;
  }

 private:
  // Level by level with one factor of the rows above: F (ws.gram_factor) is the Cholesky factor
  // of G = M + ridge over the rows of the levels done so far, grown a level at a time by block
  // Cholesky (Golub & Van Loan, sec. 4.2.6): with W = F^-1 A Jl^T, the next level's null-space
  // matrix is K = Jl Jl^T - W^T W (the rows' projection, never formed as n x n), and F's new block
  // row is [W^T, chol(Jl Jl^T - W^T W + ridge)]. Each level costs one triangular solve with its
  // rows as right-hand sides, and the posture's projector reuses F whole.
  // Factors the levels served for damping mu (M = gram() of the current J): per level S = Jt Jt^T
  // (ws.coupling), W = F^-1 A Jl^T (F's upper triangle, free), K = chol(S + mu) (ws.row_factor),
  // and F grown by the level when a lower level (or, with_posture, the posture) projects against it.
  void factor(double mu, bool with_posture) {
    const auto M = ws_.row_square.topLeftCorner(rows_, rows_);
    auto F = ws_.gram_factor.topLeftCorner(rows_, rows_);
    const double ridge = rows_ > 0 ? kProjectorRidge * std::max(M.diagonal().maxCoeff(), 1e-300) : 0.0;
    factored_posture_ = with_posture && served_ == levels_.count;
    for (int l = 0; l < served_; ++l) {
      const int b = levels_.begin[l], m = levels_.end[l] - b;
      // S = Jt Jt^T with Jt = Jl (I - A^T G^-1 A), the level's rows in the null space above.
      // The first level has no rows above: S is M's block itself (read, never written).
      const Cols S = b == 0 ? cols_of(ws_.row_square.topLeftCorner(m, m)) : cols_of(ws_.coupling.block(b, b, m, m));
      if (b > 0)
        for (int j = 0; j < m; ++j) linalg::copy(S.col(j) + j, &M(b + j, b + j), m - j);
      const Cols W = cols_of(F.block(0, b, b, m));
      if (b > 0) {
        // W^T first, where F's new block row goes (m x b: its columns are W's rows, and gram()
        // left A Jl^T there), by one substitution over all m right-hand sides at once; then W.
        const Cols Wt = cols_of(F.block(b, 0, m, b));
        linalg::lower_solve_rows(cols_of(F), b, Wt, m);
        linalg::transpose(Wt, m, b, W);
        subtract_gram_of_columns(W, b, m, S);
      }
      const Cols K = cols_of(ws_.row_factor.block(b, b, m, m));
      for (int j = 0; j < m; ++j) {  // S + mu I (+ 0.0 off the diagonal, as S + 0 I rounds)
        K(j, j) = S(j, j) + mu;
        linalg::copy_plus(K.col(j) + j + 1, S.col(j) + j + 1, m - j - 1, 0.0);
      }
      cholesky_lower(K, m, kMinPivot2);
      if (l + 1 < served_ || (factored_posture_ && l + 1 == levels_.count)) {
        const Cols D = cols_of(F.block(b, b, m, m));  // F's block row: [W^T (in place), D]
        for (int j = 0; j < m; ++j) {
          D(j, j) = S(j, j) + ridge;
          linalg::copy_plus(D.col(j) + j + 1, S.col(j) + j + 1, m - j - 1, 0.0);
        }
        cholesky_lower(D, m, kMinPivot2);
      }
    }
  }

  // The step (ws.step) for the residual rows `residual` at `params` with the factors factor() left:
  // level by level y += Jt^T z, z = K^-1 (e_l - Jl y), Jt^T z = Jl^T z - A^T F^-T (W z); then the
  // posture in the null space of every row (when factored for it). False when not finite.
  bool solve(const double* params, const Eigen::VectorXd& residual, double posture_gain) {
    auto F = ws_.gram_factor.topLeftCorner(rows_, rows_);
    const bool posture = factored_posture_ && !problem_.posture.empty() && posture_gain > 0.0;
    double* y = ws_.dof_vec_a.data();
    std::fill(y, y + cols_, 0.0);
    for (int l = 0; l < served_; ++l) {
      const int b = levels_.begin[l], m = levels_.end[l] - b;
      double* r = ws_.row_vec_a.data() + b;
      if (l == 0) {  // y is still zero: e_l - Jl y is e_l
        for (int i = 0; i < m; ++i) r[i] = residual[b + i];
      } else {
        rows_times(b, m, y, r);
        for (int i = 0; i < m; ++i) r[i] = residual[b + i] - r[i];
      }
      const Cols K = cols_of(ws_.row_factor.block(b, b, m, m));
      lower_solve(K, m, r);
      lower_transpose_solve(K, m, r);
      add_rows_transpose(b, m, r, 1.0, y);
      if (b > 0) {
        const auto W = F.block(0, b, b, m);
        auto w = ws_.row_vec_b.head(b);
        w.noalias() = W * ws_.row_vec_a.segment(b, m);
        lower_transpose_solve(cols_of(F), b, w.data());
        add_rows_transpose(0, b, w.data(), -1.0, y);
      }
    }
    if (posture) {
      double* v = ws_.dof_vec_b.data();
      for (int c = 0; c < cols_; ++c) {
        const int d = ws_.active_dofs[c];
        v[c] = posture_gain * stiffness(d) * (problem_.posture[d] - params[d]) / ws_.dof_scale[c];
      }
      if (rows_ > 0) {
        double* u = ws_.row_vec_b.data();
        rows_times(0, rows_, v, u);
        lower_solve(cols_of(F), rows_, u);
        lower_transpose_solve(cols_of(F), rows_, u);
        add_rows_transpose(0, rows_, u, -1.0, v);
      }
      for (int c = 0; c < cols_; ++c) y[c] += v[c];
    }
    ws_.step.setZero();
    for (int c = 0; c < cols_; ++c) ws_.step[ws_.active_dofs[c]] = ws_.dof_scale[c] * y[c];
    // A DOF no goal depends on goes its whole share whatever the posture's gain: the gain shortens
    // steps that drift the goals, which this one cannot.
    if (posture)
      for (int d = 0; d < tree_.dof_count(); ++d)
        if (!is_active(d)) ws_.step[d] = stiffness(d) * (problem_.posture[d] - params[d]);
    return ws_.step.allFinite();
  }

  // Calls f(first_column, width) for joint j's runs of J's columns: a floating root's translation
  // (with joint 0), then the joint's own DOFs (adjacent: active_dofs keeps the DOF order).
  template <class F>
  void for_each_joint_run(int j, F&& f) const {
    if (j == 0 && tree_.floating_root()) f(ws_.dof_column[0], 3);
    const int width = tree_.dof_count_of(j);
    if (width > 0) f(ws_.dof_column[tree_.dof_offset(j)], width);
  }
  // ... for each run that goal k's rows (in level order) can be nonzero in: its effector's support
  // (the rest of the row is zero, see linearize()).
  template <class F>
  void for_each_support_run(int k, F&& f) const {
    const int e = problem_.goals[ws_.goal_order[k]].goal.effector;
    const int* support = tree_.support_list(e);
    for (int s = 0; s < tree_.support_count(e); ++s) for_each_joint_run(support[s], f);
  }
  // Goals k and l (in level order) act on one effector: their supports, and runs, are the same.
  bool same_effector(int k, int l) const {
    return problem_.goals[ws_.goal_order[k]].goal.effector == problem_.goals[ws_.goal_order[l]].goal.effector;
  }
  // out[i] = (row first + i of J) . x for the `count` rows from `first` (whole goals), over the
  // supports only: a foot's rows touch the hips and one leg, a few of the tree's columns. Two rows
  // per operation (linalg::Pair), each summing its products in column order.
  void rows_times(int first, int count, const double* x, double* out) const {
    using linalg::load2;
    const double* J = ws_.jacobian.data();
    const Eigen::Index ld = ws_.jacobian.outerStride();
    const int* runs = ws_.support_runs.data();
    const int end = (first + count) / 3;
    for (int k = first / 3; k < end; ++k) {
      double* o = out + 3 * k - first;
      if (k + 1 < end && same_effector(k, k + 1)) {  // two goals on one effector: one pass
        Pair o01 = Pair::Zero(), o23 = Pair::Zero(), o45 = Pair::Zero();
        for (int r = ws_.run_begin[k]; r < ws_.run_begin[k + 1]; ++r) {
          const int c0 = runs[2 * r], c1 = c0 + runs[2 * r + 1];
          for (int c = c0; c < c1; ++c) {
            const double* col = J + c * ld + 3 * k;
            const Pair xc = Pair::Constant(x[c]);
            o01 += load2(col) * xc, o23 += load2(col + 2) * xc, o45 += load2(col + 4) * xc;
          }
        }
        linalg::store2(o, o01), linalg::store2(o + 2, o23), linalg::store2(o + 4, o45);
        ++k;
        continue;
      }
      Pair o01 = Pair::Zero();
      double o2 = 0.0;
      for (int r = ws_.run_begin[k]; r < ws_.run_begin[k + 1]; ++r) {
        const int c0 = runs[2 * r], c1 = c0 + runs[2 * r + 1];
        for (int c = c0; c < c1; ++c) {
          const double* col = J + c * ld + 3 * k;
          o01 += load2(col) * Pair::Constant(x[c]);
          o2 += col[2] * x[c];
        }
      }
      linalg::store2(o, o01);
      o[2] = o2;
    }
  }
  // y += sign (rows first .. first + count of J)^T x, over the supports only; two columns per
  // operation (linalg::Pair), each y[c] summing as the scalar expression does.
  void add_rows_transpose(int first, int count, const double* x, double sign, double* y) const {
    using linalg::load2;
    const double* J = ws_.jacobian.data();
    const Eigen::Index ld = ws_.jacobian.outerStride();
    const int* runs = ws_.support_runs.data();
    const int end = (first + count) / 3;
    // Entry i of columns c and c + 1 (col points at column c's).
    auto across = [ld](const double* col, int i) { return Pair(col[i], col[i + ld]); };
    for (int k = first / 3; k < end; ++k) {
      const double* xk = x + 3 * k - first;
      const double x0 = sign * xk[0], x1 = sign * xk[1], x2 = sign * xk[2];
      const Pair v0 = Pair::Constant(x0), v1 = Pair::Constant(x1), v2 = Pair::Constant(x2);
      if (k + 1 < end && same_effector(k, k + 1)) {  // two goals on one effector: one pass, y[c]
        const double x3 = sign * xk[3], x4 = sign * xk[4], x5 = sign * xk[5];  // gets k's, then k + 1's
        const Pair v3 = Pair::Constant(x3), v4 = Pair::Constant(x4), v5 = Pair::Constant(x5);
        for (int r = ws_.run_begin[k]; r < ws_.run_begin[k + 1]; ++r) {
          const int c0 = runs[2 * r], c1 = c0 + runs[2 * r + 1];
          int c = c0;
          for (; c + 2 <= c1; c += 2) {
            const double* col = J + c * ld + 3 * k;
            const Pair yk = load2(y + c) + (across(col, 0) * v0 + across(col, 1) * v1 + across(col, 2) * v2);
            linalg::store2(y + c, yk + (across(col, 3) * v3 + across(col, 4) * v4 + across(col, 5) * v5));
          }
          if (c < c1) {
            const double* col = J + c * ld + 3 * k;
            const double yk = y[c] + (col[0] * x0 + col[1] * x1 + col[2] * x2);
            y[c] = yk + (col[3] * x3 + col[4] * x4 + col[5] * x5);
          }
        }
        ++k;
        continue;
      }
      for (int r = ws_.run_begin[k]; r < ws_.run_begin[k + 1]; ++r) {
        const int c0 = runs[2 * r], c1 = c0 + runs[2 * r + 1];
        int c = c0;
        for (; c + 2 <= c1; c += 2) {
          const double* col = J + c * ld + 3 * k;
          linalg::store2(y + c, load2(y + c) + (across(col, 0) * v0 + across(col, 1) * v1 + across(col, 2) * v2));
        }
        if (c < c1) {
          const double* col = J + c * ld + 3 * k;
          y[c] += col[0] * x0 + col[1] * x1 + col[2] * x2;
        }
      }
    }
  }

  // True when J's column c (a DOF of joint j) is nonzero in the rows of a goal whose effector j
  // moves: the only rows linearize() writes there.
  bool column_moves(int c, int j) const {
    const double* col = ws_.jacobian.col(c).data();
    for (int k = 0; k < problem_.goals.size; ++k)
      if (tree_.supports(problem_.goals[ws_.goal_order[k]].goal.effector, j) &&
          (col[3 * k] != 0.0 || col[3 * k + 1] != 0.0 || col[3 * k + 2] != 0.0))
        return true;
    return false;
  }
  // True when the step in ws.step pushes a joint out of a bound it rests on that J still moves
  // (block_limits() would change J).
  bool would_block(const double* params) const {
    return any_limited_joint(tree_, ws_, cols_, [&](int j, int d, int c) {
      if (is_one_dof(tree_.joint_type(j)))
        return one_dof_blocked(tree_.joint_type(j), tree_.limits(j), params[d], ws_.step[d]) &&
               column_moves(c, j);
      glm::dvec3 normals[2];
      return ball_params_blocked(tree_.limits(j), params + d, ws_.step.data() + d, normals) > 0;
    });
  }

  // M = J J^T from the tree's structure: goals a and b share only the columns of their common
  // supports, which are the common prefix of their root-first support lists (Pinocchio's
  // "supports"), so each 3x3 block sums over those few columns instead of all of them. A joint's
  // columns are adjacent (active_dofs keeps the DOF order), so a block sums 3 x 3 products per
  // joint, in registers. The blocks within a level go to M (ws.row_square); those of a level's
  // rows against the rows above it (A Jl^T, transposed) straight to where factor() turns them
  // into W^T in place: F's block row of the level (ws.gram_factor, the same shape as M).
  void gram() const {
    const double* J = ws_.jacobian.data();
    const Eigen::Index ld = ws_.jacobian.outerStride();
    const int goals = problem_.goals.size;
    const int* runs = ws_.support_runs.data();
    const Eigen::Index ld_m = ws_.row_square.outerStride();
    double* const M = ws_.row_square.data();
    double* const F = ws_.gram_factor.data();
    // Where entry (row, column) of block (a, b) goes: F when b's rows lie above a's level.
    auto at = [&](int a, int b, int level_begin) { return (3 * b < level_begin ? F : M) + 3 * a + 3 * b * ld_m; };
    // Calls add(column) for goal a's first shared_columns(a, b) columns: the runs of the supports'
    // common prefix, in order.
    auto for_shared_columns = [&](int a, int b, auto&& add) {
      for (int r = ws_.run_begin[a], left = ws_.shared_columns[a * goals + b]; left > 0; ++r) {
        const int width = std::min(runs[2 * r + 1], left);
        for (int c = runs[2 * r]; c < runs[2 * r] + width; ++c) add(J + c * ld);
        left -= width;
      }
    };
    // Block (a, b) only: factor() reads M's lower triangle alone (b <= a; a diagonal block's upper
    // entries are written too, and never read). Two entries per operation (linalg::Pair): (b00,
    // b10), (b01, b11), (b02, b12), (b20, b21), then b22 alone; each entry gets the same products
    // added in the same order as a scalar sum, so it rounds as one.
    auto block = [&](int a, int b, int level_begin) {
      Pair p0 = Pair::Zero(), p1 = Pair::Zero(), p2 = Pair::Zero(), q = Pair::Zero();
      double b22 = 0.0;
      for_shared_columns(a, b, [&](const double* col) {
        const Pair a01 = linalg::load2(col + 3 * a), c01 = linalg::load2(col + 3 * b);
        const double a2 = col[3 * a + 2], c0 = col[3 * b], c1 = col[3 * b + 1], c2 = col[3 * b + 2];
        p0 += a01 * Pair::Constant(c0);
        p1 += a01 * Pair::Constant(c1);
        p2 += a01 * Pair::Constant(c2);
        q += Pair::Constant(a2) * c01;
        b22 += a2 * c2;
      });
      double* m = at(a, b, level_begin);
      linalg::store2(m, p0);
      linalg::store2(m + ld_m, p1);
      linalg::store2(m + 2 * ld_m, p2);
      m[2] = q[0];
      m[2 + ld_m] = q[1];
      m[2 + 2 * ld_m] = b22;
    };
    // Blocks (a, b) and (a + 1, b) at once, for goals a and a + 1 on one effector (the same
    // support, so the same shared columns): their six rows in three pairs times each of b's three
    // rows, each entry summed as block() sums it.
    auto block_pair = [&](int a, int b, int level_begin) {
      Pair p00 = Pair::Zero(), p01 = Pair::Zero(), p02 = Pair::Zero();
      Pair p10 = Pair::Zero(), p11 = Pair::Zero(), p12 = Pair::Zero();
      Pair p20 = Pair::Zero(), p21 = Pair::Zero(), p22 = Pair::Zero();
      for_shared_columns(a, b, [&](const double* col) {
        const Pair r0 = linalg::load2(col + 3 * a), r1 = linalg::load2(col + 3 * a + 2),
                   r2 = linalg::load2(col + 3 * a + 4);
        const Pair c0 = Pair::Constant(col[3 * b]), c1 = Pair::Constant(col[3 * b + 1]),
                   c2 = Pair::Constant(col[3 * b + 2]);
        p00 += r0 * c0, p10 += r1 * c0, p20 += r2 * c0;
        p01 += r0 * c1, p11 += r1 * c1, p21 += r2 * c1;
        p02 += r0 * c2, p12 += r1 * c2, p22 += r2 * c2;
      });
      double* m = at(a, b, level_begin);  // rows 3a .. 3a + 5 of columns 3b .. 3b + 2
      linalg::store2(m, p00), linalg::store2(m + 2, p10), linalg::store2(m + 4, p20);
      m += ld_m;
      linalg::store2(m, p01), linalg::store2(m + 2, p11), linalg::store2(m + 4, p21);
      m += ld_m;
      linalg::store2(m, p02), linalg::store2(m + 2, p12), linalg::store2(m + 4, p22);
    };
    int level = 0;
    for (int a = 0; a < goals; ++a) {
      while (3 * a >= levels_.end[level]) ++level;
      const int level_begin = levels_.begin[level];
      // Two goals on one effector in one level (a level boundary between them: one at a time).
      if (a + 1 < goals && same_effector(a, a + 1) && 3 * (a + 1) < levels_.end[level]) {
        for (int b = 0; b <= a; ++b) block_pair(a, b, level_begin);
        ++a;
        block(a, a, level_begin);
        continue;
      }
      for (int b = 0; b <= a; ++b) block(a, b, level_begin);
    }
  }

  // The largest fraction (<= 1) of the step that leaves every limited joint within its limits: a
  // step the limits' projection cut short would leave the null spaces (the levels it was
  // projected for would drift by first order); one cut to the first bound keeps its direction,
  // and the joint that reached its bound joins the active set at the next step. Balls by bisection
  // on their limits. Never below kMinFraction (the projection takes the rest).
  double fraction_to_bounds(const double* params) const {
    constexpr double kMinFraction = 0.05;
    constexpr double kSlack = 1e-9;  // rad: joint_within_limits' default
    double fraction = 1.0;
    any_limited_joint(tree_, ws_, cols_, [&](int j, int d, int) {
      const JointLimits& l = tree_.limits(j);
      const double* s = ws_.step.data() + d;
      if (is_one_dof(tree_.joint_type(j))) {
        const ParamRange range = param_range(tree_.joint_type(j), l);
        const double to = s[0] > 0.0 ? range.max - params[d] : range.min - params[d];
        if (s[0] != 0.0 && std::abs(s[0]) > std::abs(to)) fraction = std::min(fraction, std::max(to / s[0], 0.0));
        return false;
      }
      // A ball resting on its boundary slides along it (the active set took the outward part): the
      // projection takes back what the curved boundary adds, a second-order amount.
      double p[3] = {params[d] + s[0], params[d + 1] + s[1], params[d + 2] + s[2]};
      if (!ball_surely_inside(l, p) && !joint_within_limits(JointType::kBall, l, p, kSlack) &&
          !ball_params_on_boundary(l, params + d)) {
        // The largest t in [0, 1] with params + t step within the limits: regula falsi with the
        // Illinois modification (Dowell & Jarratt 1971) on h(t) = excess - kSlack / 2, which is
        // <= 0 at 0 and > 0 at 1; it ends inside, within kSlack / 2 of the bound, in a handful of
        // evaluations where bisection took 20.
        auto h = [&](double t) {
          for (int i = 0; i < 3; ++i) p[i] = params[d + i] + t * s[i];
          return ball_excess(l, p) - 0.5 * kSlack;
        };
        double lo = 0.0, hi = 1.0, h_lo = h(0.0), h_hi = h(1.0);
        int side = 0;
        for (int k = 0; k < 20 && h_lo < 0.0 && hi - lo > 1e-7; ++k) {
          const double t = std::clamp((lo * h_hi - hi * h_lo) / (h_hi - h_lo), lo, hi);
          const double ht = h(t);
          if (ht <= 0.0) {
            lo = t, h_lo = ht;
            if (side < 0) h_hi *= 0.5;
            side = -1;
            if (ht > -0.5 * kSlack) break;
          } else {
            hi = t, h_hi = ht;
            if (side > 0) h_lo *= 0.5;
            side = 1;
          }
        }
        fraction = std::min(fraction, h_lo <= 0.0 ? lo : 0.0);
      }
      return false;
    });
    return std::max(fraction, kMinFraction);
  }

  // Marks the DOFs the step pushes out of a bound they rest on and removes them from J; true when
  // anything new was blocked (the step is then computed again).
  bool block_limits(const double* params) {
    bool changed = false;
    any_limited_joint(tree_, ws_, cols_, [&](int j, int d, int c) {
      if (is_one_dof(tree_.joint_type(j))) {
        if (one_dof_blocked(tree_.joint_type(j), tree_.limits(j), params[d], ws_.step[d]) &&
            column_moves(c, j)) {
          ws_.jacobian.col(c).head(rows_).setZero();
          changed = true;
        }
        return false;
      }
      glm::dvec3 normals[2];
      const int count = ball_params_blocked(tree_.limits(j), params + d, ws_.step.data() + d, normals);
      for (int k = 0; k < count; ++k) remove_ball_direction(ws_.jacobian, rows_, c, normals[k]);
      changed = changed || count > 0;
      return false;
    });
    return changed;
  }


  double stiffness(int d) const {
    return problem_.posture_stiffness.empty() ? 1.0 : stiffness_scale_ * problem_.posture_stiffness[d];
  }
  bool is_active(int d) const { return ws_.dof_column[d] >= 0; }

  const Tree& tree_;
  const TreeProblem& problem_;
  TreeWorkspace& ws_;
  Levels levels_;
  int rows_ = 0, cols_ = 0;
  int served_ = 0;
  bool factored_posture_ = false;  // factor() grew F over every row (the posture's projector)
  double stiffness_scale_ = 1.0;    // a settling solve's: 1 / the largest stiffness
  bool cut_ = false;
};

// params + step, a ball's rotation vector kept at angle <= pi, each joint's turn capped at
// max_step_angle (0 = none); then onto the limits.
void make_trial(const Tree& tree, const SolverOptions& o, const double* params, const double* step, double* trial) {
  const int n = tree.dof_count();
  for (int d = 0; d < n; ++d) trial[d] = params[d] + step[d];
  for (int j = 0; j < tree.joint_count(); ++j) {
    const int d = tree.dof_offset(j);
    if (!is_one_dof(tree.joint_type(j))) {
      glm::dvec3 s(step[d], step[d + 1], step[d + 2]);
      if (o.max_step_angle > 0.0) {  // the length only then (by default there is no cap)
        const double len = glm::length(s);
        if (len > o.max_step_angle) s *= o.max_step_angle / len;
      }
      const glm::dvec3 r = so3::wrap_rotation_vector(glm::dvec3(params[d], params[d + 1], params[d + 2]) + s);
      trial[d] = r.x;
      trial[d + 1] = r.y;
      trial[d + 2] = r.z;
    } else if (turns(tree.joint_type(j)) && o.max_step_angle > 0.0) {  // a slide's metres: no cap
      trial[d] = params[d] + std::clamp(step[d], -o.max_step_angle, o.max_step_angle);
    }
  }
  project_tree_to_limits(tree, trial);
}

// True when an active joint rests on a bound of its limits (a hinge or slide on its range, a ball
// on its cone or a twist bound).
bool any_pinned(const Tree& tree, const TreeWorkspace& ws, int columns, const double* params) {
  return any_limited_joint(tree, ws, columns, [&](int j, int d, int) {
    return joint_params_at_limit(tree.joint_type(j), tree.limits(j), params + d);
  });
}

}  // namespace

TreeSolverStatus solve_tree_dls(const Tree& tree, const TreeProblem& problem, const SolverOptions& o,
                                TreeWorkspace& ws, double* params, const TreeErrors& start) {
  TreeSolverStatus status;
  const int n = tree.dof_count();
  HierarchicalStep model(tree, problem, ws);
  double* residual = ws.residual.data();
  // Every FK pass goes through here: whether ws holds the FK of ws.params_trial (else of params,
  // which changes only with an FK pass after it, or the best pose's return at the end).
  bool fk_of_trial = false;
  auto forward = [&](const double* p) {
    tree_forward_kinematics(tree, p, ws);
    fk_of_trial = p == ws.params_trial.data();
  };

  // ws holds the FK of params, solve_tree() measured it: its residual rows, in goal order, go
  // to level order (the measure in level order sums each level's goals in the same order).
  TreeErrors current = start;
  for (int k = 0; k < problem.goals.size; ++k)
    for (int i = 0; i < 3; ++i) residual[3 * k + i] = ws.residual_trial[3 * ws.goal_order[k] + i];
  double current_posture = posture_cost(tree, problem, params);
  tree_dof_axes(tree, params, ws, true);
  model.linearize();

  // The damping starts at dls_initial_damping, or at kResidualDamping |e|^2 when that is smaller
  // (Yamashita & Fukushima 2001; Fan & Yuan 2005: mu = theta |e|^2 keeps Levenberg-Marquardt
  // quadratically convergent near a solution): a warm start from the previous frame's pose is millimetres off,
  // where the Gauss-Newton step is already accurate and a fixed damping would only slow it down
  // (one more iteration per frame); from far away it changes nothing.
  const double initial_mu =
      std::clamp(std::min(o.dls_initial_damping, kResidualDamping * 2.0 * current.cost), o.dls_min_damping, o.dls_max_damping);
  double mu = initial_mu;
  double nu = 2.0;
  double posture_gain = 1.0;
  // posture_iterations > 0: the accepted steps that carried the posture from a pose within the
  // relaxed band; once there are posture_iterations of them, the steps serve the goals alone.
  const bool posture_capped = !problem.posture.empty() && problem.posture_iterations > 0;
  int posture_steps = 0;
  stuck::StallRule stall;  // by each accepted step's lexicographic gain (stalled_after_gain)
  // The best pose seen (lexicographically): escapes may leave it, the result returns to it.
  std::copy(params, params + n, ws.params_best.data());
  ws.goal_error_best.head(problem.goals.size) = ws.goal_error.head(problem.goals.size);
  TreeErrors best = current;
  double best_posture = current_posture;
  const LevelCosts relaxed = met_costs(problem, o, kRelaxedTolerances);
  const LevelCosts chord_polish = met_costs(problem, o, kChordPolishTolerances);
  const LevelCosts strict{};  // met is each goal within its tolerance (TreeErrors::level_met)
  // One level has nothing to relax for.
  const LevelCosts* met_cost = model.level_count() > 1 ? &relaxed : &strict;
  // Stuck in the relaxed phase: go on strictly from here (true), or it was the strict one (false).
  // Stuck: escape and go on from the new pose (true), or no escape left (false).
  auto escape_stuck = [&]() {
    if (status.escapes >= kMaxEscapes) return false;
    ++status.escapes;
    met_cost = model.level_count() > 1 ? &relaxed : &strict;
    // Stuck with goals unmet (the stall rule, no acceptable step at any damping, or a creep with a
    // joint on a bound): the trees' one escape (tree_common.hpp) - a straight knee on its limit is
    // a minimum no first-order step leaves, and neither is "down" for the hips above it.
    if (!tree_common::escape(tree, ws, model.columns(), status.escapes, params)) return false;
    forward(params);
    current = tree_measure(tree, problem, o, ws, ws.goal_order.data(), ws.residual.data(), ws.goal_error.data());
    residual = ws.residual.data();
    current_posture = posture_cost(tree, problem, params);
    tree_dof_axes(tree, params, ws, true);
    model.linearize();
    mu = initial_mu;
    nu = 2.0;
    posture_gain = 1.0;
    stall.reset(INFINITY);
    return true;
  };
  auto tighten = [&]() {
    if (met_cost == &strict) return false;
    met_cost = &strict;
    mu = initial_mu;
    nu = 2.0;
    stall.reset(INFINITY);
    return true;
  };
  bool chord = false;  // the next step is a chord step (model.chord())
  int posture_chords = 0;  // chord steps in a row that posture steps earned (kMaxPostureChords)
  status.reason = TerminationReason::kMaxIterations;
  for (int it = 1; it <= o.max_iterations; ++it) {
    if (ws.deadline.spent()) break;  // the time budget: kMaxIterations
    status.iterations = it;
    // Relaxed: every level at once. Strict: lexicographic Gauss-Newton, the levels down to the first
    // one not met (a lower level's step would only drift it).
    const int served = met_cost == &strict ? std::min(model.first_unmet(current) + 1, model.level_count())
                                           : model.level_count();
    // Polishing: goals only. A posture step drifts the goals by its square, so with it the polish
    // converged linearly (a few per cent an iteration on a tracking frame, for as long as the
    // posture moved). Uncapped, the solve polishes whenever every level is within the relaxed band
    // but not every goal is met (a step or two), then takes posture steps once every goal is met.
    // Capped (posture_iterations), the posture rides on the goal steps - a tracking frame's first
    // step both follows the targets and pulls toward the posture, so one linearisation often
    // serves the whole frame - until it has had its steps near the goals; then the goals alone.
    const bool near = within(current, relaxed);
    const bool posture_spent = posture_capped && posture_steps >= problem.posture_iterations;
    const bool polishing =
        !problem.posture.empty() && (posture_capped ? posture_spent : !current.all_met() && near);
    // A settling solve's posture takes its whole way only near the goals: riding on the steps that
    // still bring them in, it got the steps refused (a settle cut to a few iterations a frame by a
    // time budget then never came near).
    const double step_posture_gain =
        polishing ? 0.0 : (near ? posture_gain : posture_gain / model.settle_scale());
    // After a step that removed most of the cost the next one is a chord step (the same J and
    // factors); when that needs a new active set, or falls short, J is linearised afresh.
    bool chorded = false;
    if (chord) {
      chord = false;
      chorded = served == model.served() && model.chord(params, step_posture_gain);
      if (!chorded) {
        tree_dof_axes(tree, params, ws, true);  // ws holds the FK of params (the accepted trial's)
        model.linearize();
        if (ws.deadline.spent()) break;  // between the linearisation and the step's factorisation
      }
    }
    // A capped posture step from near the goals (posture_iterations) may leave them anywhere within
    // the relaxed band if it brings the pose nearer the posture: the goals-only steps after it
    // take the drift back quadratically (a 0.2 rad spine step drifts a hand a centimetre, which
    // the strict comparison refused, so the posture crept a few per cent a frame); the solve ends
    // with its goals met (or returns the best pose, which met them).
    const bool posture_may_drift = posture_capped && near && step_posture_gain > 0.0;
    auto accept = [&](const TreeErrors& t, double t_posture) {
      if (posture_may_drift && within(t, relaxed) && t_posture < current_posture * (1.0 - kSameCost)) return true;
      return better(t, t_posture, current, current_posture, *met_cost);
    };
    bool trial_ok = chorded || model.compute(params, mu, step_posture_gain, served);
    // Between the step's factorisations and its trial (an FK pass and the measure): a budget spent
    // there leaves the step untaken and the pose as it was (issue 16, item 6).
    if (ws.deadline.hit || (!chorded && trial_ok && ws.deadline.spent())) break;
    TreeErrors trial;
    double trial_posture = 0.0;
    const bool trial_computed = trial_ok;
    if (trial_ok) {
      make_trial(tree, o, params, ws.step.data(), ws.params_trial.data());
      forward(ws.params_trial.data());
      trial = tree_measure(tree, problem, o, ws, ws.goal_order.data(), ws.residual_trial.data(),
                           ws.goal_error_trial.data());
      trial_posture = posture_cost(tree, problem, ws.params_trial.data());
      trial_ok = accept(trial, trial_posture);
      if (!trial_ok && (model.level_count() > 1 || !problem.posture.empty()) && !ws.deadline.spent() &&
          model.correct(ws.params_trial.data(), ws.residual_trial)) {
        // ws.step now holds the correction: the trial moves by it (dof_vec_b keeps the first trial).
        ws.dof_vec_b = ws.params_trial;
        make_trial(tree, o, ws.dof_vec_b.data(), ws.step.data(), ws.params_trial.data());
        forward(ws.params_trial.data());
        trial = tree_measure(tree, problem, o, ws, ws.goal_order.data(), ws.residual_trial.data(),
                           ws.goal_error_trial.data());
        trial_posture = posture_cost(tree, problem, ws.params_trial.data());
        trial_ok = accept(trial, trial_posture);
      }
    }
    if (!trial_ok && chorded) {
      // The chord step fell short: a full step from a fresh J (the damping stays).
      forward(params);
      if (ws.deadline.spent()) break;  // before the next linearisation (issue 16, item 6)
      tree_dof_axes(tree, params, ws, true);
      model.linearize();
      continue;
    }
    if (trial_ok) {
      const bool was_met = current.all_met();
      const double gain = progress(trial, trial_posture, current, current_posture);
      // The stall and creep rules ask the first unmet level the step moved (the posture when it
      // moved none): while a higher level moves, a lower level's or the posture's gain is no
      // progress. Counted as progress, their swing up and down (the hands' error trading against
      // the feet's) hid a creep held by the limits for the whole iteration budget (a cold start
      // with straight knees).
      const double stall_gain = lexicographic_gain(trial, current, gain);
      std::copy(ws.params_trial.data(), ws.params_trial.data() + n, params);
      std::swap(ws.residual, ws.residual_trial);
      ws.goal_error.swap(ws.goal_error_trial);
      residual = ws.residual.data();
      current = trial;
      current_posture = trial_posture;
      if (better(current, current_posture, best, best_posture, strict)) {
        std::copy(params, params + n, ws.params_best.data());
        ws.goal_error_best.head(problem.goals.size) = ws.goal_error.head(problem.goals.size);
        best = current;
        best_posture = current_posture;
      }
      // Down by a third; within the relaxed band of the goals no higher than the residual's rule
      // for the first damping: joints a motion cost makes reluctant have short scaled columns,
      // which a damping that only fell by thirds held back, so the polish converged linearly (a
      // fifth of the error a step) instead of quadratically.
      const bool landed_near = within(current, relaxed);
      mu = std::max(mu / 3.0, o.dls_min_damping);
      if (landed_near) mu = std::max(std::min(mu, kResidualDamping * 2.0 * current.cost), o.dls_min_damping);
      nu = 2.0;
      // A step that carried the posture counts toward posture_iterations when it started near the
      // goals or landed near them: a tracking frame's first step (targets centimetres away) both
      // follows them and pulls toward the posture, and the next step polishes. A cold start's
      // steps from far away count only once they arrive.
      if ((near || landed_near) && step_posture_gain > 0.0) ++posture_steps;
      // Settling, the posture's gain below 1e-3 of its cost ends it. The goals hold most of that
      // cost, so this stops with some way left that tracking frames creep (a still IKBody humanoid
      // 1.8 mm, then 0.8 mm a frame). A rule on the step's size went the whole way but changed the
      // settled arm of a replayed T-pose enough that the next frame flipped its elbow's plane.
      const bool posture_settled =
          problem.posture.empty() || (posture_capped ? posture_steps >= problem.posture_iterations : gain < 1e-3);
      if (current.all_met() && posture_settled) {
        status.reason = TerminationReason::kConverged;
        break;
      }
      const bool stalled = stall.stalled_after_gain(stall_gain, o.stall_tolerance);
      const bool goals_left = !current.all_met();
      if (stalled) {
        if (goals_left && (tighten() || escape_stuck())) continue;
        status.reason = goals_left ? TerminationReason::kStalled : TerminationReason::kConverged;
        break;
      }
      if (goals_left && stall.creeping() &&
          (tighten() || (any_pinned(tree, ws, model.columns(), params) && escape_stuck())))
        continue;
      if (ws.deadline.spent()) break;  // before the next linearisation (issue 16, item 6)
      const bool kept_met = was_met && current.all_met() && step_posture_gain > 0.0;
      posture_chords = chorded && kept_met ? posture_chords + 1 : 0;
      // The capped posture's last step moved the pose along the posture's pull, off the goals'
      // linearisation: a chord step from the old J contracts the error only linearly. Left farther
      // than kChordPolishTolerances from the goals, the polish starts from a fresh J.
      const bool posture_just_spent =
          posture_capped && step_posture_gain > 0.0 && posture_steps >= problem.posture_iterations &&
          !within(current, chord_polish);
      if (!posture_just_spent && !model.cut() &&
          (gain >= kChordGain || (kept_met && posture_chords < kMaxPostureChords))) {
        chord = true;  // the next iteration reuses J
      } else {
        tree_dof_axes(tree, params, ws, true);  // FK of params is what ws holds (the trial's)
        model.linearize();
      }
    } else {
      if (current.all_met()) {
        // Only the posture was left. Its step drifts the goals by its square: a shorter one may keep
        // them met; below kMinPostureGain it goes as far as the goals allow; a short one
        // (kPostureSettledStep) finds it settled.
        // The refused trial's largest param change (params_trial still holds it); infinite when
        // there was no trial.
        double moved = trial_computed ? 0.0 : INFINITY;
        if (trial_computed)
          for (int d = 0; d < n; ++d) moved = std::max(moved, std::abs(ws.params_trial[d] - params[d]));
        if (!problem.posture.empty() && posture_gain > kMinPostureGain && !posture_spent &&
            moved > kPostureSettledStep) {
          posture_gain *= 0.25;
          forward(params);  // ws holds the trial's FK
          continue;
        }
        status.reason = TerminationReason::kConverged;
        break;
      }
      if (mu >= o.dls_max_damping) {
        if (tighten() || escape_stuck()) continue;
        status.reason = TerminationReason::kStalled;
        break;
      }
      mu = std::min(mu * nu, o.dls_max_damping);
      nu *= 2.0;
      posture_gain *= 0.5;
      // ws holds the trial's FK: the next step needs the accepted pose's (its J is kept).
      forward(params);
    }
  }
  const bool returns_best = better(best, best_posture, current, current_posture, strict);
  if (returns_best) std::copy(ws.params_best.data(), ws.params_best.data() + n, params);
  status.fk_of_params = fk_of_trial ? std::equal(params, params + n, ws.params_trial.data()) : !returns_best;
  // current measures params, best params_best (in level order, as solve_tree() measures them).
  status.measured = true;
  status.errors = returns_best ? best : current;
  if (returns_best) ws.goal_error.head(problem.goals.size) = ws.goal_error_best.head(problem.goals.size);
  return status;
}

}  // namespace ikchain
