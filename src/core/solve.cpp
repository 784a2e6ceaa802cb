#include "ikchain/solve.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"
#include "core/solvers/stuck.hpp"

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

// The start pose solve() defines: the caller's params (warm start) or the rest pose, projected onto
// the limits. Recomputed from the backup when a solve must fall back to it.
void make_start_pose(const Chain& chain, const SolverOptions& options, Eigen::Ref<Eigen::VectorXd> params) {
  if (!options.warm_start) params.setZero();
  project_to_limits(chain, params.data());
}

// The reach bounds (outside_reach, provably_out_of_reach) are the escapes' (solvers/stuck.hpp):
// one verdict on "provably out of reach" for escapes, restarts and the reason.
using stuck::outside_reach;
using stuck::provably_out_of_reach;

// A non-converged stop is "unreachable" only when the goals are provably out of reach
// (provably_out_of_reach) and the pose is a best reach: for a single tip position goal, the tip as
// close as the reach shell allows (within position_tolerance); otherwise a stationary point of
// the objective (J^T e vanishes) on a chain without limits (limits make constrained optima
// non-stationary). Every other non-converged stop - a local minimum of reachable goals included -
// is "stalled" (or the solver's kMaxIterations). Needs ws to hold the forward kinematics of
// params (or fk_current false: it computes them), and `err` their measured errors.
// SolverOptions::soft_reach: `goals` copied into `out` (same order), each position goal's target
// that lies within soft_reach of its effector's full reach pulled toward the root joint's origin
// (options.hpp gives the curve). Returns the largest pull (m).
double soften_goals(const Chain& chain, Span<const Goal> goals, double soft_reach, Goal* out) {
  double largest = 0.0;
  const glm::dvec3 root = chain.root_in_base();
  for (int i = 0; i < goals.size; ++i) {
    out[i] = goals[i];
    if (goals[i].kind != GoalKind::kPosition) continue;
    const double reach = stuck::reach_of(chain, resolve_effector(chain, goals[i].effector));
    const double soft = std::min(soft_reach, reach);
    const double start = reach - soft;  // where the soft zone begins
    const glm::dvec3 offset = goals[i].target_position - root;
    const double d = glm::length(offset);
    if (!(soft > 0.0) || !(d > start)) continue;
    const double pulled = start + soft * (1.0 - std::exp(-(d - start) / soft));
    out[i].target_position = root + offset * (pulled / d);
    largest = std::max(largest, d - pulled);
  }
  return largest;
}

