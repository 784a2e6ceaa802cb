// Helpers shared by the geometric solvers (two-bone, CCD, FABRIK): minimal rotations between
// directions, turning one joint by a base-frame rotation, per-joint limit projection, the
// root-to-tip "aim each bone at a point" pass, and the per-iteration bookkeeping (Progress: the
// shared stall rule and escape of stuck.hpp, the best pose). Header-only, internal to
// src/core/solvers/ (not part of the public API).
//
// Every function here works on one joint at a time because the geometric solvers update joints one
// by one (CCD tip-to-root, FABRIK root-to-tip) and must apply the limits of each joint right after
// its update (Kenwright 2012, "Inverse kinematics - cyclic coordinate descent", sec. 4; Aristidou &
// Lasenby 2011, "FABRIK", sec. 4.2: constraints are enforced per joint while iterating).
#pragma once
#include <algorithm>
#include <cmath>

#include "ikchain/chain.hpp"
#include "core/kinematics_internal.hpp"
#include "ikchain/result.hpp"
#include "ikchain/goal.hpp"
#include "core/math/linalg.hpp"
#include "ikchain/so3.hpp"
#include "core/solvers/stuck.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain {
namespace geometric {

inline const glm::dquat kIdentity(1.0, 0.0, 0.0, 0.0);

// A unit vector perpendicular to `v` (any length > 0), chosen stably: crosses `v` with the
// coordinate axis it is least aligned with.
inline glm::dvec3 any_perpendicular(const glm::dvec3& v) {
  const glm::dvec3 a = glm::abs(v);
  const glm::dvec3 other = (a.x <= a.y && a.x <= a.z) ? glm::dvec3(1, 0, 0)
                           : (a.y <= a.z)             ? glm::dvec3(0, 1, 0)
                                                      : glm::dvec3(0, 0, 1);
  return glm::normalize(glm::cross(v, other));
}

// Normalised component of `v` perpendicular to the unit vector `axis`; false when it is shorter
// than `min_length` (then `out` is untouched).
inline bool perpendicular_part(const glm::dvec3& v, const glm::dvec3& axis, double min_length,
                               glm::dvec3& out) {
  const glm::dvec3 p = v - axis * glm::dot(v, axis);
  const double len = glm::length(p);
  if (!(len > min_length)) return false;
  out = p / len;
  return true;
}

// The minimal rotation taking the direction of `a` onto the direction of `b` (lengths ignored).
// A zero vector gives the identity; opposite directions turn by pi about a stable perpendicular.
// atan2 of (|a x b|, a.b) keeps the angle accurate at both ends of [0, pi].
inline glm::dquat rotation_between(const glm::dvec3& a, const glm::dvec3& b) {
  const double la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0) || !(lb > 0.0)) return kIdentity;
  const glm::dvec3 u = a / la, v = b / lb;
  const glm::dvec3 c = glm::cross(u, v);
  const double s = glm::length(c);
  const double d = glm::dot(u, v);
  if (s < 1e-15) return d > 0.0 ? kIdentity : glm::angleAxis(so3::kPi, any_perpendicular(u));
  return glm::angleAxis(std::atan2(s, d), c / s);
}

// Least-squares hinge fit: the angle about the unit `axis` maximising sum_i w_i b_i . R(theta) a_i
// (the rotation best turning the vectors a_i onto b_i, Wang & Chen 1991 eq. for a revolute joint):
// theta = atan2(sum w axis.(a x b), sum w (a.b - (a.axis)(b.axis))). When every pair lies (to
// rounding) along the axis the hinge cannot help and the angle is 0 - not atan2 of rounding noise.
struct HingeFit {
  double s = 0.0, c = 0.0, scale = 0.0;
  void add(const glm::dvec3& axis, const glm::dvec3& a, const glm::dvec3& b, double w) {
    s += w * glm::dot(axis, glm::cross(a, b));
    c += w * (glm::dot(a, b) - glm::dot(a, axis) * glm::dot(b, axis));
    scale += w * glm::length(a) * glm::length(b);
  }
  double angle() const { return std::hypot(s, c) > 1e-12 * scale ? std::atan2(s, c) : 0.0; }
};

