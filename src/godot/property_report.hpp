// Errors for out-of-range property values set from scripts (the editor's range hints already
// prevent them there): the value is clamped to the nearest valid one and the error names the
// class, the property, the range and the value used.
#pragma once

#include <algorithm>
#include <cmath>
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

// A vector property that must be a finite, non-zero direction (it is stored normalised). Returns
// false, after an error naming the property, the value and the fix, when `given` is not one: the
// caller keeps its previous value.
inline bool direction_or_report(const char* class_name, const char* property, const char* fix, double x, double y,
                                double z, double& ux, double& uy, double& uz) {
  const double scale = std::max({std::abs(x), std::abs(y), std::abs(z)});  // NaN compares false
  if (std::isfinite(x) && std::isfinite(y) && std::isfinite(z) && scale > 1e-12) {
    // Scaled first, so a huge finite vector does not overflow the length.
    const double sx = x / scale, sy = y / scale, sz = z / scale;
    const double length = std::sqrt(sx * sx + sy * sy + sz * sz);
    ux = sx / length;
    uy = sy / length;
    uz = sz / length;
    return true;
  }
  char message[320];
  std::snprintf(message, sizeof(message), "%s: %s must be a finite, non-zero vector, got (%g, %g, %g); keeping the "
                "previous value. %s", class_name, property, x, y, z, fix);
  IKCHAIN_PRINT_ERROR(message);
  return false;
}

}  // namespace ikchain::godot
