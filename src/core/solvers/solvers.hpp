// The individual solvers, one per file in this folder. Call them through solve() (solve.hpp),
// which does everything common to all of them; each function here may assume that:
//  - chain, goals, options, params and workspace were validated (finite, sizes fit, weights > 0,
//    effectors in range, workspace.fits(chain, goals.size)), and so was what the solver table
//    (solver_table(), solve.cpp) says the solver takes: joint types, chain length, goal kinds and
//    where they sit, goal counts (validate_inputs(kind, ...));
//  - params hold the start pose (warm or rest), already projected onto the joint limits;
//  - the start pose is NOT already within tolerance.
// Exception: solvers for which solver_measures_start() is true (the Jacobian family's models
// evaluate every pose they visit anyway) are also called when the start pose is within tolerance;
// they measure it, return kConverged with 0 iterations, and report the start's errors in
// SolverStatus::start.
// Each must: allocate nothing and throw nothing; keep params within the joint limits; leave params
// at the best (lowest-cost) pose it reached; return kConverged when every goal is within tolerance,
// else kMaxIterations (budget spent) or kStalled (no further progress). solve() turns a
// non-converged stop at a stationary best reach into kUnreachable.
#pragma once
#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "core/kinematics_internal.hpp"
#include "ikchain/message.hpp"
#include "ikchain/options.hpp"
#include "ikchain/result.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain {

struct SolverStatus {
  TerminationReason reason = TerminationReason::kStalled;
  int iterations = 0;
  int escapes = 0;  // stuck -> escape moves made (solvers/stuck.hpp), at most stuck::kMaxEscapes
  Message message;  // for kInvalidInput
  // Errors the solver measured with its own forward kinematics, so solve() need not run it again
  // (on short chains the dispatcher's own FK passes are a noticeable part of a solve).
  // `start`: the pose it was given; required from solvers with solver_measures_start().
  // `final`: the params it returns, exactly; optional (solve() measures when final_measured is false).
  GoalErrors start, final;
  bool start_measured = false;
  bool final_measured = false;
};

// CCD tracks each goal's effector in a fixed array: more goals are rejected (solve() checks this
// before anything else, so the verdict does not depend on the start pose).
constexpr int kCcdMaxGoals = 16;
constexpr int kFabrikMaxGoals = 16;  // with orientation/aim goals (the final alignment tracks each goal)

// True for the solvers that measure the start pose themselves (see above): DLS.
inline bool solver_measures_start(SolverKind kind) { return kind == SolverKind::kDLS; }

SolverStatus solve_two_bone(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);
SolverStatus solve_ccd(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);
SolverStatus solve_jacobian_pinv(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);
SolverStatus solve_dls(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);
SolverStatus solve_bfgs(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);
SolverStatus solve_fabrik(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);

}  // namespace ikchain
