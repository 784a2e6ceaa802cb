// The time limits of one solve, checked cheaply: SolverOptions::time_budget_usec, wall-clock time
// (checked at every spent() call: before every iteration and inside the long inner loops), and the
// safety cap SolverOptions::time_cap_usec, the solving thread's CPU time (checked at every 8th call
// once armed). The cap is a net for runaway work: on the wall clock, a thread the system set aside
// for 50 ms (a loaded machine) had its solve cut short, a visible pop for work it never did (a Godot
// test's punching body, in CI). It counts from its first check, which arms it: the first 8th call
// once the solve has charged kCapArmFlops of work or made kCapArmCalls calls. A CPU-clock reading
// is a system call, ~175 ns: armed at the 8th call, it cost a 10-joint DLS solve (14 calls, 10k
// flops) a tenth of its 2 us; a solve that short now reads no clock. With a budget no longer than
// the cap it is not armed at all (CPU time never runs ahead of the wall clock). The solvers call
// spent(); nothing else reads the clocks.
//
// Work per clock reading (issue 16, item 6): the bound "1.1 x budget + 20 us" holds only if no
// stretch of work between two readings is long. Timing that is noisy, so the kernels that dominate
// a solve charge() their work, in approximate flops (one multiply-add each), and every reading
// closes the stretch since the one before (the first from start(), the last, the exit work after
// the deadline, at finish()). longest_stretch is deterministic: tests and the fuzzer compare it with
// stretch_bound() of the problem's size.
//
// Stopping before a stretch that would overrun (issue 16, item 6): some stretches cannot be split
// finely (a tree DLS step on 200+ DOF, ~70 us; a BFGS line-search trial on 600 DOF, ~95 us), and the
// exit work after the last reading (final FK, summary, the best pose put back) is as long as a few
// FK passes. So every budget reading also measures the time since the reading before (the gap),
// and the budget counts as spent from the reading after which the next stretch, then the exit work,
// would end past the bound the issue sets, kBoundRatio x budget + kBoundSlackUs. The exit work counts
// as the longest gap of the solve so far; the next stretch as that too, but never less than
// stretch_ratio set-up gaps (the gap from start() to the first budget reading): the set-up (the start
// pose's FK and measure) is the one stretch every solve has measured at its first reading, and an
// iteration's longest stretch outgrows it by a ratio that depends on the solver (a DLS step is
// 2.6 set-ups at the median and 5.5 at the 90th percentile on 100-600 DOF; a FABRIK sweep's stretch
// 1.4 and 2.5): solve() sets it from one table (stretch_ratio_of in solve.cpp). The trees set
// none: their first reading takes kFirstStretchRatio, the later ones the longest gap. Without the
// floor, stretches that grow within a first iteration (DLS's step after its linearisation, CCD's
// fits toward the root, where more goals lie beyond the joint) ran past the bound on small budgets
// (docs/benchmarks.md, h21budget: 10-17 of 16-25 solves over it stopped after one iteration; with
// it 1-2 of 4-8, in runs of 120 s; the fuzzer's ten minutes found nothing). On a clock whose gaps are
// short against the slack (the fake-clock tests' ticks of 1 us) this never comes before the
// budget's own end; `foreseen` says when it did.
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
  // The calling thread's CPU time (microseconds; the steady clock where the platform has none).
  static double thread_cpu_now_us();

  // Arms the budget (from `start_us`, a now_us() reading) and the cap (from its first check), each
  // 0 = none; clears `hit`. `ratio`: the longest stretch the set-up predicts, in set-up gaps
  // (stretch_ratio; 0: none).
  void start(double budget_us, double start_us, double cap_limit_us = 0.0, double ratio = 0.0) {
    const bool budget = budget_us > 0.0;
    cap_us = cap_limit_us > 0.0 && !(budget && budget_us <= cap_limit_us) ? cap_limit_us : 0.0;
    active = budget || cap_us > 0.0;
    every_call = budget;
    end_us = budget ? start_us + budget_us : 0.0;
    cap_armed = cap_hit = false;
    cap_start_us = cap_end_us = 0.0;
    calls = 0;
    hit = false;
    foreseen = false;
    stretch = longest_stretch = exit_stretch = work = 0.0;
    last_reading_us = start_us;
    longest_gap_us = setup_gap_us = 0.0;
    budget_readings = 0;
    stretch_ratio = ratio;
    bound_end_us = start_us + kBoundRatio * budget_us + kBoundSlackUs;
  }
  // True once the time is spent; then `hit` records that the solve stopped for it.
  bool spent() {
    if (hit) return true;  // spent stays spent: no more clock readings
    if (!active) return false;
    // The cap: every 8th call, once armed or due to arm (see the top).
    const bool cap_due = cap_us > 0.0 && (++calls & 7u) == 0u &&
                         (cap_armed || calls >= kCapArmCalls || work >= kCapArmFlops);
    if (!every_call) {
      if (!cap_due) return false;
      close_stretch();
      return cap_spent(cpu_now_us());
    }
    close_stretch();
    const double now = now_us();
    if (now >= end_us) return hit = true;
    // (A fake clock stands for both clocks: one reading a check.)
    if (cap_due && cap_spent(clock_us ? now : thread_cpu_now_us())) return true;
    // The budget: the next stretch and the exit work must end within the bound (see the top).
    const double gap = now - last_reading_us;
    const bool first = ++budget_readings == 1;
    longest_gap_us = std::max(longest_gap_us, gap);
    last_reading_us = now;
    // The first reading has seen only the set-up (the start pose's FK and measure, a solver's first
    // linearisation): the solve's longest stretch is stretch_ratio of it until one longer is seen.
    // (At the first reading the longest gap is this one's: the dispatcher's look measured a part of it.)
    // Without a ratio of its own (the trees) the set-up predicts only the first stretch.
    if (first) setup_gap_us = gap;
    const double ratio = stretch_ratio > 0.0 ? stretch_ratio : first ? kFirstStretchRatio : 0.0;
    const double ahead = std::max(longest_gap_us, ratio * setup_gap_us) + longest_gap_us;
    if (now + ahead + kReserveUs <= bound_end_us) return false;
    foreseen = true;
    return hit = true;
  }

  // The dispatcher's reading between its set-up (validation, the start pose's projection, FK and
  // measure) and the solver's (issue 16, item 6): on a long chain with a small budget the set-up
  // alone can use the budget, and a solver's own set-up (BFGS evaluates the start again with its
  // gradient) then ends past the bound before the solver's first reading. True when the budget is
  // spent, or when the set-up so far, (kFirstStretchRatio + 1) times again (the solver's set-up and
  // first stretch, then the exit work), would end past the bound. A look: the solver's first reading
  // still measures its gap from start(), the whole set-up, and applies the set-up rule to it (with
  // the gap from this look it underestimated a first iteration: 1-iteration solves ran over; the
  // charged work's stretch closes here, as at any reading). Without a budget (the cap alone) it
  // reads no clock.
  bool spent_before_solver() {
    if (hit) return true;
    if (!active || !every_call) return false;
    close_stretch();
    const double now = now_us();
    if (now >= end_us) return hit = true;
    const double gap = now - last_reading_us;  // since start(): last_reading_us stays there
    longest_gap_us = std::max(longest_gap_us, gap);
    if (now + (kFirstStretchRatio + 1.0) * gap + kReserveUs <= bound_end_us) return false;
    // Found spent here: this is the solve's last reading (a look that passes leaves it at start()).
    last_reading_us = now;
    foreseen = true;
    return hit = true;
  }

  // Inside a loop over joints whose update per joint is heavy (CCD's and FABRIK's fits, 0.2-1.5 us
  // each): spent() before every kJointsPerCheck-th joint (`done` = joints done so far), so a sweep
  // of 200 joints cannot run 150 us past the budget (issue 16, item 6: the bound allows 20 us).
  static constexpr int kJointsPerCheck = 16;
  bool spent_after_joints(int done) { return done > 0 && done % kJointsPerCheck == 0 && spent(); }

  // Work accounting (see the top): what a kernel adds, and the end of the solve's last stretch.
  void charge(double flops) {
    stretch += flops;
    work += flops;
  }
  void finish() {
    exit_stretch = stretch;
    close_stretch();
  }
  // The approximate flops the charges use: one joint of an FK (or of a DOF-axis) pass, one entry of
  // a Jacobian, one joint's geometric fit (CCD, FABRIK).
  static constexpr double kFlopsPerJoint = 60.0, kFlopsPerJacobianEntry = 8.0, kFlopsPerFit = 400.0;
  // The most work one stretch may do on a problem of `joints` joints, `dofs` DOFs and `rows`
  // residual rows: a fixed allowance (kStretchFlops, ~ the 20 us the bound allows) and
  // kStretchPasses linear passes (an FK and a Jacobian each): the exit work's FK passes fit, a
  // superlinear kernel (a Gram product per freeze pass, an eigen-decomposition, an O(n^2)
  // quasi-Newton pass) does not unless clock readings split it.
  static constexpr double kStretchFlops = 40000.0, kStretchPasses = 6.0;
  static double stretch_bound(int joints, int dofs, int rows) {
    return kStretchFlops +
           kStretchPasses * (kFlopsPerJoint * joints + kFlopsPerJacobianEntry * static_cast<double>(dofs) * rows);
  }

  // The bound on a budget-bound solve's time (issue 16, item 6), and what a stop keeps in reserve
  // beyond the predicted stretches (the clock reading's own cost and rounding).
  static constexpr double kBoundRatio = 1.1, kBoundSlackUs = 20.0, kReserveUs = 1.0;
  // The set-up's prediction of the first stretch, in set-up gaps, where solve() gives no ratio (the
  // trees' first reading; the dispatcher's look before the solver's set-up).
  static constexpr double kFirstStretchRatio = 3.0;
  // The cap arms at the first 8th call after this much charged work (~25-50 us) or this many
  // calls (a loop that charges nothing): a 50 ms net lets a solve run that long unwatched.
  static constexpr double kCapArmFlops = 100000.0;
  static constexpr unsigned kCapArmCalls = 64;

  bool active = false;
  bool every_call = false;  // a budget is set: read the clock at every check
  double cap_us = 0.0;      // the armed cap (CPU us; 0: none)
  bool cap_armed = false;   // its first check has read the CPU clock: cap_end_us is set
  bool cap_hit = false;     // the cap, not the budget, found the time spent
  double cap_start_us = 0.0;  // the CPU time (or the fake clock's) of the reading that armed the cap
  double cap_end_us = 0.0;    // ... and at which it is spent
  bool hit = false;
  unsigned calls = 0;
  double end_us = 0.0;  // the budget's end on the wall clock (or the fake clock's; 0: no budget)
  double stretch = 0.0;          // flops charged since the last clock reading
  double work = 0.0;             // flops charged since start() (when the cap arms)
  double longest_stretch = 0.0;  // the most flops between two readings since start()
  double exit_stretch = 0.0;     // the flops after the last reading (the exit work), set by finish()
  bool foreseen = false;         // hit before end_us: the next stretch would have ended past bound_end_us
  double bound_end_us = 0.0;     // start + kBoundRatio x budget + kBoundSlackUs
  double last_reading_us = 0.0, longest_gap_us = 0.0;  // budget readings: the last, the longest gap between two
  double setup_gap_us = 0.0;  // from start() to the first budget reading
  double stretch_ratio = 0.0;  // the longest stretch predicted, in set-up gaps (start(); 0: none)
  unsigned budget_readings = 0;

 private:
  double cpu_now_us() const { return clock_us ? clock_us() : thread_cpu_now_us(); }
  // The cap's check at `cpu_us`: the first arms it, the later ones compare.
  bool cap_spent(double cpu_us) {
    if (!cap_armed) {
      cap_armed = true;
      cap_start_us = cpu_us;
      cap_end_us = cpu_us + cap_us;
      return false;
    }
    if (cpu_us < cap_end_us) return false;
    cap_hit = true;
    return hit = true;
  }
  void close_stretch() {
    longest_stretch = std::max(longest_stretch, stretch);
    stretch = 0.0;
  }
};

}  // namespace ikchain
