// What every iterative solver (CCD, FABRIK, the pseudo-inverse, DLS, BFGS) does when it stops
// making progress, in one place:
//  - StallRule: the one stall rule. An iteration "counts" when it lowers the best cost seen by
//    less than stall_tolerance (relative to that best); kStallIterations such iterations in a row
//    mean the solve is stuck. Measured against the best cost rather than the previous iteration's,
//    so a method whose cost is not monotone (FABRIK on hinge chains) needs no longer window. It
//    also tells a creep (kStallIterations iterations in a row each gaining < kCreepGain): still
//    progress, but for the Newton-like solvers mostly a trap approached slowly (see kCreepGain);
//    one kLongCreep long is escaped wherever it is by a query (creep_is_long).
//  - Escapes: the one stuck -> escape move, and the best pose seen (so an escape that ends worse
//    never costs the caller anything). A solver calls escape() when the stall rule fires, or on a
//    condition of its own that means the same (no acceptable step at all, a vanishing gradient, a
//    sweep that moves nothing); escape() refuses when the budget (kMaxEscapes per solve, and
//    kFarEscapes more for a query) is spent
//    or the goals are provably out of reach (then the stuck pose is the best reach), and the
//    solver stops as kStalled.
// When joints rest on their bounds (first and third escape), the move first takes them off (across
// a full-turn range to the same angle at its other end, else into the range; see unpin()): a
// minimum the bounds hold is a constrained one that no null-space move leaves.
// In a query, a hinge that an accepted step left on a full-turn bound crosses it at once (Loop::
// after_accepted, Escapes::cross_full_turn_bounds): the same pose, the wall behind it. Left there,
// the descent crawled along the wall, 1-4 % a step, into minima the bound held (issue 16, item 20).
// When kFruitlessBeforeFar escapes in a row led back into the minimum they left, the next one of a
// query (cold_query(): started far from its goals, no restart follows) is far (far()): a
// deterministic pose spread over the limits, a restart's move inside the solve (issue 16, item 20:
// a torso + arm with its elbow on the wrong branch). A tracking frame never jumps so.
// Otherwise the move stays in the null space of J, so to first order it keeps the effectors where
// they are and changes only the configuration: first a step toward the rest pose (the
// pseudo-inverse's classic secondary task: Liegeois 1977; Buss 2004, sec. 4), which e.g. untwists a
// chain caught at a singular saddle. Where that does not leave the stationary point (at the rest
// pose itself, or with the limits in the way), a fixed, deterministic direction (the kick)
// projected the same way, with the sign that pushes no hinge resting on a bound outward: a straight
// limb whose knee sits on its limit then folds the way the limit allows, its tip pulled toward the
// root at second order. Failing both, the kick itself. Hinges on a bound that a step would push out
// are left out of its projection (the active set of jacobian::limit_aware_step). Deterministic: the
// same solve escapes the same way. Restarts (SolverOptions::max_restarts, solve.cpp) are the outer
// layer of the same idea: an escape is a local perturbation inside one solve, a restart a new
// seeded start pose across solves (docs/solvers.md, "When a solve is stuck").
// Allocates nothing: every buffer is the workspace's.
#pragma once
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "core/kinematics_internal.hpp"
#include "ikchain/options.hpp"
#include "ikchain/so3.hpp"
#include "core/solvers/jacobian_common.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain {
namespace stuck {

// Iterations in a row without a relative improvement of stall_tolerance that make a solve stuck.
constexpr int kStallIterations = 3;
// An iteration of a Newton-like solver (the pseudo-inverse, DLS, BFGS) "creeps" when it lowers the
// best cost by less than this fraction of it; kStallIterations creeping iterations in a row are
// stuck too when no restart follows (Escapes::creep_is_stuck). Their steps converge superlinearly
// near a regular solution; a run of gains this small is mostly a singular saddle or a minimum held
// by the limits, approached along a flat valley or a bound (sublinearly: the stall tolerance's
// 1e-10 per iteration is never reached, and max_iterations runs out). CCD and FABRIK converge
// linearly and do not ask (the value: docs/solvers.md, "Why these constants").
constexpr double kCreepGain = 1e-2;
// Creeping iterations in a row (each gaining < kCreepGain) that are stuck wherever the pose is,
// for a query (Escapes::creep_is_long). Not the stall window itself (3): that escaped BFGS's slow
// but sound approaches on a 100-joint chain (core_bench: 2 of 500 goals lost) and cost the
// synthetic limited arms' full poses a few goals (issue 16, item 20).
constexpr int kLongCreep = 2 * kStallIterations;
// Escapes per solve (the pseudo-inverse's path can fall back into a saddle after one escape): the
// gentle first one and four full ones. The tree solvers' budget too.
constexpr int kMaxEscapes = 5;
// A chain solve's escapes may go this many beyond kMaxEscapes, for far ones (far()): each restarts
// the descent from afar, so it needs room of its own after the local moves have failed. Bounded
// by max_iterations and the time budget anyway: with 300 iterations, the robots bench's UR5
// full-pose failures (pseudo-inverse / DLS / BFGS, of 2,000) fall from 40 / 41 / 55 at 3 to
// 4 / 4 / 28 at 16, UR10's from 61 / 72 / 87 to 10 / 32 / 34; at 100 no arm loses a goal.
constexpr int kFarEscapes = 16;
// An escape pays off when the solve then gets below kEscapeGain times the best cost before it. One
// that led to a lower but not that much lower minimum found a nearby trap, and so would another:
// when restarts are allowed (SolverOptions::max_restarts), the solve stops there and the restarts,
// the outer layer, take over. Without them nothing would: the escapes go on to kMaxEscapes. One
// that found nothing lower at all (fell back into the same saddle) may retry either way.
constexpr double kEscapeGain = 0.5;
// The null-space step's pseudo-inverse drops singular values below this fraction of |J|, so the
// nearly singular direction the residual is stuck in counts as free.
constexpr double kEscapeTruncation = 1e-2;
// A null-space step turning no DOF more than this (rad) means the pose is already at rest in every
// free direction: the kick is used instead.
constexpr double kMinEscapeAngle = 1e-3;
// The third escape's off-the-bounds move takes a joint resting on a bound this fraction of its range
// toward the other bound (the first: half; docs/solvers.md, "Why these constants").
constexpr double kSecondUnpinFraction = 0.75;
// The kick's amplitude per DOF (rad; metres for a slide): small enough to undo in a step or two.
constexpr double kKickAmplitude = 0.15;
// The gentle first escape turns no DOF by more than this (rad; metres for a slide): it only has to
// leave the stationary point, and the iterations go on from nearby. Escaping with the full moves
// first (a bound-resting knee to the middle of its range, an uncapped null-space step toward the
// rest pose) made a tracked limb jump by up to 172 deg in one frame (issue 16, item 18).
constexpr double kGentleStep = kKickAmplitude;
// A solve stuck with a combined error of at most this fraction of the chain's length escapes
// gently first (a tracking frame: the target moved a little since the last pose).
constexpr double kGentleError = 0.05;
// Escapes in a row that found nothing kEscapeGain lower (the solve fell back into the minimum it
// left) after which a query's next escape is a far one (far()): the local moves have shown that this
// minimum's basin is wider than they reach. A 10-DOF torso + arm whose elbow branch is wrong, a
// UR5 whose straight elbow holds a full pose 8 mm off: every local move led back (issue 16, item 20).
// Not one: the UR10 then failed 114 / 156 / 319 full poses of 2,000 at 100 iterations (pseudo-
// inverse / DLS / BFGS) against 78 / 128 / 213 with two, and 76 / 78 / 138 against 61 / 72 / 87 at
// 300 (presumably: a query then makes one local escape at most, so the off-the-bounds moves that
// wrap its +-pi hinges across their bounds rarely come; not traced).
constexpr int kFruitlessBeforeFar = 2;
// A solve that starts farther than this fraction of the chain's length from its goals is a query
// (Escapes::cold_query), not the next frame of a track: a tracked target held 13 cm beyond what
// the limits allow starts every frame 10 % of L off (Issue16.OutOfReachBecauseOfTheLimits...).
constexpr double kQueryError = 0.25;

// ------------------------------------------------------------------------------------------------
// Reach bounds: when goals provably cannot be met (then a stuck pose is a best reach, not a trap).

// Largest distance effector k (1..n) can be from the root joint's origin o_0: the bones before it.
inline double reach_of(const Chain& chain, int k) {
  double reach = 0.0;
  for (int i = 0; i < k; ++i) reach += chain.bone_length(i);
  return reach;
}

// Smallest distance effector k can be from o_0 (triangle inequality): the longest bone before it
// minus all the others, or 0.
inline double inner_reach_of(const Chain& chain, int k) {
  if (chain.first_prismatic() >= 0) return 0.0;  // bone lengths are upper bounds then
  double longest = 0.0;
  for (int i = 0; i < k; ++i) longest = std::max(longest, chain.bone_length(i));
  return std::max(0.0, 2.0 * longest - reach_of(chain, k));
}

// How far a position goal's target is outside its effector's reach shell around o_0 (<= 0 inside).
inline double outside_reach(const Chain& chain, const Goal& g) {
  const int k = resolve_effector(chain, g.effector);
  const double dist = glm::length(g.target_position - chain.root_in_base());
  return std::max(dist - reach_of(chain, k), inner_reach_of(chain, k) - dist);
}

// True when the goals provably cannot all be met, by the chain's workspace bounds: a position goal
// outside its effector's reach shell around o_0 (farther than the bones before it, or nearer than
// the longest of them minus the others), or two position goals farther apart than the bones
// between their effectors. (Orientation conflicts and limits are not bounded here: a solve they
// stop is "stalled", which promises nothing about reachability.)
inline bool provably_out_of_reach(const Chain& chain, Span<const Goal> goals, double tolerance) {
  for (int a = 0; a < goals.size; ++a) {
    if (goals[a].kind != GoalKind::kPosition) continue;
    const int ka = resolve_effector(chain, goals[a].effector);
    if (outside_reach(chain, goals[a]) > tolerance) return true;
    for (int b = a + 1; b < goals.size; ++b) {
      if (goals[b].kind != GoalKind::kPosition) continue;
      const int kb = resolve_effector(chain, goals[b].effector);
      const double between = std::abs(reach_of(chain, kb) - reach_of(chain, ka));
      if (glm::length(goals[b].target_position - goals[a].target_position) > between + tolerance) return true;
    }
  }
  return false;
}

// The one goal is a position goal on the tip at or beyond full reach, less `margin` (m): the best
// the chain can do is point straight at it. The single-tip case of the bounds above, for the
// solvers that change strategy there (the pseudo-inverse clamps the target, CCD and FABRIK
// straighten toward it first); each caller's margin is named where it calls.
inline bool tip_beyond_full_reach(const Chain& chain, Span<const Goal> goals, double margin) {
  return goals.size == 1 && goals[0].kind == GoalKind::kPosition &&
         resolve_effector(chain, goals[0].effector) == chain.joint_count() &&
         glm::length(goals[0].target_position - chain.root_in_base()) >= chain.total_length() - margin;
}

// ------------------------------------------------------------------------------------------------
// Stationary points: the one test, and each caller's threshold.

// A stationary point with error left: the gradient g = J^T e of the cost |e|^2 / 2 is negligible,
// |g| <= relative * jacobian_scale * |e|, although the goals are not met (e.g. a straight chain
// whose target lies on its own line, or a best reach). Every gradient-based step stands still
// there. jacobian_scale * |e| is the size |g| would have if e were not orthogonal to J's range:
// jacobian_scale is |J|_F, or L (the chain's length, the largest |J| per unit rotation). Compared
// squared, as the Jacobian solvers always did (no square root of |g|^2).
inline bool is_stationary(double gradient_norm2, double jacobian_scale, double residual_norm, double relative) {
  const double bound = relative * jacobian_scale * residual_norm;
  return gradient_norm2 <= bound * bound;
}

// The thresholds differ because the questions do (each was set with its caller; kept as they were):
// - DLS and the pseudo-inverse, before their first step and after every escape, relative to
//   |J|_F |e|: only an exact singular point (g at rounding level) must trigger an escape there;
//   a pose that is merely slow to leave must not.
constexpr double kSingularStationary = 1e-10;
// - BFGS (chains and trees), every iteration, relative to L |e|: its line search still makes
//   progress on very small gradients, so only a gradient at rounding level stops it (or escapes).
constexpr double kQuasiNewtonStationary = 1e-12;
// - solve()'s verdict after the solve has stopped (is_best_reach in solve.cpp), relative to L |e|:
//   the solver stopped where its steps stopped paying (tolerances, the stall rule), not at an exact
//   stationary point, so the bound is loose (it is asked only when the goals are provably out of
//   reach, of a chain without limits).
constexpr double kBestReachStationary = 1e-6;

// ------------------------------------------------------------------------------------------------
// Full-turn bounds.

// A hinge within this fraction of its range from a bound rests on it, for wrap_across_bound (URDF
// ranges of "a full turn" are written with a rounded pi, a few 1e-6 short of 2 pi).
constexpr double kOnBoundFraction = 1e-6;

// When hinge `joint` rests on a bound and that bound +- 2 pi also lies in its range, moves it across
// to that value and returns true: the same pose, so the same effectors, but on the other side of the
// wall. A hinge whose range spans a full turn (UR arms: +-pi) stops on a bound when its solution
// lies just beyond it, i.e. just inside the opposite end; from the wrapped value the same gradient
// leads into it. The escapes' off-the-bounds move, a query's descent (Escapes::
// cross_full_turn_bounds) and the restarts (solve.cpp) use it.
inline bool wrap_across_bound(const Chain& chain, int joint, double* params) {
  if (chain.joint_type(joint) != JointType::kHinge || !chain.limits(joint).has_hinge_limit) return false;
  const JointLimits& l = chain.limits(joint);
  const double range = l.hinge_max - l.hinge_min, slack = kOnBoundFraction * range;
  double& q = params[chain.dof_offset(joint)];
  if (q <= l.hinge_min + slack && q + 2.0 * so3::kPi <= l.hinge_max + slack) {
    q = std::min(q + 2.0 * so3::kPi, l.hinge_max);
    return true;
  }
  if (q >= l.hinge_max - slack && q - 2.0 * so3::kPi >= l.hinge_min - slack) {
    q = std::max(q - 2.0 * so3::kPi, l.hinge_min);
    return true;
  }
  return false;
}

// ------------------------------------------------------------------------------------------------
// The stall rule.
class StallRule {
 public:
  explicit StallRule(double start_cost = INFINITY) { reset(start_cost); }
  // A new start (after an escape): the best so far is `cost`, the count starts again.
  void reset(double cost) {
    best_ = cost;
    small_ = 0;
    slow_ = 0;
  }
  // After an iteration that ended at `cost`: true when kStallIterations iterations in a row lowered
  // the best cost by no more than `tolerance` (stall_tolerance) times it. NaN never improves.
  bool stalled_after(double cost, double tolerance) {
    auto gains_more_than = [&](double fraction) {
      return std::isfinite(best_) ? best_ - cost > fraction * best_ : cost < best_;
    };
    small_ = gains_more_than(tolerance) ? 0 : small_ + 1;
    slow_ = gains_more_than(kCreepGain) ? 0 : slow_ + 1;
    if (cost < best_) best_ = cost;
    return small_ >= kStallIterations;
  }
  // The same rule for a solver whose cost is not one number (the tree DLS's levels, compared
  // lexicographically): it measures each accepted step's relative gain itself. True when
  // kStallIterations steps in a row gained less than `tolerance`; a gain below kCreepGain counts
  // toward creeping(). NaN counts as a gain.
  bool stalled_after_gain(double gain, double tolerance) {
    small_ = gain < tolerance ? small_ + 1 : 0;
    slow_ = gain < kCreepGain ? slow_ + 1 : 0;
    return small_ >= kStallIterations;
  }
  // True when the last kStallIterations iterations each lowered the best cost by less than
  // kCreepGain of it: a creep, still progress, so the solver escapes when Escapes::creep_is_stuck()
  // and it can, and otherwise goes on.
  bool creeping() const { return slow_ >= kStallIterations; }
  // Iterations in a row that each lowered the best cost by less than kCreepGain of it.
  int creep_length() const { return slow_; }

