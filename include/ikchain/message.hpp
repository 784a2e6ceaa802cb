// A fixed-capacity error message: validation and build errors name the bad field and value
// ("tolerance must be > 0, got -1") without allocating.
#pragma once
#include <cstdarg>
#include <cstdio>

namespace ikchain {

struct Message {
  char text[192] = {0};

  bool empty() const { return text[0] == '\0'; }
  const char* c_str() const { return text; }

  static Message format(const char* fmt, ...) __attribute__((format(printf, 1, 2))) {
    Message m;
    va_list args;
    va_start(args, fmt);
    std::vsnprintf(m.text, sizeof(m.text), fmt, args);
    va_end(args);
    return m;
  }
};

}  // namespace ikchain
