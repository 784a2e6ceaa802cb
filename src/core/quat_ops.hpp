// Scalar quaternion arithmetic for the forward-kinematics inner loops (forward_kinematics and the
// Jacobian solvers' fused FK): plain scalar expressions take about half the instructions of the
// glm ones, and the sparse cases (coordinate-axis hinges, bones along one axis) a third of that.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace ikchain {
namespace quat_ops {

// A unit quaternion as four scalars, for FK inner loops.
struct Quat {
  double w, x, y, z;
};
inline Quat multiply(const Quat& a, const Quat& b) {
  return Quat{a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
              a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
// q v q^*, as v + w t + u x t with t = 2 u x v (u = the vector part).
inline glm::dvec3 rotate(const Quat& q, const glm::dvec3& v) {
  const double tx = 2.0 * (q.y * v.z - q.z * v.y);
  const double ty = 2.0 * (q.z * v.x - q.x * v.z);
  const double tz = 2.0 * (q.x * v.y - q.y * v.x);
  return glm::dvec3(v.x + q.w * tx + (q.y * tz - q.z * ty), v.y + q.w * ty + (q.z * tx - q.x * tz),
                    v.z + q.w * tz + (q.x * ty - q.y * tx));
}

// Sparse cases of the two operations above, for the directions rigs are built from (hinges about a
// coordinate axis, bones along one axis - Godot's along +Y): a column of q's rotation matrix, or a
// product with a rotation about a coordinate axis, costs a third of the general formula. Which
// case applies is a property of the chain, coded once by direction_code() (Chain keeps the codes):
// the FK loops switch on a byte instead of comparing three doubles per vector.
enum Direction : uint8_t { kAlongX = 0, kAlongY = 1, kAlongZ = 2, kGeneral = 3 };
inline Direction direction_code(const glm::dvec3& v) {
  if (v.x == 0.0 && v.z == 0.0) return kAlongY;  // also the zero vector
  if (v.x == 0.0 && v.y == 0.0) return kAlongZ;
  if (v.y == 0.0 && v.z == 0.0) return kAlongX;
  return kGeneral;
}

// q v q^* for v with direction code `dir`.
__attribute__((always_inline)) inline glm::dvec3 rotate_coded(const Quat& q, const glm::dvec3& v, Direction dir) {
  switch (dir) {
    case kAlongY:  // v.y * column y of R(q)
      return v.y * glm::dvec3(2.0 * (q.x * q.y - q.w * q.z), 1.0 - 2.0 * (q.x * q.x + q.z * q.z),
                              2.0 * (q.y * q.z + q.w * q.x));
    case kAlongZ:
      return v.z * glm::dvec3(2.0 * (q.x * q.z + q.w * q.y), 2.0 * (q.y * q.z - q.w * q.x),
                              1.0 - 2.0 * (q.x * q.x + q.y * q.y));
    case kAlongX:
      return v.x * glm::dvec3(1.0 - 2.0 * (q.y * q.y + q.z * q.z), 2.0 * (q.x * q.y + q.w * q.z),
                              2.0 * (q.x * q.z - q.w * q.y));
    default:
      return rotate(q, v);
  }
}
// q * (cos(t/2), sin(t/2) * axis) given c = cos(t/2), s = sin(t/2), axis a unit vector with
// direction code `dir`.
__attribute__((always_inline)) inline Quat multiply_axis_angle(const Quat& a, const glm::dvec3& axis, Direction dir,
                                                               double c, double s) {
  switch (dir) {
    case kAlongZ:
      s *= axis.z;
      return Quat{a.w * c - a.z * s, a.x * c + a.y * s, a.y * c - a.x * s, a.z * c + a.w * s};
    case kAlongY:
      s *= axis.y;
      return Quat{a.w * c - a.y * s, a.x * c - a.z * s, a.y * c + a.w * s, a.z * c + a.x * s};
    case kAlongX:
      s *= axis.x;
      return Quat{a.w * c - a.x * s, a.x * c + a.w * s, a.y * c + a.z * s, a.z * c - a.y * s};
    default:
      return multiply(a, Quat{c, s * axis.x, s * axis.y, s * axis.z});
  }
}

inline Quat from_glm(const glm::dquat& q) { return Quat{q.w, q.x, q.y, q.z}; }
inline glm::dquat to_glm(const Quat& q) { return glm::dquat(q.w, q.x, q.y, q.z); }

}  // namespace quat_ops
}  // namespace ikchain