 private:
  double best_ = INFINITY;
  int small_ = 0;
  int slow_ = 0;
};

// ------------------------------------------------------------------------------------------------
// The escape, and the best pose seen (in ws.params_best).
class Escapes {
 public:
  Escapes(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws)
      : chain_(chain), goals_(goals), options_(options), ws_(ws) {}

  // The caller knows the goals are out of reach (the pseudo-inverse after clamping its target):
  // no escape.
  void disable() { state_ = kOutOfReach; }

  int used() const { return used_; }

  // Whether a creeping run (StallRule::creeping) at params is stuck in a minimum the limits hold:
  // some hinge or slide rests on a bound (the off-the-bounds move then frees it), or a ball on its
  // cone or twist boundary (BFGS's steps then zig-zag along the curved boundary), and no restart
  // follows (max_restarts 0), so the escapes are the only way out. Elsewhere a creep may be a slow
  // approach that still ends within tolerance (near a singular solution), and with restarts the
  // run goes on and leaves a failure to them (docs/solvers.md, "When a solve is stuck").
  bool creep_is_stuck(const double* params) const {
    if (restarts_follow()) return false;
    const int active = jacobian::active_dof_count(chain_, goals_);
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i)
      if (hinge_blocked(chain_, i, params, -1.0) || hinge_blocked(chain_, i, params, 1.0) ||
          ball_on_boundary(chain_, i, params))
        return true;
    return false;
  }

