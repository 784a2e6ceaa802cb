// Solver options: every field has its default here, with its unit. validate() names a bad field.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "ikchain/message.hpp"

namespace ikchain {

enum class SolverKind : int {
  kTwoBone = 0,       // analytic, exactly 2 joints (law of cosines), optional pole
  kCCD = 1,           // cyclic coordinate descent
  kJacobianPinv = 2,  // Jacobian pseudo-inverse with residual check and step halving
  kDLS = 3,           // damped least squares / Levenberg-Marquardt, adaptive damping
  kBFGS = 4,          // quasi-Newton with a Wolfe line search
  kFABRIK = 5,        // forward and backward reaching
};
constexpr int kSolverKindCount = 6;
// 2^-60 of any step is below the resolution of a double angle: more halvings only cost time
// (docs/solvers.md, "Why these constants").
constexpr int kMaxPinvHalvings = 60;
// The same for the BFGS line search's trial steps (a fuzzer input ran for seconds without it): its
// bracket shrinks at every step, and 100 steps are far past where the step stops changing.
constexpr int kMaxBfgsLineSearchSteps = 100;
// SolverOptions::time_cap_usec's default (microseconds).
constexpr double kDefaultTimeCapUsec = 50000.0;
const char* to_string(SolverKind kind);

struct SolverOptions {
  // --- common
  int max_iterations = 100;            // > 0; one iteration = one solver step / sweep
  double position_tolerance = 1e-5;    // m; converged when every position goal is this close
  double orientation_tolerance = 1e-4; // rad; converged when every orientation/aim goal is this close
  // A solve is stuck when 3 iterations in a row lower the best objective seen by less than this
  // fraction of it (relative, dimensionless); it then escapes (at most 5 times; 21 for a query: solvers.md, "The escape") or stops as
  // "stalled" (solvers/stuck.hpp, docs/solvers.md "When a solve is stuck").
  double stall_tolerance = 1e-10;
  // true: start from the params given (the current pose); false: start from the rest pose
  // (params = 0), so the result depends only on the goals (deterministic across frames).
  bool warm_start = true;
  // Largest rotation a single iteration may apply to one joint (rad); 0 = no cap.
  double max_step_angle = 0.0;
  // Wall-clock budget of one solve (microseconds, >= 0; 0 = none). Checked on the steady clock
  // before every iteration (the first included), before each linearisation of DLS and the
  // pseudo-inverse, and inside the long inner loops (the pseudo-inverse's halvings, BFGS's
  // line-search steps and its O(n^2) passes every 64 columns, CCD's and FABRIK's sweeps every 16
  // joints, eigen-decompositions of 9 x 9 and up every 10k flops of a sweep, the escapes), so a solve overruns
  // it by at most one such piece plus the exit work. Each check also times the gap since the one
  // before, and the solve stops before the budget's end when the next piece and the exit work,
  // predicted from those gaps, would end past 1.1 x budget + 20 us (Deadline::foreseen; a budget
  // too small for one iteration may then return the start pose). Measured against that bound in
  // CPU time by bench/budget_bench.cpp (`scripts/bench --budget`; docs/solvers.md, "Time budget
  // and the safety cap"). The result then has reason kMaxIterations (or kUnreachable for a provable
  // best reach) and budget_exhausted = true, with the best pose reached so far.
  double time_budget_usec = 0.0;
  // A safety cap on every solve's CPU time, the solving thread's (microseconds, >= 0; 0 = none), on
  // whether or not time_budget_usec is set: one misconfigured solve (the pseudo-inverse on 200 bones
  // at 1,000 iterations took 1.9 s) must not freeze a game. Far above any frame (kDefaultTimeCapUsec
  // = 50 ms): a net, not a budget; set time_budget_usec for a frame's share. CPU time, not the wall
  // clock: a thread the system sets aside has its solve cut for work it never did (a pop on a loaded
  // machine). A solve the cap stops ends like a budget-bound one (budget_exhausted = true). Checked
  // at every 8th budget check, counted from the first of those, which comes only once the solve has
  // done ~25-50 us of work or 64 checks (a CPU-clock reading is a system call), so short solves read
  // no clock for it; under a budget no longer than the cap it is not checked at all
  // (docs/solvers.md, "Time budget").
  double time_cap_usec = kDefaultTimeCapUsec;
  // Restarts (off by default: a game wants frame-to-frame continuity, and a restart may jump to
  // another branch). When a solve ends without meeting its goals and they are not provably out of
  // reach, it is run again from up to max_restarts random poses within the limits, drawn from a
  // generator seeded with restart_seed (the same seed gives the same poses, so the same result);
  // the best pose over all runs is kept. Iterations and the time budget count every run. Without
  // restarts a run's escapes from stuck poses try harder (docs/solvers.md, "When a solve is stuck").
  int max_restarts = 0;        // >= 0
  uint64_t restart_seed = 1;   // any value; all 64 bits seed the generator

