// The solver a node's `solver` property picks: its value (saved in scenes) -> a core solver, or
// Auto. The table is the Godot layer's own, not the core's SolverKind order: a solver added to the
// core gets a new row with a new value, so no value saved in a scene ever changes its meaning.
#pragma once

#include <cstdint>
#include <string>

#include "ikchain/ikchain.hpp"

namespace ikchain::godot {

struct SolverChoice {
  int64_t value;         // saved in scenes: never renumber, never reuse
  const char* constant;  // the script constant (IKChain.SOLVER_DLS, IKBody.SOLVER_DLS)
  bool is_auto;          // the node picks per problem (then `kind` is unused)
  SolverKind kind;
};

inline constexpr int64_t kSolverAutoValue = 6;

inline constexpr SolverChoice kSolverChoices[] = {
    {0, "SOLVER_TWO_BONE", false, SolverKind::kTwoBone},
    {1, "SOLVER_CCD", false, SolverKind::kCCD},
    {2, "SOLVER_JACOBIAN", false, SolverKind::kJacobianPinv},
    {3, "SOLVER_DLS", false, SolverKind::kDLS},
    {4, "SOLVER_BFGS", false, SolverKind::kBFGS},
    {5, "SOLVER_FABRIK", false, SolverKind::kFABRIK},
    {kSolverAutoValue, "SOLVER_AUTO", true, SolverKind::kDLS},
};

// The row of `value`; null when no row has it.
const SolverChoice* find_solver_choice(int64_t value);
// The smallest and largest value of the table (out-of-range values set from scripts are clamped
// into this range, then fall back to Auto if they name no row).
int64_t min_solver_value();
int64_t max_solver_value();
// The inspector's enum hint ("Two Bone:0,...,Auto:6"); with `trees_only`, only the solvers that
// solve trees (the core's table, column `trees`) and Auto.
std::string solver_hint(bool trees_only);
// The core's name of the choice ("Damped Least Squares", "Auto").
const char* solver_display_name(const SolverChoice& choice);

}  // namespace ikchain::godot