bool is_best_reach(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                   Workspace& ws, const double* params, const GoalErrors& err, bool fk_current) {
  if (!provably_out_of_reach(chain, goals, options.position_tolerance)) return false;
  if (goals.size == 1 && goals[0].kind == GoalKind::kPosition &&
      resolve_effector(chain, goals[0].effector) == chain.joint_count()) {
    return err.max_position <= outside_reach(chain, goals[0]) + options.position_tolerance;
  }
  if (chain.any_limits()) return false;
  const int rows = 3 * goals.size;
  if (!fk_current) forward_kinematics(chain, params, ws);
  compute_dof_axes(chain, params, ws);
  auto J = ws.jacobian.topRows(rows);
  auto e = ws.residual.head(rows);
  evaluate_goals(chain, goals, ws, e);
  compute_jacobian(chain, goals, ws, J);
  ws.gradient.noalias() = J.transpose() * e;
  return stuck::is_stationary(ws.gradient.squaredNorm(), chain.total_length(), err.combined,
                              stuck::kBestReachStationary);
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

// True when a solver's own measurement of its final pose is within tolerance by more than the
// rounding in which its FK may differ from forward_kinematics() (DLS's fused single-goal FK sums
// in another order): then measuring again could not turn "converged" into "not converged", and the
// dispatcher's FK pass is saved. Below that margin the pose is measured here, so a reported
// "converged" always agrees with the error forward_kinematics() gives (issue 16, item 5). The
// margin, 1e-12 of the coordinates' scale, is thousands of ulps of any chain's length.
bool within_beyond_rounding(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, const GoalErrors& e) {
  double scale = chain.total_length() + glm::length(chain.root_in_base());
  for (int i = 0; i < goals.size; ++i)
    if (goals[i].kind == GoalKind::kPosition) scale = std::max(scale, glm::length(goals[i].target_position));
  const double slack = 1e-12 * scale;
  return e.max_position + slack <= o.position_tolerance && e.max_orientation + 1e-12 <= o.orientation_tolerance;
}

// True when a measurement of the final pose is within tolerance, or outside it, by more than
// that rounding: measuring again could not change the verdict.
bool clear_of_tolerance(const Chain& chain, Span<const Goal> goals, const SolverOptions& o, const GoalErrors& e) {
  if (within_beyond_rounding(chain, goals, o, e)) return true;
  double scale = chain.total_length() + glm::length(chain.root_in_base());
  for (int i = 0; i < goals.size; ++i)
    if (goals[i].kind == GoalKind::kPosition) scale = std::max(scale, glm::length(goals[i].target_position));
  return e.max_position - 1e-12 * scale > o.position_tolerance || e.max_orientation - 1e-12 > o.orientation_tolerance;
}

using SolveFn = SolverStatus (*)(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double*);

// The solver table (solve.hpp) and the function of each row, in SolverKind order.
const SolverInfo kSolverTable[] = {
    {SolverKind::kTwoBone, "two_bone", "Two Bone", 2, false, false, false, false, false},
    {SolverKind::kCCD, "ccd", "Cyclic Coordinate Descent", 0, true, true, true, false, true},
    {SolverKind::kJacobianPinv, "jacobian_pinv", "Jacobian Pseudo-Inverse", 0, true, true, true, true, false},
    {SolverKind::kDLS, "dls", "Damped Least Squares", 0, true, true, true, true, true},
    {SolverKind::kBFGS, "bfgs", "BFGS", 0, true, true, true, true, true},
    {SolverKind::kFABRIK, "fabrik", "FABRIK", 0, true, false, true, false, true},
};
const SolveFn kSolverFunctions[] = {solve_two_bone, solve_ccd, solve_jacobian_pinv, solve_dls, solve_bfgs, solve_fabrik};
static_assert(sizeof(kSolverTable) / sizeof(kSolverTable[0]) == kSolverKindCount, "one table row per SolverKind");
static_assert(sizeof(kSolverFunctions) / sizeof(kSolverFunctions[0]) == kSolverKindCount, "one function per row");

SolverStatus run_solver(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        Workspace& ws, double* p) {
  const int k = static_cast<int>(kind);
  if (k >= 0 && k < kSolverKindCount) return kSolverFunctions[k](chain, goals, options, ws, p);
  SolverStatus status;
  status.reason = TerminationReason::kInvalidInput;
  status.message = Message::format("solver kind %d is unknown", static_cast<int>(kind));
  return status;
}

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", 2014): a
// few lines, no state beyond one word, no allocation; uniform doubles in [0, 1).
struct SplitMix64 {
  uint64_t state;
  double uniform() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
  }
};

// A random pose within the limits: limited hinges uniform in their range, free hinges in
// [-pi, pi], ball joints a uniformly random axis and angle in [0, pi), projected onto their limits.
void random_pose(const Chain& chain, SplitMix64& rng, double* params) {
  for (int i = 0; i < chain.joint_count(); ++i) {
    const int o = chain.dof_offset(i);
    if (is_one_dof(chain.joint_type(i))) {  // prismatic joints always have a range
      const ParamRange range = param_range(chain.joint_type(i), chain.limits(i));
      const double lo = range.limited ? range.min : -so3::kPi;
      const double hi = range.limited ? range.max : so3::kPi;
      params[o] = lo + (hi - lo) * rng.uniform();
    } else {
      const double z = 2.0 * rng.uniform() - 1.0, phi = 2.0 * so3::kPi * rng.uniform();
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double angle = so3::kPi * rng.uniform();
      params[o] = angle * r * std::cos(phi);
      params[o + 1] = angle * r * std::sin(phi);
      params[o + 2] = angle * z;
    }
  }
  project_to_limits(chain, params);
}