  // Whether a creep is stuck by its length alone, wherever it is: kLongCreep iterations in a row
  // each gaining < kCreepGain, in a query (cold_query). The Newton-like solvers' steps converge
  // superlinearly near a regular solution; a creep this long is a singular trap approached along a
  // flat valley (a UR5's straight elbow holding a full pose 2 cm off for 20 iterations, issue 16,
  // item 20). The solver escapes it while escapes are left and otherwise creeps on.
  bool creep_is_long(const StallRule& stall) const {
    return cold_query() && stall.creep_length() >= kLongCreep;
  }

  // Moves every active hinge that rests on a bound whose bound +- 2 pi also lies in its range across
  // to that value (wrap_across_bound): the same pose. True when it moved any. Loop::after_accepted
  // asks it after every accepted step of a query (cold_query): a descent pressed against such a
  // bound crawls along it, too fast for a creep, into a minimum the bound holds, where across it
  // the descent goes on (the UR10's six hinges all span [-pi, pi]: docs/robots-bench.md, issue 16
  // item 20). Only in a query: a tracking frame keeps its steps (its escapes' off-the-bounds move
  // wraps a hinge the bound holds), and with restarts their own wrap is the move. The time budget
  // spent, nothing moves: the solver's re-evaluation there would overrun it.
  bool cross_full_turn_bounds(double* params) {
    if (full_turn_ < 0) {  // once per solve: most chains have no such hinge, and then no loop per step
      full_turn_ = 0;
      for (int i = 0; i < chain_.joint_count(); ++i) {
        const JointLimits& l = chain_.limits(i);
        if (chain_.joint_type(i) == JointType::kHinge && l.has_hinge_limit &&
            (l.hinge_max - l.hinge_min) * (1.0 + kOnBoundFraction) >= 2.0 * so3::kPi)  // wrap_across_bound's test
          full_turn_ = 1;
      }
    }
    if (full_turn_ == 0) return false;
    const int active = jacobian::active_dof_count(chain_, goals_);
    bool moved = false;
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
      const int o = chain_.dof_offset(i);
      const double before = params[o];
      if (!wrap_across_bound(chain_, i, params)) continue;
      if (!moved && ws_.deadline.spent()) {  // read once, and only when a hinge would cross
        params[o] = before;
        return false;
      }
      moved = true;
    }
    return moved;
  }

  // The cost of the pose the solve starts from (cold_query() asks it); not called: 0, a tracking
  // frame.
  void start_at(double cost) { start_error_ = std::sqrt(2.0 * std::max(cost, 0.0)); }
  // A solve that started farther than kQueryError x L from its goals and that no restart follows:
  // a query, not a tracking frame. Only such a solve escapes a long creep and escapes far (with the
  // kFarEscapes more): a tracking frame keeps its continuity (a far pose is a jump: issue 16, items
  // 14 and 18), and with restarts the outer layer makes the far moves.
  bool cold_query() const {
    return !restarts_follow() && start_error_ > kQueryError * chain_.total_length();
  }

  // Keeps params as the best pose when `cost` beats every pose offered before.
  void offer(const double* params, double cost) {
    if (!(cost < best_cost_)) return;
    best_cost_ = cost;
    std::copy(params, params + chain_.dof_count(), ws_.params_best.data());
  }
  // Leaves params at the best pose offered when it is better than `cost` (params' own cost).
  // Returns true when it changed params.
  bool restore_best(double* params, double cost) const {
    if (!(best_cost_ < cost)) return false;
    std::copy(ws_.params_best.data(), ws_.params_best.data() + chain_.dof_count(), params);
    return true;
  }

  // The solve at params (of cost `cost`) is stuck. Offers params as the best pose, then moves them
  // within the limits (see the file comment) and returns true - or returns false, params
  // untouched, when no escape is left or the goals are provably out of reach. Leaves ws's
  // kinematics stale: the caller evaluates the new pose.
  bool escape(double* params, double cost) {
    offer(params, cost);
    // The time budget is spent: the solve stops, not escapes. Read here, not only remembered: an
    // escape costs several FK and Jacobian passes, and DLS and the pseudo-inverse may call one
    // before their first iteration's check.
    if (ws_.deadline.spent()) return false;
    if (state_ == kUnknown)
      state_ = provably_out_of_reach(chain_, goals_, options_.position_tolerance) ? kOutOfReach : kReachable;
    if (state_ == kOutOfReach || used_ >= kMaxEscapes + (cold_query() ? kFarEscapes : 0)) return false;
    if (restarts_follow() && full_ > 0 && best_cost_ < best_at_escape_ &&
        !(best_cost_ < kEscapeGain * best_at_escape_))
      return false;
    fruitless_ = used_ > 0 && !(best_cost_ < kEscapeGain * best_at_escape_) ? fruitless_ + 1 : 0;
    best_at_escape_ = best_cost_;
    ++used_;
    const int n = chain_.dof_count();
    const int active = jacobian::active_dof_count(chain_, goals_);
    double* before = ws_.params_trial.data();
    double* step = ws_.dof_vec_b.data();
    std::copy(params, params + n, before);
    // The first escape of a solve stuck near its goals (the combined error sqrt(2 cost) within
    // kGentleError of the chain's length: a tracking frame) is gentle (gentle(): no DOF turns by
    // more than kGentleStep), so a straight knee on its limit with the target now a little closer
    // folds out of it and the solve goes on from nearby, continuous frame to frame. The full
    // escapes below follow when it is stuck again, or farther from its goals.
    if (used_ == 1 && std::sqrt(2.0 * best_cost_) <= kGentleError * chain_.total_length()) {
      if (gentle(active, before, step, params)) return true;
      if (ran_out(before, params)) return false;  // the gentle projections' sweeps read the clock
    }
    ++full_;
    // A query fallen back kFruitlessBeforeFar times in a row: far from this basin (far()).
    if (cold_query() && fruitless_ >= kFruitlessBeforeFar) {
      far(active, params);
      return true;
    }
    // 0. Off the bounds: a minimum with joints resting on bounds is a constrained one that no
    //    null-space move leaves (the bound, not J, holds it). Every such joint moves off its bound
    //    (unpin()) and the solve starts again from there - on the first escape and the third.
    if (full_ % 2 == 1 && unpin(active, params)) return true;
    // 1. Toward the rest pose, in the null space of J, the hinges on a bound it would push out
    //    left out - kept when it moves the pose off the stationary point.
    if (ran_out(before, params)) return false;
    linearize(params);
    project_within_limits(active, params, step, [&](double* v) { toward_rest(active, params, v); });
    if (largest(active, step) > kMinEscapeAngle && move(step, before, params)) return true;
    // 2. The fixed kick direction in the null space of J, with the sign that pushes no hinge on a
    //    bound out (the null space is symmetric); failing both signs, without the hinges that it
    //    pushes out; failing that (no null space left), the kick itself.
    if (ran_out(before, params)) return false;
    std::copy(before, before + n, params);
    linearize(params);
    kick_direction(active, params, step);
    project_onto_null_space(active, step);
    if (pushes_out(active, params, step)) scale(active, -1.0, step);
    if (pushes_out(active, params, step)) {
      linearize(params);
      project_within_limits(active, params, step, [&](double* v) { kick_direction(active, params, v); });
    }
    if (ran_out(before, params)) return false;  // the projections' sweeps read the clock
    const double size = largest(active, step);
    if (size > 1e-9) {
      scale(active, kKickAmplitude / size, step);
    } else {
      kick_direction(active, params, step);
    }
    // 3. Where that leaves a stationary point, the kick on top.
    if (!move(step, before, params)) {
      kick_direction(active, params, step);
      apply_step(chain_, step, 0.0, params);
      project_to_limits(chain_, params);
    }
    return true;
  }

 private:
  enum State { kUnknown, kReachable, kOutOfReach };

  // The time budget between an escape's phases: each costs several FK and Jacobian passes and, on
  // long chains, Gram products (issue 16, item 6). Spent: params back to `before`, no escape.
  bool ran_out(const double* before, double* params) {
    if (!ws_.deadline.spent()) return false;
    std::copy(before, before + chain_.dof_count(), params);
    return true;
  }
  bool restarts_follow() const { return options_.max_restarts > 0; }

  // The gentle escape: the null-space step toward the rest pose and, failing that, the kick (steps
  // 1 and 2 below), each scaled to turn no DOF by more than kGentleStep, no bound left. True when
  // it moved params off the stationary point; else params are left at `before`.
  bool gentle(int active, const double* before, double* step, double* params) {
    linearize(params);
    project_within_limits(active, params, step, [&](double* v) { toward_rest(active, params, v); });
    if (largest(active, step) > kGentleStep) scale(active, kGentleStep / largest(active, step), step);
    if (largest(active, step) > kMinEscapeAngle && move(step, before, params)) return true;
    if (ran_out(before, params)) return false;
    std::copy(before, before + chain_.dof_count(), params);
    linearize(params);
    kick_direction(active, params, step);
    project_onto_null_space(active, step);
    if (pushes_out(active, params, step)) scale(active, -1.0, step);
    if (pushes_out(active, params, step)) {
      linearize(params);
      project_within_limits(active, params, step, [&](double* v) { kick_direction(active, params, v); });
    }
    const double size = largest(active, step);
    if (size > 1e-9) {
      scale(active, kGentleStep / size, step);
      if (move(step, before, params)) return true;
    }
    std::copy(before, before + chain_.dof_count(), params);
    return false;
  }
  int full_ = 0;  // full escapes made (after the gentle one)
  int full_turn_ = -1;  // an active hinge's range spans a full turn: 1, 0, or -1 = not worked out yet
  int fruitless_ = 0;  // escapes in a row after which the solve found nothing kEscapeGain lower
  int far_ = 0;  // far escapes made
  double start_error_ = 0.0;  // sqrt(2 cost) of the start pose (start_at)

  // The far escape: every active hinge and slide goes to a point of a Kronecker sequence over its
  // range (a different point per far escape, DOF j's coordinate frac(0.5 + k sqrt(p_j)), p_j the
  // j-th prime), ball joints stay. Deterministic, spread over the limits and unrelated to the
  // stuck pose - a restart's move inside the solve, so one that no restart follows still leaves
  // a basin the local moves cannot (restore_best keeps the better pose if it leads nowhere).
  void far(int active, double* params) {
    static constexpr double kRootPrimes[] = {1.4142135623730951, 1.7320508075688772, 2.2360679774997898,
                                             2.6457513110645907, 3.3166247903554,    3.605551275463989,
                                             4.123105625617661,  4.358898943540674,  4.795831523312719,
                                             5.385164807134504,  5.5677643628300215, 6.082762530298219};
    constexpr int kRoots = sizeof(kRootPrimes) / sizeof(kRootPrimes[0]);
    ++far_;
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
      if (chain_.joint_type(i) == JointType::kBall) continue;
      const int o = chain_.dof_offset(i);
      const JointLimits& l = chain_.limits(i);
      const double lo = l.has_hinge_limit ? l.hinge_min : -so3::kPi;
      const double hi = l.has_hinge_limit ? l.hinge_max : so3::kPi;
      // DOFs past the 12th reuse a root with a half-period shift.
      const double u = 0.5 + far_ * kRootPrimes[o % kRoots] + (o / kRoots) * 0.5;
      params[o] = lo + (hi - lo) * (u - std::floor(u));
    }
    project_to_limits(chain_, params);
  }
  double best_at_escape_ = INFINITY;  // best_cost_ when the last escape was made

  // J (top rows of ws.jacobian) and the weighted residual (ws.residual) at params.
  void linearize(const double* params) {
    const int m = 3 * goals_.size;
    forward_kinematics(chain_, params, ws_);
    compute_dof_axes(chain_, params, ws_);
    evaluate_goals(chain_, goals_, ws_, ws_.residual.head(m));
    auto J = ws_.jacobian.topRows(m);
    compute_jacobian(chain_, goals_, ws_, J);
  }

  bool still_stationary(const double* params) {
    const int m = 3 * goals_.size;
    linearize(params);
    const auto J = ws_.jacobian.topRows(m);
    const auto e = ws_.residual.head(m);
    ws_.gradient.noalias() = J.transpose() * e;
    return is_stationary(ws_.gradient.squaredNorm(), J.norm(), e.norm(), kSingularStationary);
  }

  // params = before + step, projected onto the limits; true when that turned some DOF by more than
  // kMinEscapeAngle and the new pose is no stationary point.
  bool move(const double* step, const double* before, double* params) {
    const int n = chain_.dof_count();
    std::copy(before, before + n, params);
    apply_step(chain_, step, 0.0, params);
    project_to_limits(chain_, params);
    double moved = 0.0;
    for (int j = 0; j < n; ++j) moved = std::max(moved, std::abs(params[j] - before[j]));
    return moved > kMinEscapeAngle && !still_stationary(params);
  }

  // v <- the null-space projection of the direction `fill` writes, with the active set of
  // limit_aware_step: a hinge on a bound that the projected step pushes out leaves the problem (its
  // entry 0, its column out of J) and the projection is solved again, while that adds any (at most
  // jacobian::kMaxFreezePasses times). Needs J from linearize(); zeroes the frozen columns. Marks
  // the frozen DOFs in ws.gradient.
  template <class Fill>
  void project_within_limits(int active, const double* params, double* v, Fill&& fill) {
    const int m = 3 * goals_.size;
    double* frozen = ws_.gradient.data();
    std::fill(frozen, frozen + active, 0.0);
    for (int pass = 0; pass <= jacobian::kMaxFreezePasses; ++pass) {
      fill(v);
      for (int j = 0; j < active; ++j)
        if (frozen[j] != 0.0) v[j] = 0.0;
      project_onto_null_space(active, v);
      bool froze = false;
      for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
        const int o = chain_.dof_offset(i);
        if (frozen[o] != 0.0 || !hinge_blocked(chain_, i, params, v[o])) continue;
        frozen[o] = 1.0;
        ws_.jacobian.col(o).head(m).setZero();
        froze = true;
      }
      if (!froze) return;
    }
  }

  static double largest(int active, const double* v) {
    double m = 0.0;
    for (int j = 0; j < active; ++j) m = std::max(m, std::abs(v[j]));
    return m;
  }
  static void scale(int active, double f, double* v) {
    for (int j = 0; j < active; ++j) v[j] *= f;
  }

  // z = rest - params over the active DOFs (hinge angles modulo 2 pi, ball rotation vectors toward
  // 0, slides toward 0), zero elsewhere.
  void toward_rest(int active, const double* params, double* z) const {
    std::fill(z, z + chain_.dof_count(), 0.0);
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
      const int d0 = chain_.dof_offset(i);
      if (chain_.joint_type(i) == JointType::kPrismatic) {
        z[d0] = -params[d0];
      } else if (chain_.joint_type(i) == JointType::kHinge) {
        z[d0] = -std::remainder(params[d0], 2.0 * so3::kPi);
      } else {
        for (int d = d0; d < d0 + 3; ++d) z[d] = -params[d];
      }
    }
  }

  // Moves every limited hinge or slide resting on a bound off it: across a full-turn range to the
  // same angle at its other end (wrap_across_bound: the bound was the only thing in the way), else
  // to the middle of its range on the first escape (nearer fractions of the range left more of the
  // real arms' pinned minima) and, on the third, three quarters of the way to its other bound (the
  // middle led back to this minimum once; the same move would again). True when it moved any.
  bool unpin(int active, double* params) const {
    bool moved = false;
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
      const bool low = hinge_blocked(chain_, i, params, -1.0);
      if (!low && !hinge_blocked(chain_, i, params, 1.0)) continue;
      moved = true;
      if (wrap_across_bound(chain_, i, params)) continue;
      const ParamRange r = param_range(chain_.joint_type(i), chain_.limits(i));
      const double toward_other_end = full_ >= 3 ? kSecondUnpinFraction : 0.5;
      params[chain_.dof_offset(i)] =
          low ? r.min + toward_other_end * (r.max - r.min)
              : r.max - toward_other_end * (r.max - r.min);
    }
    return moved;
  }

  // The kick: DOF j turns by kKickAmplitude * sin(golden angle * (j + 1) + escape number) (signs
  // alternating irregularly, a different pattern per escape), a hinge on a bound toward the inside
  // of its range; zero beyond the active DOFs.
  void kick_direction(int active, const double* params, double* v) const {
    for (int j = 0; j < chain_.dof_count(); ++j)
      v[j] = j < active ? kKickAmplitude * std::sin(2.399963 * (j + 1) + std::max(full_ - 1, 0)) : 0.0;
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i) {
      const int o = chain_.dof_offset(i);
      if (hinge_blocked(chain_, i, params, v[o])) v[o] = -v[o];
    }
  }

  // True when v pushes a hinge (or slide) resting on a bound outward.
  bool pushes_out(int active, const double* params, const double* v) const {
    for (int i = 0; i < chain_.joint_count() && chain_.dof_offset(i) < active; ++i)
      if (hinge_blocked(chain_, i, params, v[chain_.dof_offset(i)])) return true;
    return false;
  }

  // v <- (I - J+ J) v over the active DOFs, J+ truncated below kEscapeTruncation |J| (so a nearly
  // singular direction the residual is stuck in counts as free), J from linearize(). Uses
  // goal_square, dof_square, goal_vec and dof_vec_a as scratch.
  void project_onto_null_space(int active, double* v) {
    const int m = 3 * goals_.size;
    const auto J = ws_.jacobian.topLeftCorner(m, active);
    Eigen::Map<Eigen::VectorXd> zv(v, active);
    // The Gram matrix of the smaller side, as the Jacobian models' pseudo-inverse.
    if (m < active) {  // z -= J^T V diag(1/lambda) V^T J z   (J J^T = V diag(lambda) V^T)
      auto A = ws_.goal_square.topLeftCorner(m, m);
      auto V = ws_.dof_square.topLeftCorner(m, m);
      A.noalias() = J * J.transpose();
      ws_.deadline.charge(static_cast<double>(m) * m * active + 2.0 * m * active);
      const double floor = truncation_floor(A.trace());
      if (linalg::jacobi_eigen(A, V, m, &ws_.deadline) < 0) return stopped(active, v);
      auto y = ws_.goal_vec.head(m);
      auto t = ws_.dof_vec_a.head(m);
      y.noalias() = J * zv;
      t.noalias() = V.transpose() * y;
      for (int i = 0; i < m; ++i) t[i] = A(i, i) > floor ? t[i] / A(i, i) : 0.0;
      y.noalias() = V * t;
      zv.noalias() -= J.transpose() * y;
    } else {  // z -= W W^T z over the kept eigenvectors W of J^T J
      auto A = ws_.dof_square.topLeftCorner(active, active);
      auto W = ws_.goal_square.topLeftCorner(active, active);
      A.noalias() = J.transpose() * J;
      ws_.deadline.charge(static_cast<double>(active) * active * m);
      const double floor = truncation_floor(A.trace());
      if (linalg::jacobi_eigen(A, W, active, &ws_.deadline) < 0) return stopped(active, v);
      auto t = ws_.dof_vec_a.head(active);
      t.noalias() = W.transpose() * zv;
      for (int i = 0; i < active; ++i) t[i] = A(i, i) > floor ? t[i] : 0.0;
      zv.noalias() -= W * t;
    }
  }

  // The time budget stopped the eigen-decomposition (its sweeps read the clock: on 12 x 12 and
  // up one costs tens of microseconds, more than the stretch the budget foresaw): no direction,
  // and the escape's next ran_out() returns the pose it started from.
  static void stopped(int active, double* v) { std::fill(v, v + active, 0.0); }

  double truncation_floor(double trace) const {
    return jacobian::gram_rank_floor(
        std::max(options_.pinv_singular_threshold, kEscapeTruncation * std::sqrt(std::max(trace, 0.0))), trace);
  }

  const Chain& chain_;
  Span<const Goal> goals_;
  const SolverOptions& options_;
  Workspace& ws_;
  double best_cost_ = INFINITY;
  int used_ = 0;
  State state_ = kUnknown;
};

