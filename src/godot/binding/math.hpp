// Godot's math builtins as plain layouts (real_t as the engine was built) and their
// conversions to the core's double-precision GLM types. Pure: no engine needed, unit-tested in
// tests/binding/math_test.cpp.
//
// Layout notes (Godot core/math): Vector3 {x,y,z}; Quaternion {x,y,z,w}; Basis is ROW-major,
// `Vector3 rows[3]`, rows[i][j] = element (row i, column j); Transform3D {Basis basis; Vector3 origin}.
// GLM is column-major: m[c][r]. Conversions below index element by element, never memcpy.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <type_traits>

#include "engine_api.gen.hpp"

namespace ikchain::gdx {

// The engine's build configuration decides (extension_api.json's "precision"), not this file.
using real_t = std::conditional_t<gen::kRealIsDouble, double, float>;

struct Vector3 {
  real_t x = 0, y = 0, z = 0;
};

struct Quaternion {
  real_t x = 0, y = 0, z = 0, w = 1;
};

struct Basis {
  Vector3 rows[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
};

struct Transform3D {
  Basis basis;
  Vector3 origin;
};

static_assert(std::is_standard_layout_v<Vector3> && std::is_trivially_copyable_v<Vector3>);
static_assert(std::is_standard_layout_v<Transform3D> && std::is_trivially_copyable_v<Transform3D>);

inline real_t component(const Vector3& v, int i) { return i == 0 ? v.x : (i == 1 ? v.y : v.z); }

// real_t (float) <-> double happens here and only here: the core computes in double.
inline glm::dvec3 to_glm(const Vector3& v) {
  return glm::dvec3(double(v.x), double(v.y), double(v.z));
}
inline Vector3 from_glm(const glm::dvec3& v) {
  return Vector3{real_t(v.x), real_t(v.y), real_t(v.z)};
}

// glm::dquat's constructor takes (w, x, y, z); its memory order is not Godot's (x, y, z, w).
inline glm::dquat to_glm(const Quaternion& q) {
  return glm::dquat(double(q.w), double(q.x), double(q.y), double(q.z));
}
inline Quaternion from_glm(const glm::dquat& q) {
  return Quaternion{real_t(q.x), real_t(q.y), real_t(q.z), real_t(q.w)};
}

// Godot rows[r][c] == GLM m[c][r].
inline glm::dmat3 to_glm(const Basis& b) {
  glm::dmat3 m(1.0);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m[c][r] = double(component(b.rows[r], c));
  return m;
}
inline Basis from_glm(const glm::dmat3& m) {
  Basis b;
  for (int r = 0; r < 3; ++r)
    b.rows[r] = Vector3{real_t(m[0][r]), real_t(m[1][r]), real_t(m[2][r])};
  return b;
}

// Affine 4x4 (column-major, last row 0 0 0 1): columns 0..2 are the basis columns, column 3 the origin.
inline glm::dmat4 to_glm(const Transform3D& t) {
  glm::dmat4 m(to_glm(t.basis));
  m[3] = glm::dvec4(to_glm(t.origin), 1.0);
  return m;
}
inline Transform3D from_glm(const glm::dmat4& m) {
  Transform3D t;
  t.basis = from_glm(glm::dmat3(m));
  t.origin = from_glm(glm::dvec3(m[3]));
  return t;
}

inline bool is_finite(const glm::dquat& q) {
  return std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) && std::isfinite(q.w);
}
inline bool is_finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace ikchain::gdx