  // --- pole (every solver)
  // A point in base space the chain's middle should bend toward (a knee or an elbow "pole vector").
  // Two-bone: it fixes the bend plane (root, target, pole). Every other solver: a soft preference
  // applied after the solve, which never worsens the goals: the chain is swivelled about its
  // root -> tip axis toward the pole (see apply_pole() in solve.cpp for what moves and when).
  bool use_pole = false;
  glm::dvec3 pole_in_base{0.0};  // m

  // --- soft reach (every solver; off by default)
  // A limb straightening toward a target near its full reach R snaps its last degrees of knee or
  // elbow in a frame or two: the bend angle goes as sqrt(R - d), 12 deg over the last 5 mm of a
  // 0.87 m leg. Soft IK (as Final IK and Unreal offer; Harris's exponential soft zone): with
  // soft_reach = s > 0, a position goal whose target lies farther than R - s from the root joint's
  // origin (R: the bones before its effector) is pulled toward the root, to distance
  // R - s + s (1 - exp(-(d - R + s) / s)): continuous, smooth (C1 at R - s), always short of R, so
  // the limb straightens only asymptotically and a target beyond R is followed without a snap.
  // The pulled target is the goal: errors and the reason refer to it, and SolveResult::soft_pull
  // says how far it was pulled. s is capped at R.
  double soft_reach = 0.0;  // m, >= 0 (0 = off); e.g. 5 % of the limb's length

  // --- Jacobian pseudo-inverse
  // The step is halved while the change the trial pose achieves misses the change the step
  // promised (J J+ de) by more than this fraction of it (dimensionless, in (0, 1]); see
  // solvers/jacobian_pinv.cpp for why this, not |(I - J J+) de| / |de|, is what halving controls.
  // 0.5: a step must deliver at least half the change it promised (stricter values need several
  // times the iterations: docs/solvers.md, "Why these constants").
  double pinv_residual_tolerance = 0.5;
  int pinv_max_halvings = 20;          // in [0, kMaxPinvHalvings]
  double pinv_singular_threshold = 1e-9;  // singular values below this (m/rad) are treated as 0

  // --- damped least squares (Levenberg-Marquardt)
  double dls_initial_damping = 1e-3;   // lambda^2 start, m^2
  double dls_min_damping = 1e-12;      // m^2, > 0
  double dls_max_damping = 1e6;        // m^2, >= dls_min_damping

  // --- BFGS (Wolfe line search, Nocedal & Wright Alg. 3.5/3.6)
  double bfgs_wolfe_c1 = 1e-4;         // sufficient decrease, 0 < c1 < c2 < 1
  double bfgs_wolfe_c2 = 0.9;          // curvature condition
  int bfgs_max_line_search_steps = 20; // in [1, kMaxBfgsLineSearchSteps]

  // Empty message when valid; otherwise names the field: "position_tolerance must be > 0, got -1".
  Message validate() const;
};

}  // namespace ikchain