// ------------------------------------------------------------------------------------------------
// Which creeps (StallRule::creeping) an accepted step escapes. kEvery: any (the pseudo-inverse,
// whose halved steps follow the Newton flow into singular saddles; with no escape left only a creep
// the limits hold stops the solve). kStuckOrLong: one the limits hold (Escapes::creep_is_stuck; no
// escape left: stalled) or a long one (Escapes::creep_is_long; no escape left: it goes on).
enum class Creeps { kEvery, kStuckOrLong };
// What an accepted step leads to (Loop::after_accepted). kMoved: params moved (an escape, or a
// query's hinge across a full-turn bound) and the solver's Moved evaluated them there.
enum class Verdict { kGoOn, kMoved, kStalled };

// Every Newton-like chain solver's loop around the rules above (the pseudo-inverse and DLS through
// JacobianLoop below, BFGS directly: bfgs.cpp): the stall rule and the escapes over params, the
// verdict after an accepted step, and the best pose at the end - one mechanism, so the solvers
// differ only in their steps. `Moved` is called after an escape (or a query's crossing of a
// full-turn bound) moved params: it evaluates the solve there (and resets the solver's step state)
// and returns the cost there. Holds references only: allocates nothing.
template <class Moved>
class Loop {
 public:
  Loop(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws, double* params,
       Moved moved)
      : options_(options), params_(params), moved_(moved), escapes_(chain, goals, options, ws) {}