// Moves every hinge resting on a bound whose bound +- 2 pi also lies in its range across to that
// value (stuck::wrap_across_bound: the same pose on the other side of the wall). Returns whether any
// hinge moved.
bool wrap_bound_hinges(const Chain& chain, double* params) {
  bool moved = false;
  for (int i = 0; i < chain.joint_count(); ++i) moved = stuck::wrap_across_bound(chain, i, params) || moved;
  return moved;
}

// Seeded restarts (SolverOptions::max_restarts): while the goals are unmet, not provably out of
// reach, restarts are left and the time budget is not spent, the solver runs again from a random
// pose within the limits, or from the last run's end wrapped across its bounds; the best pose
// over every run is kept (params, status). The outer layer of the stuck -> escape mechanism
// (solvers/stuck.hpp): inside a run, a stuck solve escapes by a local, deterministic move (at
// most stuck::kMaxEscapes); across runs, a restart re-seeds the whole pose. Iterations and escapes count every run.
void run_restarts(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                  Workspace& ws, double* p, SolverStatus& status, int& restarts) {
  if (options.max_restarts <= 0 || kind == SolverKind::kTwoBone) return;
  if (status.reason == TerminationReason::kConverged || status.reason == TerminationReason::kInvalidInput) return;
  if (provably_out_of_reach(chain, goals, options.position_tolerance)) return;
  // The budget first: spent, no restart runs, and the last run's pose needs no FK pass to be
  // measured here (on 600 DOF the pass and the measure cost 5-8 us of the exit work, issue 16 item 6).
  if (ws.deadline.hit || ws.deadline.spent()) return;
  const int dofs = chain.dof_count();
  SplitMix64 rng{options.restart_seed};
  forward_kinematics(chain, p, ws);
  double best_cost = measure_goals(chain, goals, ws).cost;
  if (!std::isfinite(best_cost)) best_cost = INFINITY;
  std::copy(p, p + dofs, ws.params_restart_best.data());
  SolverStatus best = status;
  int iterations = status.iterations;
  int escapes = status.escapes;
  // p holds the last run's end; a restart after a fresh draw first tries that end wrapped across
  // its bounds (wrap_bound_hinges), then draws again: alternating, so a wrap never repeats itself.
  bool last_was_wrap = false;
  // The budget is read before each restart: above for the first, at the loop's end for the others.
  for (bool first = true; restarts < options.max_restarts; first = false) {
    if (!first && (ws.deadline.hit || ws.deadline.spent())) break;
    ++restarts;
    if (!last_was_wrap && wrap_bound_hinges(chain, p)) {
      last_was_wrap = true;
    } else {
      random_pose(chain, rng, p);
      last_was_wrap = false;
    }
    SolverStatus run = run_solver(kind, chain, goals, options, ws, p);
    iterations += run.iterations;
    escapes += run.escapes;
    if (run.reason == TerminationReason::kInvalidInput) break;
    forward_kinematics(chain, p, ws);
    const GoalErrors err = measure_goals(chain, goals, ws);
    if (err.cost < best_cost) {  // NaN compares false
      best_cost = err.cost;
      std::copy(p, p + dofs, ws.params_restart_best.data());
      run.start = status.start;  // the reported start stays the caller's
      run.start_measured = status.start_measured;
      best = run;
      if (err.within(options)) break;
    }
  }
  std::copy(ws.params_restart_best.data(), ws.params_restart_best.data() + dofs, p);
  status = best;
  status.iterations = iterations;
  status.escapes = escapes;
}

}  // namespace