inline double wrap_angle(double a) {
  a = std::remainder(a, 2.0 * so3::kPi);  // [-pi, pi]
  return a;
}

inline glm::dvec3 ball_param(const double* params, int o) {
  return glm::dvec3(params[o], params[o + 1], params[o + 2]);
}
inline void set_ball_param(double* params, int o, const glm::dvec3& r) {
  params[o] = r.x;
  params[o + 1] = r.y;
  params[o + 2] = r.z;
}

// Base-frame axis of hinge j given the frame its motion happens in (pre_j = Q_{j-1} * rest_rotation_j).
inline glm::dvec3 hinge_axis_in_base(const Chain& chain, int j, const glm::dquat& pre_j) {
  return pre_j * chain.axis(j);
}

// Turns a ball joint by the base-frame rotation `delta` (about the joint's origin): Q_j <- delta * Q_j,
// i.e. R_j <- conj(pre_j) * delta * pre_j * R_j. The angle is capped at max_step_angle (0 = none)
// and the joint projected onto its limits. `p`: the joint's own 3 params (chains and trees share
// this, as they share project_joint_params). Returns the base-frame rotation actually applied.
inline glm::dquat turn_ball_params(const JointLimits& limits, const glm::dquat& pre_j, glm::dquat delta,
                                   double max_step_angle, double* p) {
  if (max_step_angle > 0.0) {
    glm::dvec3 r = so3::log(delta);
    const double angle = glm::length(r);
    if (angle > max_step_angle) delta = so3::exp(r * (max_step_angle / angle));
  }
  const glm::dquat old_local = so3::exp(ball_param(p, 0));
  const glm::dquat new_local =
      glm::normalize(glm::conjugate(pre_j) * delta * pre_j * old_local);
  set_ball_param(p, 0, so3::log(new_local));
  project_joint_params(JointType::kBall, limits, p);
  const glm::dquat applied_local = so3::exp(ball_param(p, 0)) * glm::conjugate(old_local);
  return glm::normalize(pre_j * applied_local * glm::conjugate(pre_j));
}
inline glm::dquat turn_ball(const Chain& chain, int j, const glm::dquat& pre_j, glm::dquat delta,
                            double max_step_angle, double* params) {
  return turn_ball_params(chain.limits(j), pre_j, delta, max_step_angle, params + chain.dof_offset(j));
}

// Turns a hinge by `angle` (rad) about its axis; same capping and projection as turn_ball. Returns
// the angle actually applied. An unlimited hinge's angle is kept in [-pi, pi]. `p`: its param.
inline double turn_hinge_param(const JointLimits& limits, double angle, double max_step_angle, double* p) {
  if (max_step_angle > 0.0) angle = std::clamp(angle, -max_step_angle, max_step_angle);
  const double old = p[0];
  if (limits.has_hinge_limit) {
    p[0] = old + angle;
    project_joint_params(JointType::kHinge, limits, p);
  } else {
    p[0] = wrap_angle(old + angle);
  }
  return wrap_angle(p[0] - old);
}
inline double turn_hinge(const Chain& chain, int j, double angle, double max_step_angle, double* params) {
  return turn_hinge_param(chain.limits(j), angle, max_step_angle, params + chain.dof_offset(j));
}

// The hinge's triangle step of CCD (ccd.cpp's file comment; tree_ccd.cpp): a hinge right after a
// ball joint without limits, one position goal after it. triangle_turn() applies when the hinge can
// change the ball-to-effector distance by more than this share of |o_j - o_{j-1}| |effector - o_j|
// (r / (|u| |v|) below: the product of the sines of the angles the bone before the hinge and the
// effector make with its axis): a hinge twisting about the bone before it is left to the classic fit.
constexpr double kTriangleMinShare = 1e-3;
// ... and when some angle within the limits makes that distance to this share of what the hinge can
// change it by (2 r below; rounding only).
constexpr double kTriangleMaxMiss = 1e-9;