  // The solve starts at params, of cost `cost`.
  void start(double cost) {
    stall_.reset(cost);
    escapes_.start_at(cost);
  }

  Escapes& escapes() { return escapes_; }

  // Stuck at params, of cost `cost`: escape and start again there (true), or no escape left (false).
  bool escape(double cost) {
    if (!escapes_.escape(params_, cost)) return false;
    stall_.reset(moved_());
    return true;
  }

  // After a step was accepted into params, at `cost`: in a query, its hinges on full-turn bounds
  // across them (Escapes::cross_full_turn_bounds); then the stall rule and the creeps (see Creeps).
  // kMoved: params moved (an escape, or only the crossing) and Moved evaluated them; kStalled:
  // stuck, no escape left; kGoOn: the solver goes on from the accepted step.
  Verdict after_accepted(double cost, Creeps creeps) {
    // The crossing keeps the pose and its cost, so the rules judge the step as taken. It is not an
    // escape (no budget, no new start for the stall rule): a hinge that the next step presses
    // against the other bound crosses back, and a run of such steps gaining little is a creep the
    // limits hold (a joint rests on a bound), escaped as before. (Crossing only a hinge that had
    // just arrived at its bound, or each hinge once per descent, left more goals unmet:
    // docs/robots-bench.md.)
    const bool crossed = escapes_.cold_query() && escapes_.cross_full_turn_bounds(params_);
    const Verdict verdict = judge(cost, creeps);
    if (!crossed || verdict == Verdict::kMoved) return verdict;
    moved_();  // the solver's state, of the same pose in new coordinates
    return verdict == Verdict::kGoOn ? Verdict::kMoved : verdict;
  }