Span<const SolverInfo> solver_table() { return Span<const SolverInfo>(kSolverTable, kSolverKindCount); }

const SolverInfo& solver_info(SolverKind kind) { return kSolverTable[static_cast<int>(kind)]; }

Message validate_goal(const Goal& g, int i) {
  if (!(g.weight > 0.0 && g.weight <= kMaxWeight))
    return Message::format("goal %d: weight must be > 0 and <= %g, got %g", i, kMaxWeight, g.weight);
  switch (g.kind) {
    case GoalKind::kPosition:
      if (!within_magnitude(g.target_position))
        return Message::format("goal %d: target_position (%g, %g, %g) must be finite, each component within "
                               "+-%g m", i, g.target_position.x, g.target_position.y, g.target_position.z,
                               kMaxMagnitude);
      break;
    case GoalKind::kOrientation: {
      const glm::dquat& q = g.target_orientation;
      // Overflow-safe: a finite quaternion of huge components is a rotation like any other.
      const double len = so3::scaled_length(q);
      if (!so3::finite(q) || !(len >= 1e-9))
        return Message::format("goal %d: target_orientation must be a finite non-zero quaternion", i);
      break;
    }
    case GoalKind::kAim:
      // Bounded: normalising (1e200, 0, 0) divides by an infinite length and gives the zero vector,
      // which would read as "aim met".
      if (!within_magnitude(g.aim_axis) || glm::length(g.aim_axis) < 1e-9)
        return Message::format("goal %d: aim_axis must be a non-zero vector, each component within +-%g", i,
                               kMaxMagnitude);
      if (!within_magnitude(g.aim_direction) || glm::length(g.aim_direction) < 1e-9)
        return Message::format("goal %d: aim_direction must be a non-zero vector, each component within +-%g", i,
                               kMaxMagnitude);
      break;
    case GoalKind::kAimAt:
      if (!within_magnitude(g.aim_axis) || glm::length(g.aim_axis) < 1e-9)
        return Message::format("goal %d: aim_axis must be a non-zero vector, each component within +-%g", i,
                               kMaxMagnitude);
      if (!within_magnitude(g.target_position))
        return Message::format("goal %d: target_position (the point to aim at) (%g, %g, %g) must be finite, each "
                               "component within +-%g m", i, g.target_position.x, g.target_position.y,
                               g.target_position.z, kMaxMagnitude);
      break;
    default:
      return Message::format("goal %d: unknown kind", i);
  }
  return Message();
}

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
    Message goal = validate_goal(goals[i], i);
    if (!goal.empty()) return goal;
    if (goals[i].effector < 0 || goals[i].effector > chain.joint_count())
      return Message::format("goal %d: effector must be in 0..%d, got %d", i, chain.joint_count(), goals[i].effector);
  }
  return Message();
}

