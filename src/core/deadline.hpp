// The wall-clock budget of one solve (SolverOptions::time_budget_usec), checked cheaply: the
// solvers call spent() once per iteration, which reads the steady clock only when a budget is set.
#pragma once
#include <chrono>

namespace ikchain {

struct Deadline {
  // Microseconds on a monotonic clock; the steady clock unless a test installs its own (a fake
  // clock makes the budget logic testable without timing noise).
  using ClockFn = double (*)();
  ClockFn clock_us = nullptr;

  static double steady_now_us() {
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  double now_us() const { return clock_us ? clock_us() : steady_now_us(); }

  // Arms the budget (0 = none) from `start_us` (a now_us() reading); clears `hit`.
  void start(double budget_us, double start_us) {
    active = budget_us > 0.0;
    end_us = start_us + budget_us;
    hit = false;
  }
  // True once the budget is spent; then `hit` records that the solve stopped for it.
  bool spent() {
    if (!active) return false;
    if (now_us() < end_us) return false;
    hit = true;
    return true;
  }

  bool active = false;
  bool hit = false;
  double end_us = 0.0;
};

}  // namespace ikchain