// The hinge angle that puts the effector at the target's distance from the ball's origin h (the
// law of cosines, as two_bone.cpp and the triangulation of Mueller-Cajar & Mukundan, IVCNZ 2007):
// with the effector f, the hinge's origin o and unit axis k (base frame), v = f - o split into
// v_par (along k) and v_perp, w = k x v_perp and u = o - h, turning the hinge by t gives
// |f(t) - h|^2 = |u + v_par|^2 + |v_perp|^2 + 2 (A cos t + B sin t), A = u.v_perp, B = u.w, so
// A cos t + B sin t = C with C = (|target - h|^2 - |u + v_par|^2 - |v_perp|^2) / 2:
// t = atan2(B, A) +- acos(C / hypot(A, B)) (clamped: the nearest distance the hinge can make).
// Of the two solutions, and the bounds, the one within the limits whose distance is nearest the
// target's, then the smaller turn. `q0`: the hinge's param now. Writes the turn into `turn` (rad,
// not yet applied); false when the hinge barely changes that distance, or no angle within the
// limits makes it (the ball's origin must move first, which the classic fit leaves room for: set
// straight or fully folded here, a limb on its bound would ask for the stuck escape every sweep).
inline bool triangle_turn(const glm::dvec3& h, const glm::dvec3& o, const glm::dvec3& k, const glm::dvec3& effector,
                          const glm::dvec3& target, const JointLimits& l, double q0, double& turn) {
  turn = 0.0;
  const glm::dvec3 v = effector - o;
  const glm::dvec3 v_par = k * glm::dot(k, v), v_perp = v - v_par, w = glm::cross(k, v_perp), u = o - h;
  const double a = glm::dot(u, v_perp), b = glm::dot(u, w), r = std::hypot(a, b);
  // The hinge changes the distance by at most 2 r; below this share of |u| |v| it cannot steer it.
  if (!(r > kTriangleMinShare * glm::length(u) * glm::length(v))) return false;
  const glm::dvec3 to_target = target - h;
  const double c =
      0.5 * (glm::dot(to_target, to_target) - glm::dot(u + v_par, u + v_par) - glm::dot(v_perp, v_perp));
  const double phi = std::atan2(b, a), alpha = std::acos(std::clamp(c / r, -1.0, 1.0));
  // The angle actually reached by a turn of t (the limits applied as turn_hinge applies them).
  auto reached = [&](double t) { return l.has_hinge_limit ? std::clamp(q0 + t, l.hinge_min, l.hinge_max) - q0 : t; };
  const double candidates[4] = {wrap_angle(phi + alpha), wrap_angle(phi - alpha), l.hinge_min - q0, l.hinge_max - q0};
  const int count = l.has_hinge_limit ? 4 : 2;
  double best_miss = INFINITY;
  for (int i = 0; i < count; ++i) {
    const double t = reached(candidates[i]);
    const double miss = std::abs(a * std::cos(t) + b * std::sin(t) - c);
    if (miss < best_miss - 1e-12 * r || (miss <= best_miss + 1e-12 * r && std::abs(t) < std::abs(turn))) {
      best_miss = std::min(best_miss, miss);
      turn = t;
    }
  }
  return best_miss <= kTriangleMaxMiss * r;
}

// The ball's twist before a hinge in aim_chain_at_points maximises sum b . R(t) a plus this share
// of sum |a| |b| times cos t (a prior toward no twist, as Levenberg-Marquardt's damping): the
// points after the ball pull the twist only as far as they lie off its axis. On a nearly straight
// limb (a collarbone, a hinged upper arm at its bound 0 and an elbow bent 2 deg) they lie almost on
// it, the fit is flat, and the undamped angle turned the whole arm by 30-90 deg in a frame's few
// iterations (issue 16, item 18: Humanoid.Item18FabrikHingeLimitsTrackWithoutJumps, the arms from
// the collarbone; 0 runs of 100 jump with 1e-2, 4-6 with 1e-3, 5-7 with 1e-4, 6-9 undamped). On a
// leg whose knee is bent 10 deg the foot's own pull is about 0.6 of the prior's; FABRIK's forward
// stage puts a knee's points in its current plane there (keep_bend_plane, fabrik.cpp), so little
// twist is asked for.
constexpr double kTwistDamping = 1e-2;

