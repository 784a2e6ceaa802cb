// Small helpers the IKChain and IKBody nodes share (kept here so the two nodes do not each carry
// a copy): Godot text from std::string, finiteness of a transform, the result's reason names.
#pragma once

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <string_view>

#include "binding/builtins.hpp"
#include "binding/math.hpp"
#include "ikchain/result.hpp"

namespace ikchain::godot {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The Object held by element i of an Array (null when it holds none): the nodes' resource arrays.
inline gdx::ObjectPtr object_at(const gdx::Array& array, int64_t i) {
  gdx::ObjectPtr object = nullptr;
  gdx::variant_to(array.at(i), object);
  return object;
}

inline gdx::String text(const std::string& s) { return gdx::String(std::string_view(s)); }

inline bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 3; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}
inline bool finite(const gdx::Transform3D& t) { return finite(gdx::to_glm(t)); }

// The names get_last_result()["reason"] uses (scripts compare against them).
inline const char* reason_name(TerminationReason r) {
  switch (r) {
    case TerminationReason::kConverged: return "converged";
    case TerminationReason::kMaxIterations: return "max_iterations";
    case TerminationReason::kStalled: return "stalled";
    case TerminationReason::kUnreachable: return "unreachable";
    case TerminationReason::kInvalidInput: return "invalid_input";
  }
  return "invalid_input";
}

// IKBody's name of an element of `effectors` in its messages: "effectors[2] ('LeftHand')".
inline std::string effector_label(int index, const std::string& bone) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "effectors[%d]%s%s%s", index, bone.empty() ? "" : " ('", bone.c_str(),
                bone.empty() ? "" : "')");
  return buf;
}

}  // namespace ikchain::godot
