// The safety cap's clock (include/ikchain/deadline.hpp, src/core/deadline.cpp): the solving thread's
// CPU time, so a thread the system sets aside is not cut short for work it never did (a Godot
// test's punching body failed in CI: a frame stopped mid-solve, hands 22 mm off).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "ikchain/deadline.hpp"

namespace ikchain {
namespace {

// Calls spent() `n` times; true when one of them found the time spent.
bool spent_within(Deadline& d, int n) {
  bool spent = false;
  for (int i = 0; i < n; ++i) spent = d.spent() || spent;
  return spent;
}

// The CPU clock's step: nanoseconds on Linux; Windows' GetThreadTimes (and wine's, from /proc's
// 10 ms ticks) charges a thread whole ticks of 10-16 ms.
double cpu_clock_step_us() {
  const double t0 = Deadline::thread_cpu_now_us();
  double t1 = t0;
  while (t1 == t0) t1 = Deadline::thread_cpu_now_us();
  return t1 - t0;
}

TEST(Deadline, CapCountsTheThreadsCpuTimeNotTheWallClock) {
  // 2 ms, or four of the clock's steps where it is coarser: one tick charged to a thread that
  // happened to be running at the clock interrupt is 5-8 times a 2 ms cap (the Windows suite under
  // wine was cut after its 4th sleep once).
  const double kCapUs = std::max(2000.0, 4.0 * cpu_clock_step_us());
  Deadline d;
  d.start(0.0, 0.0, kCapUs);
  ASSERT_TRUE(d.active);
  d.charge(Deadline::kCapArmFlops);  // work enough to arm it
  EXPECT_FALSE(spent_within(d, 8));  // the 8th call arms the cap
  ASSERT_TRUE(d.cap_armed);
  // Set aside (asleep) for ten times the cap, checking all along: the wall clock passes it, the
  // thread's CPU time does not.
  for (int i = 0; i < 20; ++i) {
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int>(kCapUs / 2)));
    EXPECT_FALSE(spent_within(d, 8)) << "a sleeping thread's solve was cut after " << i + 1 << " sleeps";
  }
  // Working past the cap: the next cap check (within 8 calls) finds it spent.
  const double armed_at = d.cap_end_us - kCapUs;
  while (Deadline::thread_cpu_now_us() < armed_at + kCapUs) {
  }
  EXPECT_TRUE(spent_within(d, 8));
  EXPECT_TRUE(d.hit);
  EXPECT_TRUE(d.cap_hit);
}

// CPU time never runs ahead of the wall clock: under a budget no longer than the cap the budget
// always ends first, and the cap is not armed (no CPU-clock readings in a budget-bound solve).
TEST(Deadline, CapIsArmedOnlyWhereItCanEndFirst) {
  Deadline d;
  d.start(100.0, 0.0, 50000.0);
  EXPECT_EQ(d.cap_us, 0.0);
  EXPECT_TRUE(d.every_call);
  d.start(50000.0, 0.0, 50000.0);
  EXPECT_EQ(d.cap_us, 0.0);
  d.start(80000.0, 0.0, 50000.0);
  EXPECT_EQ(d.cap_us, 50000.0);
  d.start(0.0, 0.0, 50000.0);
  EXPECT_EQ(d.cap_us, 50000.0);
  EXPECT_FALSE(d.every_call);
  EXPECT_TRUE(d.active);
  d.start(0.0, 0.0, 0.0);
  EXPECT_FALSE(d.active);
}

// On a fake clock (one clock for both, 1 us a reading) the cap alone reads it at every 8th call
// only: armed at the 8th (once the solve has charged kCapArmFlops), spent at the first 8th-call
// reading `cap` after it.
double g_fake_us = 0.0;
double fake_clock() { return g_fake_us += 1.0; }

TEST(Deadline, CapAloneReadsTheClockEveryEighthCall) {
  g_fake_us = 0.0;
  Deadline d;
  d.clock_us = fake_clock;
  d.start(0.0, 0.0, 3.0);
  d.charge(Deadline::kCapArmFlops);
  int calls = 0;
  while (!d.spent()) ++calls;
  ++calls;
  // Readings at calls 8 (arms: 1 us, end 4 us), 16 (2 us), 24 (3 us), 32 (4 us: spent).
  EXPECT_EQ(calls, 32);
  EXPECT_EQ(g_fake_us, 4.0);
  EXPECT_TRUE(d.cap_hit);
  // With a budget longer than the cap, one reading a call serves both (a fake clock stands for
  // both clocks): the budget's end (start 0 + 100) is never reached, the cap ends the solve.
  g_fake_us = 0.0;
  d.start(100.0, 0.0, 3.0);
  d.charge(Deadline::kCapArmFlops);
  calls = 0;
  while (!d.spent()) ++calls;
  ++calls;
  // Armed at call 8 (8 us, end 11 us), checked at 16 (16 us: spent).
  EXPECT_EQ(calls, 16);
  EXPECT_EQ(g_fake_us, 16.0);
  EXPECT_TRUE(d.cap_hit);
}

// A short solve reads no clock for the cap: it arms only once the solve has charged kCapArmFlops
// of work, or at the first 8th call from kCapArmCalls on (a loop that charges nothing). A CPU-clock
// reading is a system call (~175 ns): armed at the 8th call it cost the 10-joint DLS benchmark, 14
// calls and 10k flops a solve, 0.2 of its 2.2 us.
TEST(Deadline, AShortSolveReadsNoClockForTheCap) {
  g_fake_us = 0.0;
  Deadline d;
  d.clock_us = fake_clock;
  d.start(0.0, 0.0, 50000.0);
  for (int i = 1; i < 8 * 4; ++i) {
    d.charge(1000.0);  // 31k flops in all: short
    EXPECT_FALSE(d.spent());
  }
  EXPECT_EQ(g_fake_us, 0.0) << "a short solve read the clock";
  EXPECT_FALSE(d.cap_armed);
  d.charge(Deadline::kCapArmFlops);  // now a long one: the next 8th call (the 32nd) arms the cap
  EXPECT_FALSE(d.spent());
  EXPECT_TRUE(d.cap_armed);
  EXPECT_EQ(g_fake_us, 1.0);
  // Without charges the 64th call arms it.
  g_fake_us = 0.0;
  d.start(0.0, 0.0, 50000.0);
  EXPECT_FALSE(spent_within(d, static_cast<int>(Deadline::kCapArmCalls) - 1));
  EXPECT_FALSE(d.cap_armed);
  EXPECT_FALSE(d.spent());
  EXPECT_TRUE(d.cap_armed);
  EXPECT_EQ(g_fake_us, 1.0);
}

}  // namespace
}  // namespace ikchain