// The twist `fit` asks of a ball about its bone (the pairs of what hangs from it), damped toward
// none by kTwistDamping: chains (aim_chain_at_points) and trees (tree_fabrik.cpp) twist by it.
inline double damped_twist_angle(HingeFit fit) {
  fit.c += kTwistDamping * fit.scale;
  return fit.angle();
}

// Running sums over the points k = j+1..n of one pass: the current points x_k and the desired
// points y_k (both relative to the root, which keeps the sums' rounding at the chain's scale), so
// that a hinge's least-squares fit over every point after it costs O(1) instead of O(n).
struct PointSums {
  int count = 0;
  glm::dvec3 x{0.0}, y{0.0};
  glm::dmat3 xy{0.0};  // sum x_k y_k^T
  double xx = 0.0, yy = 0.0;
  void add(const glm::dvec3& xk, const glm::dvec3& yk, double sign) {
    count += sign > 0.0 ? 1 : -1;
    x += sign * xk;
    y += sign * yk;
    xy += sign * glm::outerProduct(xk, yk);
    xx += sign * glm::dot(xk, xk);
    yy += sign * glm::dot(yk, yk);
  }
  // The hinge fit (see HingeFit) of the pairs a_k = turn * (x_k - xj) -> b_k = y_k - oj about the
  // unit `axis`: with G = sum a_k b_k^T = turn * P, P = sum (x_k - xj)(y_k - oj)^T,
  // s = axis . (sum a_k x b_k) (the axial vector of G) and c = tr G - axis^T G axis.
  HingeFit fit(const glm::dvec3& axis, const glm::dquat& turn, const glm::dvec3& xj, const glm::dvec3& oj) const {
    const double m = count;
    const glm::dmat3 p = xy - glm::outerProduct(x, oj) - glm::outerProduct(xj, y) + m * glm::outerProduct(xj, oj);
    const glm::dmat3 g = glm::mat3_cast(turn) * p;  // glm: g[col][row]
    HingeFit f;
    f.s = axis.x * (g[2][1] - g[1][2]) + axis.y * (g[0][2] - g[2][0]) + axis.z * (g[1][0] - g[0][1]);
    f.c = g[0][0] + g[1][1] + g[2][2] - glm::dot(axis, g * axis);
    // Cauchy-Schwarz bound on sum |a_k||b_k|, for HingeFit's "nothing to turn" test.
    const double aa = xx - 2.0 * glm::dot(xj, x) + m * glm::dot(xj, xj);
    const double bb = yy - 2.0 * glm::dot(oj, y) + m * glm::dot(oj, oj);
    f.scale = std::sqrt(std::max(aa, 0.0) * std::max(bb, 0.0));
    return f;
  }
};

// A point where it is in the pose on entry and where it should be (aim_chain_at_points).
struct PointPair {
  glm::dvec3 old_in_base{0.0}, desired_in_base{0.0};
};

