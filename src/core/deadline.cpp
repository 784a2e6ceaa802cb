// The safety cap's clock (include/ikchain/deadline.hpp): the calling thread's CPU time.
#include "ikchain/deadline.hpp"

#if defined(_WIN32)
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#else
#include <time.h>
#endif

namespace ikchain {

double Deadline::thread_cpu_now_us() {
#if defined(_WIN32)
  FILETIME created, exited, kernel, user;
  if (GetThreadTimes(GetCurrentThread(), &created, &exited, &kernel, &user)) {
    const auto ticks = [](const FILETIME& t) {  // 100 ns units
      return static_cast<double>((static_cast<unsigned long long>(t.dwHighDateTime) << 32) | t.dwLowDateTime);
    };
    return (ticks(kernel) + ticks(user)) * 0.1;
  }
#elif defined(CLOCK_THREAD_CPUTIME_ID)
  timespec t;
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) == 0) return static_cast<double>(t.tv_sec) * 1e6 + t.tv_nsec * 1e-3;
#endif
  return steady_now_us();  // no thread CPU clock here: the wall clock, as before
}

}  // namespace ikchain
