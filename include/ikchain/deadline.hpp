// The wall-clock limits of one solve, checked cheaply: SolverOptions::time_budget_usec (checked at
// every spent() call: before every iteration and inside the long inner loops) and the safety cap
// SolverOptions::time_cap_usec (alone, checked at every 8th call, so a short solve reads no clock
// for it). The solvers call spent(); nothing else reads the clock.
#pragma once
#include <algorithm>
#include <chrono>

namespace ikchain {

struct Deadline {
  // Microseconds on a monotonic clock; the steady clock unless a test installs its own (a fake
  // clock makes the budget logic testable, and fuzzable, without timing noise).
  using ClockFn = double (*)();
  ClockFn clock_us = nullptr;

  static double steady_now_us() {
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  double now_us() const { return clock_us ? clock_us() : steady_now_us(); }

  // Arms the budget and the cap (each 0 = none) from `start_us` (a now_us() reading); clears `hit`.
  void start(double budget_us, double start_us, double cap_us = 0.0) {
    const bool budget = budget_us > 0.0, cap = cap_us > 0.0;
    active = budget || cap;
    every_call = budget;
    end_us = start_us + (budget && cap ? std::min(budget_us, cap_us) : budget ? budget_us : cap_us);
    calls = 0;
    hit = false;
  }
  // True once the time is spent; then `hit` records that the solve stopped for it.
  bool spent() {
    if (hit) return true;  // spent stays spent: no more clock readings
    if (!active) return false;
    if (!every_call && (++calls & 7u) != 0u) return false;  // the cap alone: every 8th call
    if (now_us() < end_us) return false;
    hit = true;
    return true;
  }

  // Inside a loop over joints whose update per joint is heavy (CCD's and FABRIK's fits, 0.2-1.5 us
  // each): spent() before every kJointsPerCheck-th joint (`done` = joints done so far), so a sweep
  // of 200 joints cannot run 150 us past the budget (issue 16, item 6: the bound allows 20 us).
  static constexpr int kJointsPerCheck = 16;
  bool spent_after_joints(int done) { return done > 0 && done % kJointsPerCheck == 0 && spent(); }

  bool active = false;
  bool every_call = false;  // a budget is set: read the clock at every check
  bool hit = false;
  unsigned calls = 0;
  double end_us = 0.0;
};

}  // namespace ikchain