// Root-to-tip pass: each joint j in turn is rotated so that the chain after it best follows the
// desired points `desired[k]` (k = 1..n: joint origins o_k, desired[n] = the tip), with the joints
// before it already updated. Ball joints get the minimal rotation taking the bone o_j -> o_{j+1}
// onto o_j -> desired[j+1]. A hinge gets the angle that best aligns (least squares, projected on
// the plane perpendicular to its axis) ALL the points after it with their desired positions: the
// bone alone is not enough, because a hinge whose bone runs along its own axis (a "twist" hinge,
// as in the alternating z/y benchmark chain) cannot move o_{j+1} at all and is aimed only by the
// points further on; fitting just the next one or two points left FABRIK at non-solution fixed
// points on hinge chains (docs/solvers.md, "Why these constants").
// A bone of zero length is aimed by the first later point off the joint. Limits are applied
// joint by joint. This is FABRIK's backward-reaching stage (Aristidou & Lasenby 2011, sec. 3,
// Alg. 1) fused with the conversion of positions to joint parameters; with every desired point
// equal to one target it straightens the chain toward it (the optimum for an out-of-reach target).
//
// `last_link_point` (optional) is one more pair, a point rigid with the last joint's frame (after
// every joint) where it is in the old pose and where it should be: it joins every hinge's fit and
// the ball twist, for what the chain's own points cannot say (FABRIK: the last hinge's axis).
//
// Needs ws filled by forward_kinematics(params) on entry (the "old" pose: the parts of the chain
// after joint j are moved rigidly with it). Leaves ws stale; call forward_kinematics() after.
// `deadline` (optional): checked every Deadline::kJointsPerCheck joints; once spent, the joints
// after stay as they were (moved rigidly with the ones before: a valid pose).
inline void aim_chain_at_points(const Chain& chain, Workspace& ws, const glm::dvec3* desired,
                                double max_step_angle, double* params,
                                const PointPair* last_link_point = nullptr, Deadline* deadline = nullptr) {
  const int n = chain.joint_count();
  const double tiny = 1e-12 * chain.total_length();
  const glm::dvec3 root = chain.root_in_base();
  auto old_point = [&](int k) -> const glm::dvec3& { return k < n ? ws.joint_origins[k] : ws.tip; };
  PointSums sums;
  for (int k = 1; k <= n; ++k) sums.add(old_point(k) - root, desired[k] - root, 1.0);
  if (last_link_point) sums.add(last_link_point->old_in_base - root, last_link_point->desired_in_base - root, 1.0);
  glm::dvec3 origin = root;               // o_j of the updated chain
  glm::dquat parent(1.0, 0.0, 0.0, 0.0);  // Q_{j-1} of the updated chain
  for (int j = 0; j < n; ++j) {
    if (deadline && deadline->spent_after_joints(j)) break;
    // A fit, and for a ball the rigid motion of every point after it (~30 flops each).
    if (deadline) deadline->charge(Deadline::kFlopsPerFit + 30.0 * (n - j));
    if (j > 0) {
      origin += parent * chain.offset_translation(j);
      sums.add(old_point(j) - root, desired[j] - root, -1.0);  // now k = j+1..n
    }
    const glm::dquat pre = glm::normalize(parent * chain.rest_rotation(j));
    // Rigid motion of the sub-chain from joint j on, caused by the updates before j.
    const glm::dquat moved = glm::normalize(pre * glm::conjugate(ws.joint_pre_rotations[j]));
    const glm::dvec3& old_origin = ws.joint_origins[j];
    if (chain.joint_type(j) == JointType::kBall) {
      for (int k = j + 1; k <= n; ++k) {
        const glm::dvec3 current = moved * (old_point(k) - old_origin);
        if (glm::length(current) <= tiny) continue;
        const glm::dvec3 aim = desired[k] - origin;
        const glm::dquat applied =
            turn_ball(chain, j, pre, rotation_between(current, aim), max_step_angle, params);
        // A hinge next can only bend in its own plane, which the minimal rotation leaves where it
        // was: a hip swung toward a knee point keeps the knee's plane away from the foot's target
        // (FABRIK then stalls on legs with hinge knees). So the ball also twists about its new
        // bone direction (o_{j+1} stays put) by the angle that best aligns the points after it,
        // damped toward no twist (kTwistDamping).
        if (j + 1 < n && chain.joint_type(j + 1) == JointType::kHinge && glm::length(aim) > tiny) {
          const glm::dvec3 bone = glm::normalize(aim);
          const HingeFit fit = sums.fit(bone, glm::normalize(applied * moved), old_origin - root, origin - root);
          turn_ball(chain, j, pre, glm::angleAxis(damped_twist_angle(fit), bone), max_step_angle, params);
        }
        break;
      }
    } else {
      const glm::dvec3 axis = hinge_axis_in_base(chain, j, pre);
      const HingeFit fit = sums.fit(axis, moved, old_origin - root, origin - root);
      turn_hinge(chain, j, fit.angle(), max_step_angle, params);
    }
    parent = glm::normalize(pre * joint_motion(chain, j, params));
  }
}

// ------------------------------------------------------------------------------------------------
// Per-joint goal fits (CCD's sweep; FABRIK's final alignment of the tip joint). Each goal becomes
// weighted vector pairs (current a -> desired b, seen from the joint's origin); see ccd.cpp.

