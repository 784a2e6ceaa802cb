#include "ikchain/options.hpp"

#include <cmath>

#include "ikchain/chain.hpp"

namespace ikchain {

const char* to_string(SolverKind kind) {
  switch (kind) {
    case SolverKind::kTwoBone: return "two_bone";
    case SolverKind::kCCD: return "ccd";
    case SolverKind::kJacobianPinv: return "jacobian_pinv";
    case SolverKind::kDLS: return "dls";
    case SolverKind::kBFGS: return "bfgs";
    case SolverKind::kFABRIK: return "fabrik";
  }
  return "unknown";
}

Message SolverOptions::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (max_iterations <= 0) return Message::format("max_iterations must be > 0, got %d", max_iterations);
  if (!positive(position_tolerance))
    return Message::format("position_tolerance must be > 0, got %g", position_tolerance);
  if (!positive(orientation_tolerance))
    return Message::format("orientation_tolerance must be > 0, got %g", orientation_tolerance);
  if (!(std::isfinite(stall_tolerance) && stall_tolerance >= 0.0))
    return Message::format("stall_tolerance must be >= 0, got %g", stall_tolerance);
  if (!(std::isfinite(max_step_angle) && max_step_angle >= 0.0))
    return Message::format("max_step_angle must be >= 0 (0 = no cap), got %g", max_step_angle);
  if (!(positive(pinv_residual_tolerance) && pinv_residual_tolerance <= 1.0))
    return Message::format("pinv_residual_tolerance must be in (0, 1], got %g", pinv_residual_tolerance);
  if (pinv_max_halvings < 0 || pinv_max_halvings > kMaxPinvHalvings)
    return Message::format("pinv_max_halvings must be in [0, %d], got %d", kMaxPinvHalvings, pinv_max_halvings);
  if (!positive(pinv_singular_threshold))
    return Message::format("pinv_singular_threshold must be > 0, got %g", pinv_singular_threshold);
  if (!positive(dls_min_damping))
    return Message::format("dls_min_damping must be > 0, got %g", dls_min_damping);
  if (!(positive(dls_max_damping) && dls_max_damping >= dls_min_damping))
    return Message::format("dls_max_damping must be >= dls_min_damping (%g), got %g",
                           dls_min_damping, dls_max_damping);
  if (!(std::isfinite(dls_initial_damping) && dls_initial_damping >= 0.0))
    return Message::format("dls_initial_damping must be >= 0, got %g", dls_initial_damping);
  if (!(bfgs_wolfe_c1 > 0.0 && bfgs_wolfe_c1 < bfgs_wolfe_c2 && bfgs_wolfe_c2 < 1.0))
    return Message::format("bfgs_wolfe_c1/c2 must satisfy 0 < c1 < c2 < 1, got c1=%g c2=%g",
                           bfgs_wolfe_c1, bfgs_wolfe_c2);
  if (bfgs_max_line_search_steps <= 0 || bfgs_max_line_search_steps > kMaxBfgsLineSearchSteps)
    return Message::format("bfgs_max_line_search_steps must be in [1, %d], got %d", kMaxBfgsLineSearchSteps,
                           bfgs_max_line_search_steps);
  if (max_restarts < 0) return Message::format("max_restarts must be >= 0 (0 = none), got %d", max_restarts);
  if (!(std::isfinite(time_budget_usec) && time_budget_usec >= 0.0))
    return Message::format("time_budget_usec must be >= 0 (0 = no budget), got %g", time_budget_usec);
  if (!(std::isfinite(time_cap_usec) && time_cap_usec >= 0.0))
    return Message::format("time_cap_usec must be >= 0 (0 = no cap), got %g", time_cap_usec);
  auto coordinate = [](double v) { return std::abs(v) <= kMaxMagnitude; };  // false for NaN
  if (!(coordinate(soft_reach) && soft_reach >= 0.0))
    return Message::format("soft_reach must be >= 0 m (0 = off) and at most %g, got %g", kMaxMagnitude, soft_reach);
  if (use_pole && !(coordinate(pole_in_base.x) && coordinate(pole_in_base.y) && coordinate(pole_in_base.z)))
    return Message::format("pole_in_base (%g, %g, %g) must be finite, each component within +-%g m when use_pole is set",
                           pole_in_base.x, pole_in_base.y, pole_in_base.z, kMaxMagnitude);
  return Message();
}

}  // namespace ikchain