Message validate_inputs(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        const Workspace& ws, const Eigen::Ref<const Eigen::VectorXd>& params) {
  Message m = validate_inputs(chain, goals, options, ws, params);
  if (!m.empty()) return m;
  if (static_cast<int>(kind) < 0 || static_cast<int>(kind) >= kSolverKindCount)
    return Message::format("solver kind %d is unknown (0..%d)", static_cast<int>(kind), kSolverKindCount - 1);
  // What the solver table says each solver takes, checked here once for all of them.
  const SolverInfo& info = solver_info(kind);
  if (!info.prismatic_joints && chain.first_prismatic() >= 0)
    return Message::format("%s turns joints only; joint %d is prismatic: use DLS, the pseudo-inverse or BFGS", info.id,
                           chain.first_prismatic());
  if (info.joint_count != 0 && chain.joint_count() != info.joint_count)
    return Message::format("%s needs a chain of exactly %d joints, got %d", info.id, info.joint_count,
                           chain.joint_count());
  if (info.orientation_goals && !info.intermediate_orientation_goals) {
    for (int g = 0; g < goals.size; ++g) {
      const int k = resolve_effector(chain, goals[g].effector);
      if (goals[g].kind != GoalKind::kPosition && k != chain.joint_count())
        return Message::format("%s: goal %d (orientation/aim) is on effector %d; %s pursues those only on the tip "
                               "(effector 0 or %d): use CCD, DLS or BFGS", info.id, g, k, info.display_name,
                               chain.joint_count());
    }
  }
  switch (kind) {
    case SolverKind::kTwoBone:
      if (goals.size != 1 || goals[0].kind != GoalKind::kPosition || resolve_effector(chain, goals[0].effector) != 2)
        return Message::format(
            "two_bone takes exactly 1 goal, a position goal on the tip (effector 0 or 2); got %d goal(s)",
            goals.size);
      break;
    case SolverKind::kCCD:
      if (goals.size > kCcdMaxGoals)
        return Message::format("ccd supports at most %d goals, got %d", kCcdMaxGoals, goals.size);
      break;
    case SolverKind::kFABRIK: {
      bool tip_frame_goals = false;
      for (int g = 0; g < goals.size; ++g) tip_frame_goals = tip_frame_goals || goals[g].kind != GoalKind::kPosition;
      if (tip_frame_goals && goals.size > kFabrikMaxGoals)
        return Message::format("fabrik supports at most %d goals with orientation/aim goals, got %d", kFabrikMaxGoals,
                               goals.size);
      break;
    }
    default:
      break;
  }
  return Message();
}