// An effector a goal is attached to, tracked through the sweep.
struct Tracked {
  int effector = 0;  // 1..n
  glm::dvec3 position{0.0};
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0};
  double aim_at_on_point = 0.0;  // kAimAt: aim_at_on_point_radius (kinematics.hpp), m
};

// Accumulates the vector pairs of one joint (see the file comment).
struct BallFit {
  int pairs = 0;
  glm::dvec3 first_a{0.0}, first_b{0.0};
  double m[3][3] = {{0.0}};  // sum w a b^T
  void add(const glm::dvec3& a, const glm::dvec3& b, double w) {
    if (pairs++ == 0) {
      first_a = a;
      first_b = b;
    }
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m[r][c] += w * a[r] * b[c];
  }
  glm::dquat rotation() const {
    if (pairs == 1) return rotation_between(first_a, first_b);
    // Horn 1987, eq. for N: rotation maximising sum w b . R a is N's top eigenvector (w, x, y, z).
    const double sxx = m[0][0], sxy = m[0][1], sxz = m[0][2];
    const double syx = m[1][0], syy = m[1][1], syz = m[1][2];
    const double szx = m[2][0], szy = m[2][1], szz = m[2][2];
    Eigen::Matrix4d a;
    a << sxx + syy + szz, syz - szy, szx - sxz, sxy - syx,
         syz - szy, sxx - syy - szz, sxy + syx, szx + sxz,
         szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy,
         sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz;
    Eigen::Matrix4d v;
    linalg::jacobi_eigen(a, v, 4);  // eigenvalues a(i, i), eigenvectors the columns of v
    double top = a(0, 0), scale = 0.0;
    for (int i = 0; i < 4; ++i) {
      top = std::max(top, a(i, i));
      scale = std::max(scale, std::abs(a(i, i)));
    }
    // Among rotations that are all optimal (degenerate top eigenvalue, e.g. pairs all parallel),
    // take the one closest to the identity: project (1, 0, 0, 0) on the top eigenspace.
    double q[4] = {0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < 4; ++i)
      if (a(i, i) >= top - 1e-9 * scale)
        for (int r = 0; r < 4; ++r) q[r] += v(r, i) * v(0, i);
    double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (norm < 1e-6) {
      for (int i = 0; i < 4; ++i)
        if (a(i, i) == top)
          for (int r = 0; r < 4; ++r) q[r] = v(r, i);
      norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    }
    if (!(norm > 0.0) || !std::isfinite(norm)) return kIdentity;
    for (double& x : q) x /= norm;
    return glm::dquat(q[0], q[1], q[2], q[3]);
  }
};

// Adds goal g's pairs seen from `origin` to a fit (BallFit or HingeFit through `add`).
template <typename AddPair>
inline void goal_pairs(const Goal& g, const Tracked& t, const glm::dvec3& origin, AddPair&& add) {
  switch (g.kind) {
    case GoalKind::kPosition:
      add(t.position - origin, g.target_position - origin, g.weight);
      break;
    case GoalKind::kOrientation: {
      const glm::dquat target = so3::normalized(g.target_orientation);
      for (int i = 0; i < 3; ++i) {
        glm::dvec3 e(0.0);
        e[i] = 1.0;
        add(t.orientation * e, target * e, 0.5 * g.weight);
      }
      break;
    }
    case GoalKind::kAim:
      add(glm::normalize(t.orientation * g.aim_axis), glm::normalize(g.aim_direction), g.weight);
      break;
    case GoalKind::kAimAt: {
      // The direction to the point from where the effector is now: exact once the joint's turn
      // no longer moves the effector much, refined by the next sweep otherwise. On the point (the
      // rule every solver measures by, aim_at_direction) the goal is met: nothing to add.
      const glm::dvec3 to_point = g.target_position - t.position;
      const double distance = glm::length(to_point);
      if (distance > t.aim_at_on_point)
        add(glm::normalize(t.orientation * g.aim_axis), to_point / distance, g.weight);
      break;
    }
  }
}

