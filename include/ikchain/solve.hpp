// The one entry point: every solver has the same call (like KDL's position solvers).
#pragma once
#include <Eigen/Dense>

#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "ikchain/options.hpp"
#include "ikchain/result.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain {

// Moves `params` (joint parameters, chain.dof_count() entries; see chain.hpp) toward the goals.
// On kInvalidInput params are untouched and result.message names the bad field. Never allocates
// when workspace.fits(chain, goals.size); never throws; never writes a non-finite value to params.
// The workspace's contents afterwards are scratch (call forward_kinematics() for the final pose's frames).
SolveResult solve(SolverKind kind, const Chain& chain, Span<const Goal> goals,
                  const SolverOptions& options, Workspace& workspace, Eigen::Ref<Eigen::VectorXd> params);

// The solver table: one row per SolverKind, in enum order - what the engine layer's enum, hint
// strings and docs are generated from or checked against. solve() dispatches through the same
// table (solve.cpp), so a solver cannot exist without its row.
struct SolverInfo {
  SolverKind kind;
  const char* id;            // to_string(kind): "dls"
  const char* display_name;  // "Damped Least Squares"
  int joint_count;           // the only chain length it takes (two-bone: 2), or 0 for any
  bool orientation_goals;    // pursues orientation, aim and aim-at goals (else position goals only)
  bool intermediate_orientation_goals;  // ... on effectors other than the tip too (FABRIK: tip only)
  bool several_goals;        // takes more than one goal
  bool prismatic_joints;     // takes chains with prismatic joints
  bool trees;                // solves branched trees in one coupled problem (solve_tree); strict priority
                             // levels: DLS only, the others weigh levels (docs/full-body.md)
};
Span<const SolverInfo> solver_table();
const SolverInfo& solver_info(SolverKind kind);  // kind must be one of the enum's values

// One goal's own fields (weight, kind, target, axes; `index` names it in the message): the per-goal
// check solve() and solve_tree() share. The effector's range is the caller's (chains and trees
// count effectors differently).
Message validate_goal(const Goal& goal, int index);

// The checks solve() makes before running a solver; empty message when all is well.
Message validate_inputs(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        const Workspace& workspace, const Eigen::Ref<const Eigen::VectorXd>& params);
// The same plus the solver's own rules (a known kind; two-bone: exactly 2 joints and one tip
// position goal; CCD: at most kCcdMaxGoals goals). solve() makes all of them before it looks at the
// start pose, so an input gets the same verdict whatever the target.
Message validate_inputs(SolverKind kind, const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                        const Workspace& workspace, const Eigen::Ref<const Eigen::VectorXd>& params);

}  // namespace ikchain
