// Rotation helpers in double precision: exponential/logarithm maps between rotation vectors and
// unit quaternions, the left Jacobian of SO(3), swing-twist decomposition.
// Reference: Sola, Deray, Atchuthan, "A micro Lie theory for state estimation in robotics" (2018),
// eq. (143)-(146) for the SO(3) left Jacobian.
#pragma once
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace ikchain {
namespace so3 {

constexpr double kPi = 3.14159265358979323846;

// Length of a finite vector or quaternion without overflow or underflow in the squares: a plain
// glm::length of (1e200, 0, 0) is inf, and normalising by it gives the zero vector (a tip
// rotation of 1e300 components once became the zero quaternion that way). 0, inf and NaN come
// back as the largest |component| (so isfinite() and "< tiny" tests still reject them).
template <typename V>
inline double scaled_length(const V& v) {
  double m = 0.0;
  for (int i = 0; i < V::length(); ++i) m = std::max(m, std::abs(v[i]));
  if (!(m > 0.0) || !std::isfinite(m)) return m;
  return m * glm::length(v / m);
}

// q / |q| for any finite non-zero q, however large or small its components (scaled_length);
// the identity for a zero or non-finite q. Components whose squares neither overflow nor
// underflow take glm::normalize itself (bit for bit what the per-frame paths computed before).
inline glm::dquat normalized(const glm::dquat& q) {
  const double m = std::max(std::max(std::abs(q.w), std::abs(q.x)), std::max(std::abs(q.y), std::abs(q.z)));
  if (m < 1e150 && m > 1e-150) return glm::normalize(q);
  if (!(m > 0.0) || !std::isfinite(m)) return glm::dquat(1.0, 0.0, 0.0, 0.0);
  return glm::normalize(q / m);
}

// exp: rotation vector (axis * angle, radians) -> unit quaternion.
inline glm::dquat exp(const glm::dvec3& r) {
  const double theta2 = glm::dot(r, r);
  if (theta2 < 1e-16) {
    // Second-order Taylor expansion keeps the result unit length to machine precision.
    const glm::dvec3 v = 0.5 * r;
    return glm::normalize(glm::dquat(1.0 - theta2 / 8.0, v.x, v.y, v.z));
  }
  const double theta = std::sqrt(theta2);
  const double s = std::sin(0.5 * theta) / theta;
  return glm::dquat(std::cos(0.5 * theta), s * r.x, s * r.y, s * r.z);
}

// log: unit quaternion -> rotation vector with angle in [0, pi].
inline glm::dvec3 log(glm::dquat q) {
  if (q.w < 0.0) q = -q;  // the shorter of the two equivalent rotations
  const glm::dvec3 v(q.x, q.y, q.z);
  const double s = glm::length(v);
  if (s < 1e-12) return 2.0 * v;  // small angle: sin(theta/2) ~ theta/2
  const double theta = 2.0 * std::atan2(s, q.w);
  return v * (theta / s);
}

inline glm::dmat3 skew(const glm::dvec3& v) {
  // Column-major: columns of [v]x.
  return glm::dmat3(glm::dvec3(0, v.z, -v.y), glm::dvec3(-v.z, 0, v.x), glm::dvec3(v.y, -v.x, 0));
}

// Left Jacobian J_l(r): exp(r + d) ~= exp(J_l(r) d) * exp(r) for small d.
inline glm::dmat3 left_jacobian(const glm::dvec3& r) {
  const double theta2 = glm::dot(r, r);
  const glm::dmat3 K = skew(r);
  if (theta2 < 1e-10) return glm::dmat3(1.0) + 0.5 * K + (1.0 / 6.0) * (K * K);
  const double theta = std::sqrt(theta2);
  const double a = (1.0 - std::cos(theta)) / theta2;
  const double b = (theta - std::sin(theta)) / (theta2 * theta);
  return glm::dmat3(1.0) + a * K + b * (K * K);
}

// Swing-twist decomposition q = swing * twist, twist about unit `axis` (same frame as q).
// Returns the signed twist angle in (-pi, pi]; swing is a rotation about an axis orthogonal to `axis`.
inline void swing_twist(const glm::dquat& q, const glm::dvec3& axis, glm::dquat& swing,
                        double& twist_angle) {
  const glm::dvec3 v(q.x, q.y, q.z);
  const double p = glm::dot(v, axis);
  glm::dquat twist(q.w, axis.x * p, axis.y * p, axis.z * p);
  const double n = std::sqrt(twist.w * twist.w + p * p);
  if (n < 1e-12) {
    // 180 degree swing: twist is undefined, choose none.
    twist = glm::dquat(1, 0, 0, 0);
    twist_angle = 0.0;
  } else {
    twist = twist * (1.0 / n);
    twist_angle = 2.0 * std::atan2(p / n, twist.w);
    if (twist_angle > kPi) twist_angle -= 2.0 * kPi;
    if (twist_angle <= -kPi) twist_angle += 2.0 * kPi;
  }
  swing = q * glm::conjugate(twist);
}

// Wrap a rotation vector to angle <= pi (same rotation), keeping parameters bounded.
inline glm::dvec3 wrap_rotation_vector(const glm::dvec3& r) {
  const double theta = glm::length(r);
  if (theta <= kPi) return r;
  return log(exp(r));
}

// sin and cos of x together, for FK's hinge half-angles (forward_kinematics and the Jacobian
// solvers' fused FK). libm's sincos is accurate but is a function call with a general argument
// reduction; this inline version (the fdlibm kernels __kernel_sin/__kernel_cos with a three-part
// Cody-Waite reduction by pi/2, as in fdlibm's e_rem_pio2.c) is accurate to ~1 ulp for |x| < 1e5
// and several times faster. Larger or non-finite x fall back to libm.
// Branch-free past that test: solver poses put half-angles on both sides of +-pi/4 at random, so
// a branch on the quadrant mispredicts about every other call (docs/solvers.md, "Why these
// constants").
inline void fast_sincos(double x, double& sin_x, double& cos_x) {
  if (!(std::abs(x) < 1e5)) {
    sin_x = std::sin(x);
    cos_x = std::cos(x);
    return;
  }
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kPio2_1 = 1.57079632673412561417e+00;   // first 33 bits of pi/2
  constexpr double kPio2_2 = 6.07710050630396597660e-11;   // next 33 bits
  constexpr double kPio2_3 = 2.02226624871116645580e-21;   // next 33 bits
  constexpr double kPio2_3t = 8.47842766036889956997e-32;  // pi/2 - (pio2_1 + pio2_2 + pio2_3)
  // Nearest multiple of pi/2: lrint is one instruction (cvtsd2si) under -fno-math-errno.
  const long qi = std::lrint(x * kTwoOverPi);
  const double q = static_cast<double>(qi);
  // q * pio2_1 and q * pio2_2 are exact (|q| < 2^17, 33-bit constants), so r carries ~100 bits of pi.
  const double r = ((x - q * kPio2_1) - q * kPio2_2) - (q * kPio2_3 + q * kPio2_3t);
  const double z = r * r;
  const double s = r + r * z * (-1.66666666666666324348e-01 +
                                z * (8.33333333332248946124e-03 +
                                     z * (-1.98412698298579493134e-04 +
                                          z * (2.75573137070700676789e-06 +
                                               z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
  const double c = 1.0 - 0.5 * z +
                   z * z * (4.16666666666666019037e-02 +
                            z * (-1.38888888888741095749e-03 +
                                 z * (2.48015872894767294178e-05 +
                                      z * (-2.75573143513906633035e-07 +
                                           z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  // Quadrant qi mod 4 = 0: (s, c); 1: (c, -s); 2: (-s, -c); 3: (-c, s), as combinations of s and
  // c with coefficients 0 / +-1 from a table: exact (products with 0 and +-1 and sums with 0 round
  // nothing) and branch-free.
  static constexpr double kSinS[4] = {1.0, 0.0, -1.0, 0.0};
  static constexpr double kSinC[4] = {0.0, 1.0, 0.0, -1.0};
  const int k = static_cast<int>(qi & 3);
  sin_x = kSinS[k] * s + kSinC[k] * c;
  cos_x = kSinS[k] * c - kSinC[k] * s;
}

inline bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
inline bool finite(const glm::dquat& q) {
  return std::isfinite(q.w) && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
}

}  // namespace so3
}  // namespace ikchain