// Where each goal's effector is now (after forward_kinematics()).
inline void track_goals(const Chain& chain, Span<const Goal> goals, const Workspace& ws, Tracked* tracked) {
  for (int g = 0; g < goals.size; ++g) {
    tracked[g].effector = resolve_effector(chain, goals[g].effector);
    tracked[g].position = effector_position(chain, ws, goals[g].effector);
    tracked[g].orientation = effector_orientation(chain, ws, goals[g].effector);
    tracked[g].aim_at_on_point = aim_at_on_point_radius(chain, goals[g]);
  }
}

// Turns joint j (ball or hinge) to the rotation that best serves the goals on effectors after it
// (tracked[g] holds goal g's effector as the pose is now), limits applied. Returns the base-frame
// rotation applied about o_j, or the identity when no goal is after j.
inline glm::dquat fit_joint(const Chain& chain, Span<const Goal> goals, const Tracked* tracked, int j,
                            const glm::dvec3& origin, const glm::dquat& pre, double max_step_angle,
                            double* params) {
  if (chain.joint_type(j) == JointType::kBall) {
    BallFit fit;
    for (int g = 0; g < goals.size; ++g)
      if (tracked[g].effector > j)
        goal_pairs(goals[g], tracked[g], origin,
                   [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(a, b, w); });
    if (fit.pairs == 0) return kIdentity;
    return turn_ball(chain, j, pre, fit.rotation(), max_step_angle, params);
  }
  const glm::dvec3 axis = hinge_axis_in_base(chain, j, pre);
  HingeFit fit;
  bool any = false;
  for (int g = 0; g < goals.size; ++g)
    if (tracked[g].effector > j) {
      any = true;
      goal_pairs(goals[g], tracked[g], origin,
                 [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(axis, a, b, w); });
    }
  if (!any) return kIdentity;
  return glm::angleAxis(turn_hinge(chain, j, fit.angle(), max_step_angle, params), axis);
}

// Keeps the lowest-cost pose seen so far in ws.params_best (the contract: leave params at the best
// pose reached).
struct BestPose {
  double cost = 0.0;
  void init(const Chain& chain, Workspace& ws, const double* params, double c) {
    cost = c;
    std::copy(params, params + chain.dof_count(), ws.params_best.data());
  }
  // Returns true when `c` is a new best.
  bool offer(const Chain& chain, Workspace& ws, const double* params, double c) {
    if (!(c < cost)) return false;
    init(chain, ws, params, c);
    return true;
  }
  void restore(const Chain& chain, const Workspace& ws, double* params) const {
    std::copy(ws.params_best.data(), ws.params_best.data() + chain.dof_count(), params);
  }
};

// The bookkeeping CCD and FABRIK do around their iterations: the start pose's error, the best pose
// seen (returned at the end) and the shared stuck rules (stuck.hpp). Stuck: the stall rule, or a
// fixed point (an iteration turning no parameter more than kStillAngle, e.g. a straight chain
// pulled along itself, where neither method moves any joint); either calls the shared escape, and
// with none left the solve stops as stalled. A limb held straight by a hinge on its bound
// (straight_at_bound_hinge) asks for the escape too, but one refused there is no stop.
class Progress {
 public:
  static constexpr double kStillAngle = 1e-12;  // rad
  // The bones on both sides of a hinge are collinear when the sine of their angle is below this:
  // a hinge on its bound holds them exactly straight (a knee on its limit 0), to rounding.
  static constexpr double kStraightSine = 1e-9;

  // Measures the start pose (FK into ws) and decides whether the target is a single tip position
  // goal at or beyond full reach (the solvers straighten toward it first).
  Progress(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
           const double* params)
      : chain_(chain), goals_(goals), options_(options), ws_(ws), escapes_(chain, goals, options, ws) {
    forward_kinematics(chain, params, ws);
    cost_ = measure_goals(chain, goals, ws).cost;
    stall_.reset(cost_);
    escapes_.offer(params, cost_);
    // Margin position_tolerance: a target within tolerance of full reach is met by the straight
    // chain too, so straightening toward it first is right there as well.
    out_of_reach_ = stuck::tip_beyond_full_reach(chain, goals, options.position_tolerance);
  }