  // The solve's end at params, of cost `cost`: the escapes used, and params back at the best pose
  // seen unless it converged.
  void finish(SolverStatus& status, double cost) {
    status.escapes = escapes_.used();
    if (status.reason != TerminationReason::kConverged) escapes_.restore_best(params_, cost);
  }

 private:
  // The stall rule and the creeps over the accepted step (after_accepted).
  Verdict judge(double cost, Creeps creeps) {
    if (stall_.stalled_after(cost, options_.stall_tolerance))
      return escape(cost) ? Verdict::kMoved : Verdict::kStalled;
    if (!stall_.creeping()) return Verdict::kGoOn;  // creep_is_long implies creeping too
    if (creeps == Creeps::kEvery) {
      if (escape(cost)) return Verdict::kMoved;
      // No escape left: a creep the limits hold would creep on in vain; any other is still progress.
      return escapes_.creep_is_stuck(params_) ? Verdict::kStalled : Verdict::kGoOn;
    }
    if (escapes_.creep_is_stuck(params_)) return escape(cost) ? Verdict::kMoved : Verdict::kStalled;
    return escapes_.creep_is_long(stall_) && escape(cost) ? Verdict::kMoved : Verdict::kGoOn;
  }

  const SolverOptions& options_;
  double* params_;
  Moved moved_;
  StallRule stall_;
  Escapes escapes_;
};

