// Conversion of a Variant-call argument to the C++ parameter type of a bound method. Pure: the
// engine-facing part (binding/method_bind.hpp) first decodes the Variant into a ScalarVariant.
//
// Scripts reach our methods through two paths: typed GDScript uses ptrcall (arguments already in
// the declared encoding), while call()/set() pass Variants as they are. There an int arrives for a
// float parameter (`ik.tolerance = 1`, `ik.set("tolerance", 1)`): it must be converted to 1.0,
// never its bits reinterpreted. We accept what Godot's own strict conversion accepts between
// scalars (bool <-> int <-> float) and reject anything else with CALL_ERROR_INVALID_ARGUMENT.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

namespace ikchain::gdx {

// Values of Variant::Type we need (GDExtensionVariantType in gdextension_interface.h).
enum class VariantType : uint32_t { Nil = 0, Bool = 1, Int = 2, Float = 3, String = 4 };

struct ScalarVariant {
  uint32_t type = 0;  // a VariantType value; anything else is "not a scalar"
  bool b = false;
  int64_t i = 0;
  double f = 0.0;
};

inline bool scalar_to_double(const ScalarVariant& v, double& out) {
  switch (VariantType(v.type)) {
    case VariantType::Float: out = v.f; return true;
    case VariantType::Int: out = double(v.i); return true;
    case VariantType::Bool: out = v.b ? 1.0 : 0.0; return true;
    default: return false;
  }
}

// float -> int truncates toward zero like Godot; NaN becomes 0 and +-inf / out-of-range values
// saturate (a plain cast would be undefined behaviour).
inline int64_t saturating_double_to_int64(double f) {
  if (std::isnan(f)) return 0;
  if (f >= 9223372036854775807.0) return std::numeric_limits<int64_t>::max();
  if (f <= -9223372036854775808.0) return std::numeric_limits<int64_t>::min();
  return int64_t(f);
}

inline bool scalar_to_int64(const ScalarVariant& v, int64_t& out) {
  switch (VariantType(v.type)) {
    case VariantType::Int: out = v.i; return true;
    case VariantType::Float: out = saturating_double_to_int64(v.f); return true;
    case VariantType::Bool: out = v.b ? 1 : 0; return true;
    default: return false;
  }
}

inline bool scalar_to_bool(const ScalarVariant& v, bool& out) {
  switch (VariantType(v.type)) {
    case VariantType::Bool: out = v.b; return true;
    case VariantType::Int: out = v.i != 0; return true;
    case VariantType::Float: out = v.f != 0.0; return true;
    default: return false;
  }
}

}  // namespace ikchain::gdx
