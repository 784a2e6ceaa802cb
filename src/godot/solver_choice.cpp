#include "solver_choice.hpp"

#include <algorithm>

namespace ikchain::godot {

const SolverChoice* find_solver_choice(int64_t value) {
  for (const SolverChoice& c : kSolverChoices)
    if (c.value == value) return &c;
  return nullptr;
}

int64_t min_solver_value() {
  int64_t v = kSolverChoices[0].value;
  for (const SolverChoice& c : kSolverChoices) v = std::min(v, c.value);
  return v;
}

int64_t max_solver_value() {
  int64_t v = kSolverChoices[0].value;
  for (const SolverChoice& c : kSolverChoices) v = std::max(v, c.value);
  return v;
}

const char* solver_display_name(const SolverChoice& choice) {
  return choice.is_auto ? "Auto" : solver_info(choice.kind).display_name;
}

std::string solver_hint(bool trees_only) {
  std::string hint;
  for (const SolverChoice& c : kSolverChoices) {
    if (trees_only && !c.is_auto && !solver_info(c.kind).trees) continue;
    if (!hint.empty()) hint += ",";
    hint += std::string(solver_display_name(c)) + ":" + std::to_string(c.value);
  }
  return hint;
}

}  // namespace ikchain::godot
