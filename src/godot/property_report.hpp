// Errors for out-of-range property values set from scripts (the editor's range hints already
// prevent them there): the value is clamped to the nearest valid one and the error names the
// class, the property, the range and the value used.
#pragma once

#include <cstdio>

#include "binding/log.hpp"

namespace ikchain::godot {

inline void report_clamped(const char* class_name, const char* property, const char* range, double given,
                           double used) {
  char message[256];
  std::snprintf(message, sizeof(message), "%s: %s must be in %s, got %g; using %g.", class_name, property, range,
                given, used);
  IKCHAIN_PRINT_ERROR(message);
}

}  // namespace ikchain::godot