// The longest stretch between two budget readings of a solve, in set-up gaps, that the first
// reading predicts (Deadline::stretch_ratio): about the 90th percentile of the longest stretch over
// the set-up gap measured on 100-600 DOF (docs/benchmarks.md, h21budget). One table: a solver's
// first iteration does other work than the set-up (DLS linearises, then steps: its step is the
// longest stretch; CCD's fits cost more toward the root, where more goals lie beyond the joint).
double stretch_ratio_of(SolverKind kind) {
  switch (kind) {
    case SolverKind::kDLS: return 5.5;
    case SolverKind::kCCD: return 4.0;
    case SolverKind::kJacobianPinv: return 3.5;
    case SolverKind::kBFGS: return 2.5;
    case SolverKind::kFABRIK: return 2.5;
    case SolverKind::kTwoBone: break;
  }
  return Deadline::kFirstStretchRatio;
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
  if (options.soft_reach > 0.0) {  // the pulled targets are the goals from here on
    result.soft_pull = soften_goals(chain, goals, options.soft_reach, ws.softened_goals.data());
    goals = Span<const Goal>(ws.softened_goals.data(), goals.size);
  }
  ws.params_backup = params;
  // The budget's start: the reading `start` above (a second read is not free next to a short
  // solve), or the fake clock's when a test installed one. The cap arms itself (Deadline).
  const bool timed = options.time_budget_usec > 0.0;
  const double start_us = !timed                  ? 0.0
                          : ws.deadline.clock_us ? ws.deadline.now_us()
                                                 : std::chrono::duration<double, std::micro>(start.time_since_epoch()).count();
  ws.deadline.start(options.time_budget_usec, start_us, options.time_cap_usec, stretch_ratio_of(kind));
  double* p = params.data();

  // The start pose: the current one (warm start) or the rest pose, made feasible. It is measured
  // here unless the solver measures it itself (solver_measures_start).
  make_start_pose(chain, options, params);
  // A budget can stop a solve before it moves: then the start pose comes back, already measured,
  // and the exit work measures it no second time (below). Kept only when a budget is set.
  const bool budgeted = options.time_budget_usec > 0.0;
  if (budgeted) ws.params_start = params;
  GoalErrors err;
  SolverStatus status;
  const bool self_measured = solver_measures_start(kind);
  if (!self_measured) {
    forward_kinematics(chain, p, ws);
    err = measure_goals(chain, goals, ws);
  }

  if (!self_measured && err.within(options)) {
    status.reason = TerminationReason::kConverged;
  } else if (!self_measured && ws.deadline.spent_before_solver()) {
    // The budget is gone after the set-up, or the solver's own set-up (BFGS evaluates the start
    // again with its gradient: 25-40 us on 600 DOF) would take it past the bound: the start pose,
    // measured, with budget_exhausted (issue 16, item 6).
    status.reason = TerminationReason::kMaxIterations;
  } else {
    status = run_solver(kind, chain, goals, options, ws, p);
    run_restarts(kind, chain, goals, options, ws, p, status, result.restarts);
  }
  const GoalErrors start_err = self_measured ? status.start : err;
  result.initial_error = start_err.combined;
  result.initial_position_error = start_err.max_position;
  result.initial_orientation_error = start_err.max_orientation;
  result.iterations = status.iterations;
  result.escapes = status.escapes;
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
  bool posed = false;
  if (!restored && status.reason != TerminationReason::kInvalidInput && kind != SolverKind::kTwoBone)
    posed = apply_pole(chain, goals, options, ws, p);

  const bool trust_final = status.final_measured && !restored && !posed &&
                           within_beyond_rounding(chain, goals, options, status.final);
  // The pose the solve returns is the start pose, bit for bit (the budget stopped it before it
  // moved, or it was put back): its errors are the start's. Measured by the dispatcher, they are
  // what a measure here would give; measured by the solver (DLS), they are trusted only where its
  // rounding cannot change the verdict (clear_of_tolerance), as for its final measure.
  const bool unchanged = budgeted && !posed && status.reason != TerminationReason::kInvalidInput &&
                         std::memcmp(p, ws.params_start.data(), sizeof(double) * chain.dof_count()) == 0 &&
                         (!self_measured || (status.start_measured &&
                                             clear_of_tolerance(chain, goals, options, status.start)));
  bool fk_current = false;
  if (unchanged) {
    err = start_err;
  } else if (trust_final) {
    err = status.final;
  } else {
    forward_kinematics(chain, p, ws);
    err = measure_goals(chain, goals, ws);
    fk_current = true;
  }
  if (!restored && !(err.cost <= start_err.cost)) {
    // Never worse than the start by the solve's own objective (or non-finite): a solver that ends
    // above it (the pseudo-inverse stalling on an unreachable target with a limited root did) gives
    // the start pose back.
    params = ws.params_backup;
    make_start_pose(chain, options, params);
    forward_kinematics(chain, p, ws);
    err = measure_goals(chain, goals, ws);
    fk_current = true;
  }
  result.final_error = err.combined;
  result.final_position_error = err.max_position;
  result.final_orientation_error = err.max_orientation;
  if (result.reason != TerminationReason::kInvalidInput) {
    if (err.within(options))
      result.reason = TerminationReason::kConverged;
    else if (is_best_reach(chain, goals, options, ws, p, err, fk_current))
      result.reason = TerminationReason::kUnreachable;
    else if (result.reason == TerminationReason::kConverged)
      result.reason = TerminationReason::kStalled;  // a claim the measurement does not confirm
  }
  // The budget's verdict (result.hpp): budget_exhausted comes only with kMaxIterations or
  // kUnreachable. When the budget cut the restarts short after a stalled run (the best run's
  // reason), the solve as a whole stopped for the budget, not for a stall: kMaxIterations. A
  // converged pose, or the start pose put back after a non-finite one, is not the budget's doing.
  if (ws.deadline.hit && !restored && result.reason == TerminationReason::kStalled)
    result.reason = TerminationReason::kMaxIterations;
  result.budget_exhausted = ws.deadline.hit && (result.reason == TerminationReason::kMaxIterations ||
                                                result.reason == TerminationReason::kUnreachable);
  if (result.reason != TerminationReason::kInvalidInput) result.joints_at_limit = joints_at_limit(chain, p);
  ws.deadline.finish();  // the exit work's stretch
  return finish();
}

}  // namespace ikchain