// The Jacobian solvers' Loop (DLS and the pseudo-inverse: dls.cpp, jacobian_pinv.cpp) over one
// model (jacobian_common.hpp's SinglePositionModel or GoalModel): after an escape the model is
// evaluated and linearised at the new pose, and `restart` resets the solver's step state (DLS: the
// damping, the pseudo-inverse: the step fraction). Holds references only: allocates nothing.
template <class Model, class Restart>
class JacobianLoop {
 public:
  // The model is evaluated and linearised at params, the solve's start.
  JacobianLoop(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
               Model& model, double* params, Restart restart)
      : model_(model), loop_(chain, goals, options, ws, params, Relinearize{model, params, restart}) {
    loop_.start(model.cost());
  }

  Escapes& escapes() { return loop_.escapes(); }

  // Stuck at params: escape and start again there (true), or no escape left (false).
  bool escape() { return loop_.escape(model_.cost()); }

  // At a singular stationary point with error left (kSingularStationary; every step is zero
  // there): escapes while it can. Needs the model linearised at params.
  void escape_if_stationary() {
    if (is_stationary(model_.gradient_norm2(), model_.jacobian_norm(), model_.residual_norm(), kSingularStationary))
      escape();
  }

  // Loop::after_accepted.
  Verdict after_accepted(double cost, Creeps creeps) { return loop_.after_accepted(cost, creeps); }

  // Loop::finish at the model's cost.
  void finish(SolverStatus& status) { loop_.finish(status, model_.cost()); }

 private:
  struct Relinearize {
    Model& model;
    double* params;
    Restart restart;
    double operator()() {
      model.evaluate(params);
      model.accept();
      model.linearize(params);
      restart();
      return model.cost();
    }
  };
  Model& model_;
  Loop<Relinearize> loop_;
};

}  // namespace stuck
}  // namespace ikchain
