// Rotation helpers in double precision: exponential/logarithm maps between rotation vectors and
// unit quaternions, the left Jacobian of SO(3), swing-twist decomposition.
// Reference: Sola, Deray, Atchuthan, "A micro Lie theory for state estimation in robotics" (2018),
// eq. (143)-(146) for the SO(3) left Jacobian.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace ikchain {
namespace so3 {

constexpr double kPi = 3.14159265358979323846;

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

inline bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
inline bool finite(const glm::dquat& q) {
  return std::isfinite(q.w) && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
}

}  // namespace so3
}  // namespace ikchain
