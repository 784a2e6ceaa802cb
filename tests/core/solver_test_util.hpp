// Checks shared by the solver suites (ccd_test.cpp, fabrik_test.cpp, dls_test.cpp,
// jacobian_pinv_test.cpp, bfgs_test.cpp, two_bone_test.cpp). Each suite keeps its own named TEST
// cases, its seeds, chains, trial counts and thresholds (with the measured figures next to them);
// the loops that were copied between suites live here, parameterised by SolverKind and by what
// the copies did differently (start policy, extra assertions, limit ranges, budgets).
//
// The helpers draw from their random generators in the same order as the loops they replaced, so
// every suite sees the same targets and starts as before.
#pragma once
#include <cmath>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "core/kinematics_internal.hpp"
#include "core/solvers/jacobian_common.hpp"
#include "core/solvers/solvers.hpp"
#include "test_util.hpp"

namespace ikchain {
namespace test {

// Options of one suite for a given chain (the tolerance scales with the chain's length).
using OptionsFor = SolverOptions (*)(const Chain&);

inline SolveResult run(SolverKind kind, const Chain& chain, const std::vector<Goal>& goals, const SolverOptions& o,
                       Workspace& ws, Eigen::VectorXd& params) {
  return solve(kind, chain, Span<const Goal>(goals), o, ws, params);
}

// Position tolerance 1e-5 L: the success criterion of every iterative solver suite. No wall-clock
// cap: the suites assert what the iterations reach, and under a shared machine's load (12-15) the
// 50 ms cap cut 200-joint pseudo-inverse solves short (JacobianPinv.FkRoundTripBallChains,
// BenchmarkTargetSetsAllReached). max_iterations still bounds every solve.
inline SolverOptions tolerance_options(const Chain& c) {
  SolverOptions o;
  o.position_tolerance = 1e-5 * c.total_length();
  o.time_cap_usec = 0.0;
  return o;
}

// Robot arms (the robots bench's criterion): 1e-5 L and 1e-4 rad, no time cap, no restart.
inline SolverOptions arm_options(const Chain& c) {
  SolverOptions o = tolerance_options(c);
  o.orientation_tolerance = 1e-4;
  return o;
}

// The robots bench's start: the middle of every hinge's limits.
inline Eigen::VectorXd middle_of_limits(const Chain& c) {
  Eigen::VectorXd middle(c.dof_count());
  for (int i = 0; i < c.dof_count(); ++i) middle[i] = 0.5 * (c.limits(i).hinge_min + c.limits(i).hinge_max);
  return middle;
}

// CCD and FABRIK: `max_iterations` sweeps, warm start (the default).
inline SolverOptions sweep_options(const Chain& c, int max_iterations = 200) {
  SolverOptions o = tolerance_options(c);
  o.max_iterations = max_iterations;
  return o;
}

// DLS and the pseudo-inverse: the default budget, always from the rest pose.
inline SolverOptions cold_start_options(const Chain& c) {
  SolverOptions o = tolerance_options(c);
  o.warm_start = false;
  return o;
}

inline glm::dvec3 effector_of(const Chain& chain, const Eigen::VectorXd& params, int effector) {
  Workspace ws(chain, 1);
  forward_kinematics(chain, params.data(), ws);
  return effector_position(chain, ws, effector);
}

// ---------------------------------------------------------------------------------------------
// Chains with random joint limits.

enum class LimitedJoints { kAllHinges, kAllBalls, kEveryThirdBall };

// hinge in [-(hinge_base + hinge_spread u), hinge_base + hinge_spread u'], cone angle
// cone_base + cone_spread u, twist like the hinge; u, u' uniform in [0, 1).
struct LimitRanges {
  double hinge_base, hinge_spread;
  double cone_base, cone_spread;
  double twist_base, twist_spread;
};

// kEveryField: every joint draws all five limits (hinge min/max, cone, twist min/max) and gets the
// hinge axis, the joint type only decides which limits are switched on (the CCD / FABRIK chains).
// kOwnFieldsOnly: a joint draws only the limits of its type (the DLS / pinv / BFGS chains).
enum class LimitDraws { kEveryField, kOwnFieldsOnly };

// n joints, unit bones along +Y, hinges about z and x alternately (x so that hinge limits bite on
// bends, unlike the benchmark chain's y twists).
inline Chain limited_chain(int n, LimitedJoints joints, const LimitRanges& r, LimitDraws draws, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    const bool ball = joints == LimitedJoints::kAllBalls || (joints == LimitedJoints::kEveryThirdBall && i % 3 == 2);
    j.type = ball ? JointType::kBall : JointType::kHinge;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    if (!ball || draws == LimitDraws::kEveryField) {
      j.axis = (i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
      j.limits.has_hinge_limit = !ball;
      j.limits.hinge_min = -r.hinge_base - r.hinge_spread * u(rng);
      j.limits.hinge_max = r.hinge_base + r.hinge_spread * u(rng);
    }
    if (ball || draws == LimitDraws::kEveryField) {
      j.limits.has_cone_limit = ball;
      j.limits.cone_angle = r.cone_base + r.cone_spread * u(rng);
      j.limits.has_twist_limit = ball;
      j.limits.twist_min = -r.twist_base - r.twist_spread * u(rng);
      j.limits.twist_max = r.twist_base + r.twist_spread * u(rng);
    }
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

// ---------------------------------------------------------------------------------------------
// Forward-kinematics round trips (KDL solvertest style): random params -> tip target -> solve ->
// own FK distance.

enum class RoundTripStart {
  kRest,                  // params = 0
  kRandom,                // random params (one extra draw per trial); solvers on warm_start = false ignore them
  kAlternateRestRandom,   // rest on even trials, random on odd ones
};

// What each trial asserts besides counting successes; the suites differ and each keeps its own.
struct RoundTripChecks {
  RoundTripStart start = RoundTripStart::kRest;
  bool usable = false;                   // r.usable()
  bool finite_within_limits = false;     // params finite and within the joint limits
  double reported_error_slack = -1.0;    // |r.final_position_error - measured| bound; < 0: not checked
  bool met_means_converged = false;      // a target met within tolerance must report kConverged
  bool count_only_converged = false;     // a success is met AND kConverged (else: met)
};

// CCD / FABRIK: from rest; every solve usable, finite, within limits, its reported error the
// measured one; a met target reports kConverged.
inline RoundTripChecks rest_start_checks() {
  RoundTripChecks k;
  k.usable = true;
  k.finite_within_limits = true;
  k.reported_error_slack = 1e-9;
  k.met_means_converged = true;
  return k;
}

// DLS / pinv: random incoming params (ignored: warm_start = false starts from rest); a met target
// reports kConverged.
inline RoundTripChecks cold_start_checks() {
  RoundTripChecks k;
  k.start = RoundTripStart::kRandom;
  k.met_means_converged = true;
  return k;
}

// BFGS: alternately from rest and from a random pose; usable, reported error the measured one;
// counted only when met and kConverged.
inline RoundTripChecks alternating_start_checks() {
  RoundTripChecks k;
  k.start = RoundTripStart::kAlternateRestRandom;
  k.usable = true;
  k.reported_error_slack = 1e-12;
  k.count_only_converged = true;
  return k;
}

// Returns the fraction of `trials` targets reached within o.position_tolerance.
inline double round_trip_rate(SolverKind kind, const Chain& c, const SolverOptions& o, int trials, unsigned seed,
                              const RoundTripChecks& k) {
  std::mt19937 rng(seed);
  Workspace ws(c, 1);
  int ok = 0;
  for (int t = 0; t < trials; ++t) {
    const Goal g = Goal::position(tip_of(c, random_params(c, rng)));
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    if (k.start == RoundTripStart::kRandom || (k.start == RoundTripStart::kAlternateRestRandom && t % 2 == 1))
      p = random_params(c, rng);
    const SolveResult r = solve(kind, c, Span<const Goal>(&g, 1), o, ws, p);
    const double dist = glm::length(tip_of(c, p) - g.target_position);
    if (k.usable) { EXPECT_TRUE(r.usable()); }
    if (k.finite_within_limits) {
      EXPECT_TRUE(p.allFinite());
      EXPECT_TRUE(within_limits(c, p.data()));
    }
    if (k.reported_error_slack >= 0.0) { EXPECT_NEAR(dist, r.final_position_error, k.reported_error_slack); }
    const bool met = dist <= o.position_tolerance;
    if (met && k.met_means_converged) { EXPECT_EQ(r.reason, TerminationReason::kConverged); }
    if (met && (!k.count_only_converged || r.reason == TerminationReason::kConverged)) ++ok;
  }
  return static_cast<double>(ok) / trials;
}

// Round trips on the benchmark chains n = 2, 3, 7, 10, 30 (hinge chains of unit links, or ball
// chains of 0.5 links), seed seed_base + n, 1000 trials (trials_at_30 for n = 30); each rate >= at_least.
inline void expect_benchmark_round_trips(SolverKind kind, OptionsFor options_for, const RoundTripChecks& k,
                                         JointType joints, unsigned seed_base, int trials_at_30, double at_least) {
  for (int n : {2, 3, 7, 10, 30}) {
    const Chain c = joints == JointType::kHinge ? make_hinge_chain(n) : make_ball_chain(n, 0.5);
    const int trials = n >= 30 ? trials_at_30 : 1000;
    EXPECT_GE(round_trip_rate(kind, c, options_for(c), trials, seed_base + n, k), at_least)
        << n << (joints == JointType::kHinge ? " hinges" : " balls");
  }
}

// ---------------------------------------------------------------------------------------------
// The lecture's precision case: a target 2 beyond full reach along `direction` from the root. The
// optimum is the straight chain pointing at it, 2 away; the solve from `start` must end there,
// within tolerance_per_length * L, and report kUnreachable.

struct Outcome {
  SolveResult result;
  double distance;  // measured |tip - target|
};

inline Outcome expect_ends_two_beyond_reach(SolverKind kind, const Chain& c, const glm::dvec3& direction,
                                            const SolverOptions& o, Workspace& ws, Eigen::VectorXd& start,
                                            double tolerance_per_length = 1e-6) {
  const double L = c.total_length();
  const Goal g = Goal::position(c.root_in_base() + direction * (L + 2.0));
  const SolveResult r = solve(kind, c, Span<const Goal>(&g, 1), o, ws, start);
  const double d = glm::length(tip_of(c, start) - g.target_position);
  EXPECT_EQ(r.reason, TerminationReason::kUnreachable) << to_string(r.reason);
  EXPECT_NEAR(d, 2.0, tolerance_per_length * L);
  return {r, d};
}

// CCD / FABRIK (sweep_options): ball chains n = 2, 3, 7, 10, 30 and benchmark hinge chains n = 3, 7,
// 10, each from a random bent start (seed 21, angles <= 1). The hinge benchmark chain can only lie
// straight in the xy plane (its first bone turns about z): a generic direction in that plane.
inline void expect_precision_case_from_random_bent_starts(SolverKind kind) {
  std::mt19937 rng(21);
  for (int n : {2, 3, 7, 10, 30}) {
    SCOPED_TRACE("ball chain n=" + std::to_string(n));
    const Chain c = make_ball_chain(n);
    Workspace ws(c, 1);
    Eigen::VectorXd p = random_params(c, rng, 1.0);
    expect_ends_two_beyond_reach(kind, c, glm::normalize(glm::dvec3(0.3, -0.5, 0.81)), sweep_options(c), ws, p);
  }
  for (int n : {3, 7, 10}) {
    SCOPED_TRACE("hinge chain n=" + std::to_string(n));
    const Chain c = make_hinge_chain(n);
    Workspace ws(c, 1);
    Eigen::VectorXd p = random_params(c, rng, 1.0);
    expect_ends_two_beyond_reach(kind, c, glm::normalize(glm::dvec3(-0.6, 0.35, 0.0)), sweep_options(c), ws, p);
  }
}

// DLS / pinv: the 10-hinge benchmark chain (straightens only within the xy-plane: joint 0 turns
// about z, the y-hinges twist about their own bones) and a 10-ball chain (can point anywhere), from
// a fixed bent start, warm. The reported error must be the measured one.
inline void expect_precision_case_from_fixed_bent_start(SolverKind kind, OptionsFor options_for) {
  struct Case {
    Chain chain;
    glm::dvec3 direction;
  };
  const std::vector<Case> cases = {
      {make_hinge_chain(10), glm::dvec3(std::cos(0.7), std::sin(0.7), 0.0)},
      {make_ball_chain(10, 0.5), glm::normalize(glm::dvec3(0.3, 0.8, -0.5))},
  };
  for (const Case& c : cases) {
    Workspace ws(c.chain, 1);
    SolverOptions o = options_for(c.chain);
    o.warm_start = true;
    Eigen::VectorXd params(c.chain.dof_count());
    for (int i = 0; i < params.size(); ++i) params[i] = (i % 2 == 0) ? 0.35 : -0.25;  // bent start
    const Outcome out = expect_ends_two_beyond_reach(kind, c.chain, c.direction, o, ws, params);
    EXPECT_NEAR(out.result.final_error, out.distance, 1e-12);
  }
}

// ---------------------------------------------------------------------------------------------
// Singular starts: the straight rest pose with targets on the chain's own line (J^T e = 0 for the
// Jacobian methods, a degenerate plane for the per-joint ones), and a target exactly on the root.

struct StraightStartChecks {
  bool finite = false;              // params finite
  bool no_worse = false;            // final error <= initial error
  bool within_tolerance = false;    // tip within position_tolerance of the target
  // A target (fraction of L) whose convergence is not asserted (a known fixed point); NaN: none.
  double not_asserted_converged = std::numeric_limits<double>::quiet_NaN();
};

// Targets (0, f L, 0) for each f in `fractions`, each solved from the straight rest pose; each
// must report kConverged (except `not_asserted_converged`) and pass `k`.
inline void expect_solves_from_straight_rest(SolverKind kind, const Chain& c, const SolverOptions& o, Workspace& ws,
                                             std::initializer_list<double> fractions, const StraightStartChecks& k) {
  const double L = c.total_length();
  for (double f : fractions) {
    const glm::dvec3 target(0, f * L, 0);
    const Goal g = Goal::position(target);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = solve(kind, c, Span<const Goal>(&g, 1), o, ws, p);
    if (k.finite) { EXPECT_TRUE(p.allFinite()); }
    if (k.no_worse) { EXPECT_LE(r.final_error, r.initial_error); }
    if (f != k.not_asserted_converged) { EXPECT_EQ(r.reason, TerminationReason::kConverged) << target.y; }
    if (k.within_tolerance) { EXPECT_LE(glm::length(tip_of(c, p) - target), o.position_tolerance); }
  }
}

// Target exactly on the root, from rest: no NaN ever reaches the caller; a finite, usable pose no
// farther from the target than the start, converged if `must_converge` (chains that can fold onto
// their root).
inline void expect_target_on_root_finite_and_no_worse(SolverKind kind, const Chain& c, const SolverOptions& o,
                                                      Workspace& ws, bool must_converge) {
  const Goal on_root = Goal::position(c.root_in_base());
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult r = solve(kind, c, Span<const Goal>(&on_root, 1), o, ws, p);
  EXPECT_TRUE(p.allFinite());
  EXPECT_TRUE(r.usable());
  EXPECT_LE(r.final_error, r.initial_error);
  if (must_converge) { EXPECT_EQ(r.reason, TerminationReason::kConverged); }
}

// CCD / FABRIK (sweep_options): the straight 4-ball and 4-hinge chains at rest with targets 0.6 L
// and 0.9 L ahead and 0.5 L behind the root (all reachable), checked as given per chain; then a
// target on the root, reached by the ball chain (it can fold onto its root).
inline void expect_sweep_singular_starts(SolverKind kind, const StraightStartChecks& ball_checks,
                                         const StraightStartChecks& hinge_checks) {
  for (const Chain& c : {make_ball_chain(4), make_hinge_chain(4)}) {
    Workspace ws(c, 1);
    const SolverOptions o = sweep_options(c);
    const bool ball = c.joint_type(0) == JointType::kBall;
    expect_solves_from_straight_rest(kind, c, o, ws, {0.6, 0.9, -0.5}, ball ? ball_checks : hinge_checks);
    expect_target_on_root_finite_and_no_worse(kind, c, o, ws, ball);
  }
}

// DLS / pinv: the straight 10-hinge and 6-ball chains at rest, targets 0.6 L ahead and 0.5 L behind
// the root: converged, within tolerance.
inline void expect_jacobian_singular_starts_solved(SolverKind kind, OptionsFor options_for) {
  StraightStartChecks checks;
  checks.within_tolerance = true;
  for (const Chain& chain : {make_hinge_chain(10), make_ball_chain(6)}) {
    Workspace ws(chain, 1);
    expect_solves_from_straight_rest(kind, chain, options_for(chain), ws, {0.6, -0.5}, checks);
  }
}

// DLS / pinv: the 4-hinge and 4-ball chains (both can fold onto their root), target on the root:
// finite, no worse than the start, converged.
inline void expect_jacobian_target_on_root_reached(SolverKind kind, OptionsFor options_for) {
  for (const Chain& chain : {make_hinge_chain(4), make_ball_chain(4)}) {
    Workspace ws(chain, 1);
    expect_target_on_root_finite_and_no_worse(kind, chain, options_for(chain), ws, true);
  }
}

// ---------------------------------------------------------------------------------------------
// Joint limits.

// Random targets in a cube of half-size 1.5 L (reachable or not), each from a random start: the
// pose returned is within the limits.
inline void expect_limits_hold_for_random_targets(SolverKind kind, const Chain& c, const SolverOptions& o,
                                                  std::mt19937& rng, int trials) {
  Workspace ws(c, 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < trials; ++t) {
    const Goal g = Goal::position(glm::dvec3(u(rng), u(rng), u(rng)) * (1.5 * c.total_length()));
    Eigen::VectorXd p = random_params(c, rng);
    solve(kind, c, Span<const Goal>(&g, 1), o, ws, p);
    EXPECT_TRUE(within_limits(c, p.data()));
  }
}

// Minimum success rates per chain of the CCD / FABRIK limits test.
struct UniformLimitRates {
  double hinge_3, hinge_7, ball_3, ball_7;
};

// CCD / FABRIK: all-hinge and all-ball chains of 3 and 7 joints (seed 31, limits drawn for every
// field: hinges in [-(0.2 + 1.8 u), 0.2 + 1.8 u'], cones 0.3 + 1.2 u, twists [-(0.1 + 0.9 u),
// 0.1 + 0.9 u']): round trips (300, seed 40 + n, 200 sweeps, rest-start checks) at the given rates,
// then 50 random targets whose poses must stay within the limits.
inline void expect_limits_respected_on_uniform_chains(SolverKind kind, const UniformLimitRates& at_least) {
  const LimitRanges ranges = {0.2, 1.8, 0.3, 1.2, 0.1, 0.9};
  std::mt19937 rng(31);
  for (bool hinge : {true, false}) {
    for (int n : {3, 7}) {
      const Chain c = limited_chain(n, hinge ? LimitedJoints::kAllHinges : LimitedJoints::kAllBalls, ranges,
                                    LimitDraws::kEveryField, rng);
      const double expected =
          hinge ? (n == 3 ? at_least.hinge_3 : at_least.hinge_7) : (n == 3 ? at_least.ball_3 : at_least.ball_7);
      EXPECT_GE(round_trip_rate(kind, c, sweep_options(c, 200), 300, 40 + n, rest_start_checks()), expected)
          << "hinge=" << hinge << " n=" << n;
      expect_limits_hold_for_random_targets(kind, c, sweep_options(c), rng, 50);
    }
  }
}

struct Tally {
  int ok = 0, trials = 0;
  double rate() const { return static_cast<double>(ok) / trials; }
};

// DLS / pinv: 10 chains of 7 joints, every third a ball (seed 11; hinges in [-(0.2 + 1.5 u),
// 0.2 + 1.5 u'], cones 0.3 + 1.2 u, twists [-(0.2 + u), 0.2 + u']), 50 feasible targets each (FK
// of feasible params) solved from rest; every pose within the limits (fatal otherwise: call
// through ASSERT_NO_FATAL_FAILURE); counts the targets reached.
inline void reach_feasible_targets_on_mixed_chains(SolverKind kind, OptionsFor options_for, Tally& tally) {
  const LimitRanges ranges = {0.2, 1.5, 0.3, 1.2, 0.2, 1.0};
  std::mt19937 rng(11);
  for (int chain_index = 0; chain_index < 10; ++chain_index) {
    const Chain chain = limited_chain(7, LimitedJoints::kEveryThirdBall, ranges, LimitDraws::kOwnFieldsOnly, rng);
    Workspace ws(chain, 1);
    const SolverOptions o = options_for(chain);
    for (int t = 0; t < 50; ++t, ++tally.trials) {
      const glm::dvec3 target = tip_of(chain, random_params(chain, rng));
      // Ignored by these options (they start from rest), but validated like any params: never
      // uninitialised memory (mingw's heap handed out NaNs where glibc's happened to be zero).
      Eigen::VectorXd params = Eigen::VectorXd::Zero(chain.dof_count());
      run(kind, chain, {Goal::position(target)}, o, ws, params);
      ASSERT_TRUE(within_limits(chain, params.data())) << "chain " << chain_index << " trial " << t;
      if (glm::length(tip_of(chain, params) - target) <= o.position_tolerance) ++tally.ok;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Several goals.

// DLS / pinv: on a 4-ball chain (0.5 links), 100 poses made by FK (seed 5): tip position +
// orientation, orientation of effector 2, aim, and elbow + hand positions, each solved from rest.
// Every solve meets every goal and every trial converges on all four.
inline void expect_orientation_aim_and_two_goal_solves(SolverKind kind, OptionsFor options_for) {
  const Chain chain = make_ball_chain(4, 0.5);
  std::mt19937 rng(5);
  Workspace ws(chain, 4);
  const SolverOptions o = options_for(chain);
  int ok = 0;
  const int trials = 100;
  for (int t = 0; t < trials; ++t) {
    const Eigen::VectorXd truth = random_params(chain, rng, 1.5);
    Workspace fk(chain, 1);
    forward_kinematics(chain, truth.data(), fk);
    const glm::dvec3 hand = fk.tip, elbow = fk.joint_origins[2];
    const glm::dquat hand_rotation = fk.joint_orientations[3];
    const std::vector<std::vector<Goal>> problems = {
        {Goal::position(hand), Goal::orientation(hand_rotation)},
        {Goal::orientation(hand_rotation, 2)},
        {Goal::aim(glm::dvec3(0, 1, 0), hand_rotation * glm::dvec3(0, 1, 0))},
        {Goal::position(elbow, 2), Goal::position(hand)},
    };
    bool all = true;
    for (const std::vector<Goal>& goals : problems) {
      Eigen::VectorXd params = Eigen::VectorXd::Zero(chain.dof_count());
      const SolveResult r = run(kind, chain, goals, o, ws, params);
      all = all && r.reason == TerminationReason::kConverged;
      EXPECT_LE(r.final_position_error, o.position_tolerance);
      EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
    }
    ok += all;
  }
  EXPECT_EQ(ok, trials);
}

// ---------------------------------------------------------------------------------------------
// Deterministic starts, fast paths, allocation, input rules.

struct ColdStartChecks {
  bool converged = false;            // every cold solve reports kConverged
  bool warm_restart_is_free = false; // a warm re-solve from the converged pose takes 0 iterations
};

// `o` has warm_start = false: 20 tip targets (FK of random params), each solved from two different
// random incoming poses, must give identical params and iteration counts.
inline void expect_cold_start_ignores_incoming_params(SolverKind kind, const Chain& chain, SolverOptions o,
                                                      Workspace& ws, std::mt19937& rng, const ColdStartChecks& k) {
  for (int t = 0; t < 20; ++t) {
    const std::vector<Goal> goals = {Goal::position(tip_of(chain, random_params(chain, rng)))};
    Eigen::VectorXd a = random_params(chain, rng), b = random_params(chain, rng);
    const SolveResult ra = run(kind, chain, goals, o, ws, a);
    const SolveResult rb = run(kind, chain, goals, o, ws, b);
    EXPECT_EQ(a, b);
    EXPECT_EQ(ra.iterations, rb.iterations);
    if (k.converged) { EXPECT_EQ(ra.reason, TerminationReason::kConverged); }
    if (k.warm_restart_is_free) {
      o.warm_start = true;
      const SolveResult warm = run(kind, chain, goals, o, ws, a);
      EXPECT_EQ(warm.reason, TerminationReason::kConverged);
      EXPECT_EQ(warm.iterations, 0);
      EXPECT_EQ(a, b);
      o.warm_start = false;
    }
  }
}

// CCD / FABRIK: the 7-hinge benchmark chain, seed 61, sweep_options with warm_start = false.
inline void expect_sweep_solver_ignores_incoming_params(SolverKind kind) {
  std::mt19937 rng(61);
  const Chain c = make_hinge_chain(7);
  Workspace ws(c, 1);
  SolverOptions o = sweep_options(c);
  o.warm_start = false;
  expect_cold_start_ignores_incoming_params(kind, c, o, ws, rng, {});
}

// DLS / pinv: the 10-hinge benchmark chain, seed 3; a warm re-solve from the converged pose has
// nothing left to do.
inline void expect_jacobian_solver_ignores_incoming_params(SolverKind kind, OptionsFor options_for) {
  const Chain chain = make_hinge_chain(10);
  Workspace ws(chain, 2);
  std::mt19937 rng(3);
  ColdStartChecks checks;
  checks.warm_restart_is_free = true;
  expect_cold_start_ignores_incoming_params(kind, chain, options_for(chain), ws, rng, checks);
}

using SolverFunction = SolverStatus (*)(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double*);

// What the fused single-position fast path must share with the generic goal machinery beyond the
// same cost and Jacobian: kBothConverge (both solve every problem) or kSameReason (they stop for
// the same reason, and within tolerance when converged).
enum class PathAgreement { kBothConverge, kSameReason };

// The fused single-position fast path and the generic goal machinery: the same cost and Jacobian
// at random poses (to rounding), and both solve the same problems (seed 9, 200 per chain).
inline void expect_fast_path_agrees_with_generic(OptionsFor options_for, SolverFunction fast_solver,
                                                 SolverFunction generic_solver, PathAgreement agreement) {
  for (const Chain& chain : {make_hinge_chain(10), make_ball_chain(5), make_hinge_chain(3)}) {
    std::mt19937 rng(9);
    Workspace ws(chain, 1), generic_ws(chain, 1);
    const SolverOptions o = options_for(chain);
    const int n = chain.dof_count();
    for (int t = 0; t < 200; ++t) {
      const int effector = t % 3 == 0 ? 0 : 1 + t % chain.joint_count();
      const std::vector<Goal> goals = {
          Goal::position(effector_of(chain, random_params(chain, rng), effector), effector, 0.7)};
      const Eigen::VectorXd pose = random_params(chain, rng);
      jacobian::SinglePositionModel model(chain, goals[0], ws);
      const double cost = model.evaluate(pose.data());
      model.accept();
      model.linearize(pose.data());
      forward_kinematics(chain, pose.data(), generic_ws);
      compute_dof_axes(chain, pose.data(), generic_ws);
      Eigen::VectorXd e(3);
      const GoalErrors err = evaluate_goals(chain, goals, generic_ws, e);
      Eigen::MatrixXd J(3, n);
      compute_jacobian(chain, goals, generic_ws, J);
      EXPECT_NEAR(cost, err.cost, 1e-12 * (1.0 + err.cost));
      const int active = model.active_dofs();
      EXPECT_LE((ws.jacobian.topLeftCorner(3, active) - J.leftCols(active)).norm(), 1e-12 * (1.0 + J.norm()));
      EXPECT_EQ(J.rightCols(n - active).norm(), 0.0);  // DOFs past the effector do not move it

      Eigen::VectorXd fast = Eigen::VectorXd::Zero(n), generic = fast;
      const SolverStatus sf = fast_solver(chain, goals, o, ws, fast.data());
      const SolverStatus sg = generic_solver(chain, goals, o, ws, generic.data());
      if (agreement == PathAgreement::kBothConverge) {
        EXPECT_EQ(sf.reason, TerminationReason::kConverged);
        EXPECT_EQ(sg.reason, TerminationReason::kConverged);
      } else {
        EXPECT_EQ(sf.reason, sg.reason);
      }
      if (agreement == PathAgreement::kBothConverge || sf.reason == TerminationReason::kConverged) {
        EXPECT_LE(glm::length(effector_of(chain, fast, goals[0].effector) - goals[0].target_position),
                  o.position_tolerance);
        EXPECT_LE(glm::length(effector_of(chain, generic, goals[0].effector) - goals[0].target_position),
                  o.position_tolerance);
      }
    }
  }
}

// After a warm-up solve of `goals` from rest, solving them again from rest and then a far
// (unreachable) target allocates nothing.
inline void expect_solves_allocate_nothing(SolverKind kind, const Chain& c, const std::vector<Goal>& goals,
                                           const SolverOptions& o) {
  Workspace ws(c, static_cast<int>(goals.size()));
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  run(kind, c, goals, o, ws, p);  // warm-up
  p.setZero();
  const std::size_t before = allocation_count();
  run(kind, c, goals, o, ws, p);
  const Goal far = Goal::position(glm::dvec3(0, 30, 0));
  solve(kind, c, Span<const Goal>(&far, 1), o, ws, p);
  EXPECT_EQ(allocation_count(), before);
}

// DLS / pinv on the 10-hinge chain: the fast path and both generic shapes (fewer rows than DOFs,
// and at least as many), each solve after its warm-up allocates nothing.
inline void expect_jacobian_solves_allocate_nothing(SolverKind kind, OptionsFor options_for) {
  const Chain chain = make_hinge_chain(10);
  Workspace ws(chain, 4);
  const SolverOptions o = options_for(chain);
  std::mt19937 rng(1);
  const glm::dvec3 hand = tip_of(chain, random_params(chain, rng));
  const std::vector<std::vector<Goal>> problems = {
      {Goal::position(hand)},                                              // fast path
      {Goal::position(glm::dvec3(1, 2, 0), 5), Goal::position(hand)},      // generic, m < n
      {Goal::position(hand), Goal::orientation(glm::dquat(1, 0, 0, 0)),   // generic, m >= n
       Goal::aim(glm::dvec3(0, 1, 0), glm::dvec3(1, 0, 0), 3), Goal::position(glm::dvec3(0, 3, 0), 4)},
  };
  // Zeros, not uninitialised memory: the first solve validates them (under wine the heap handed out
  // non-finite values and every solve was refused as invalid input).
  Eigen::VectorXd params = Eigen::VectorXd::Zero(chain.dof_count());
  for (const std::vector<Goal>& goals : problems) {
    run(kind, chain, goals, o, ws, params);  // warm-up
    const std::size_t before = allocation_count();
    const SolveResult r = run(kind, chain, goals, o, ws, params);
    EXPECT_EQ(allocation_count(), before);
    EXPECT_TRUE(r.usable());
  }
}

// The solve is refused with kInvalidInput, a message containing `message_part`, and params as given.
inline void expect_rejected_and_untouched(SolverKind kind, const Chain& chain, const std::vector<Goal>& goals,
                                          const SolverOptions& o, const Eigen::VectorXd& params,
                                          const char* message_part) {
  Workspace ws(chain, static_cast<int>(goals.size()));
  Eigen::VectorXd p = params;
  const SolveResult r = run(kind, chain, goals, o, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find(message_part), std::string::npos);
  EXPECT_EQ(p, params);
}

}  // namespace test
}  // namespace ikchain