  bool out_of_reach() const { return out_of_reach_; }
  int escapes() const { return escapes_.used(); }

  // After an iteration that changed no parameter by more than `moved` (rad): measures the pose
  // (FK into ws), keeps it if best, escapes when stuck, and returns true when the solve stops, with
  // `reason` set to kConverged, kStalled or (time budget) kMaxIterations; left alone otherwise.
  bool stop_after_iteration(double* params, double moved, TerminationReason& reason) {
    forward_kinematics(chain_, params, ws_);
    const GoalErrors err = measure_goals(chain_, goals_, ws_);
    cost_ = err.cost;
    escapes_.offer(params, cost_);
    if (err.within(options_)) {
      reason = TerminationReason::kConverged;
      return true;
    }
    const bool stalled = stall_.stalled_after(cost_, options_.stall_tolerance);
    const bool still = moved <= kStillAngle || stalled;
    // A straight limb whose hinge rests on its bound, the goals unmet and not beyond reach: both
    // methods bend a hinge only by where the points after it lie, and on a straight limb those lie
    // on the hinge's own line, so a fold the bound forbids is all they ask for (clipped to the
    // bound) while the straight limb swings toward the target, slower with every sweep and never
    // stalling within 64 (a tracked leg stayed straight, 153-315 mm off: issue 16, item 13). The
    // escape folds the hinge the way its bound allows. Refused (none left, or the goals provably
    // out of reach), the sweeps go on.
    const bool pinned_straight = !still && !out_of_reach_ && straight_at_bound_hinge(params);
    if (still || pinned_straight) {
      if (escapes_.escape(params, cost_)) {
        forward_kinematics(chain_, params, ws_);
        cost_ = measure_goals(chain_, goals_, ws_).cost;
        stall_.reset(cost_);
      } else if (still) {
        reason = TerminationReason::kStalled;
        return true;
      }
    }
    if (ws_.deadline.spent()) {
      reason = TerminationReason::kMaxIterations;  // the time budget
      return true;
    }
    return false;
  }

  // A converged pose stays as it is; otherwise params (and ws's FK) go to the best pose seen.
  void finish(TerminationReason reason, double* params) const {
    if (reason == TerminationReason::kConverged) return;
    if (escapes_.restore_best(params, cost_)) forward_kinematics(chain_, params, ws_);
  }

 private:
  // Some bending hinge j >= 1 rests on a bound with the bone before it and the one after it (to the
  // next joint or the tip) collinear, pointing the same way (after forward_kinematics()). A hinge
  // whose axis runs along its next bone twists it rather than bends it: not a straight limb's knee.
  bool straight_at_bound_hinge(const double* params) const {
    const int n = chain_.joint_count();
    for (int j = 1; j < n; ++j) {
      if (chain_.joint_type(j) != JointType::kHinge || !chain_.limits(j).has_hinge_limit) continue;
      if (!hinge_blocked(chain_, j, params, -1.0) && !hinge_blocked(chain_, j, params, 1.0)) continue;
      const glm::dvec3 before = ws_.joint_origins[j] - ws_.joint_origins[j - 1];
      const glm::dvec3 after = (j + 1 < n ? ws_.joint_origins[j + 1] : ws_.tip) - ws_.joint_origins[j];
      const double lb = glm::length(before), la = glm::length(after);
      if (!(lb > 0.0) || !(la > 0.0) || glm::dot(before, after) <= 0.0) continue;
      if (glm::length(glm::cross(before, after)) > kStraightSine * lb * la) continue;
      const glm::dvec3 axis = hinge_axis_in_base(chain_, j, ws_.joint_pre_rotations[j]);
      if (std::abs(glm::dot(axis, after)) > 0.5 * la) continue;
      return true;
    }
    return false;
  }

  const Chain& chain_;
  Span<const Goal> goals_;
  const SolverOptions& options_;
  Workspace& ws_;
  stuck::StallRule stall_;
  stuck::Escapes escapes_;
  double cost_ = 0.0;  // of params as last measured
  bool out_of_reach_ = false;
};

}  // namespace geometric
}  // namespace ikchain
