#include "core/kinematics_internal.hpp"

#include <algorithm>
#include <cmath>

#include "core/quat_ops.hpp"
#include "ikchain/so3.hpp"

namespace ikchain {

void forward_kinematics(const Chain& chain, const double* params, Workspace& ws) {
  using namespace quat_ops;
  const int n = chain.joint_count();
  glm::dvec3 origin(0.0);
  Quat orientation{1.0, 0.0, 0.0, 0.0};
  for (int i = 0; i < n; ++i) {
    origin += rotate_coded(orientation, chain.offset_translation(i), Direction(chain.offset_direction(i)));
    const Quat pre = chain.rest_is_identity(i) ? orientation
                                               : multiply(orientation, from_glm(chain.rest_rotation(i)));
    // Products of unit quaternions stay unit to ~1e-16 per joint in double precision (1e-14 over
    // 100 joints): no renormalisation needed on the hot path.
    if (chain.joint_type(i) == JointType::kHinge) {
      double s, c;
      so3::fast_sincos(0.5 * params[chain.dof_offset(i)], s, c);
      orientation = multiply_axis_angle(pre, chain.axis(i), Direction(chain.axis_direction(i)), c, s);
    } else if (chain.joint_type(i) == JointType::kPrismatic) {
      // The slide moves the joints after this one (o_i itself stays: only joints before effector
      // k move it, chain.hpp).
      orientation = pre;
      ws.joint_origins[i] = origin;
      ws.joint_pre_rotations[i] = to_glm(pre);
      ws.joint_orientations[i] = to_glm(orientation);
      origin += rotate(pre, chain.axis(i) * params[chain.dof_offset(i)]);
      continue;
    } else {
      orientation = multiply(pre, from_glm(joint_motion(chain, i, params)));
    }
    ws.joint_origins[i] = origin;
    ws.joint_pre_rotations[i] = to_glm(pre);
    ws.joint_orientations[i] = to_glm(orientation);
  }
  ws.tip = origin + rotate_coded(orientation, chain.tip_offset(), Direction(chain.tip_direction()));
  ws.deadline.charge(Deadline::kFlopsPerJoint * n);
}

int resolve_effector(const Chain& chain, int effector) {
  return effector <= 0 ? chain.joint_count() : effector;
}

glm::dvec3 effector_position(const Chain& chain, const Workspace& ws, int effector) {
  const int k = resolve_effector(chain, effector);
  return k >= chain.joint_count() ? ws.tip : ws.joint_origins[k];
}

glm::dquat effector_orientation(const Chain& chain, const Workspace& ws, int effector) {
  const int k = resolve_effector(chain, effector);
  if (k >= chain.joint_count()) return ws.joint_orientations[k - 1] * chain.tip_rotation();
  return ws.joint_orientations[k - 1];
}

double aim_at_on_point_radius(const Chain& chain, const Goal& goal) {
  return kAimAtOnPoint * (chain.total_length() + glm::length(goal.target_position));
}

bool aim_at_direction(const Chain& chain, const Workspace& ws, const Goal& goal, glm::dvec3& direction,
                      double& distance) {
  const glm::dvec3 d = goal.target_position - effector_position(chain, ws, goal.effector);
  distance = glm::length(d);
  if (!(distance > aim_at_on_point_radius(chain, goal))) return false;
  direction = d / distance;
  return true;
}

void compute_dof_axes(const Chain& chain, const double* params, Workspace& ws) {
  const int n = chain.joint_count();
  for (int i = 0; i < n; ++i) {
    const int o = chain.dof_offset(i);
    const glm::dquat& pre = ws.joint_pre_rotations[i];
    if (is_one_dof(chain.joint_type(i))) {  // hinge: rotation axis, prismatic: slide direction
      ws.dof_axes[o] = pre * chain.axis(i);
    } else {
      const glm::dmat3 jl = so3::left_jacobian(glm::dvec3(params[o], params[o + 1], params[o + 2]));
      for (int k = 0; k < 3; ++k) ws.dof_axes[o + k] = pre * jl[k];
    }
  }
  ws.deadline.charge(Deadline::kFlopsPerJoint * n);
}

namespace {

// Aim residual: the rotation vector turning `axis_in_base` onto `direction` (both unit).
glm::dvec3 aim_error(const glm::dvec3& axis_in_base, const glm::dvec3& direction) {
  const glm::dvec3 c = glm::cross(axis_in_base, direction);
  const double s = glm::length(c);
  const double angle = std::atan2(s, glm::dot(axis_in_base, direction));
  if (s > 1e-12) return c * (angle / s);
  if (angle < 1.0) return glm::dvec3(0.0);
  // Opposite: any perpendicular axis turns it, pick a stable one.
  glm::dvec3 perp = glm::cross(axis_in_base, glm::dvec3(1, 0, 0));
  if (glm::dot(perp, perp) < 1e-6) perp = glm::cross(axis_in_base, glm::dvec3(0, 1, 0));
  return glm::normalize(perp) * angle;
}

}  // namespace

glm::dvec3 goal_error_at(const Goal& g, const glm::dvec3& effector_position, const glm::dquat& effector_orientation,
                         double on_point_radius) {
  switch (g.kind) {
    case GoalKind::kPosition:
      return g.target_position - effector_position;
    case GoalKind::kOrientation:
      return so3::log(so3::normalized(g.target_orientation) * glm::conjugate(effector_orientation));
    case GoalKind::kAim:
      return aim_error(glm::normalize(effector_orientation * g.aim_axis), glm::normalize(g.aim_direction));
    case GoalKind::kAimAt: {
      const glm::dvec3 d = g.target_position - effector_position;
      const double distance = glm::length(d);
      if (!(distance > on_point_radius)) return glm::dvec3(0.0);
      return aim_error(glm::normalize(effector_orientation * g.aim_axis), d / distance);
    }
  }
  return glm::dvec3(0.0);
}

namespace {

glm::dvec3 goal_error(const Chain& chain, const Goal& g, const Workspace& ws) {
  return goal_error_at(g, effector_position(chain, ws, g.effector), effector_orientation(chain, ws, g.effector),
                       g.kind == GoalKind::kAimAt ? aim_at_on_point_radius(chain, g) : 0.0);
}

template <typename Sink>
GoalErrors evaluate(const Chain& chain, Span<const Goal> goals, const Workspace& ws, Sink&& sink) {
  GoalErrors out;
  double weighted = 0.0;
  for (int i = 0; i < goals.size; ++i) {
    const Goal& g = goals[i];
    const glm::dvec3 e = goal_error(chain, g, ws);
    const double len2 = glm::dot(e, e);
    weighted += g.weight * len2;
    const double len = std::sqrt(len2);
    // Not std::max: it drops a NaN (max(0, NaN) is 0), and a NaN error must never read as "met".
    double& worst = g.kind == GoalKind::kPosition ? out.max_position : out.max_orientation;
    if (len > worst || std::isnan(len)) worst = len;
    sink(i, e * std::sqrt(g.weight));
  }
  out.cost = 0.5 * weighted;
  out.combined = std::sqrt(weighted);
  return out;
}

}  // namespace

GoalErrors evaluate_goals(const Chain& chain, Span<const Goal> goals, const Workspace& ws,
                          Eigen::Ref<Eigen::VectorXd> residual) {
  return evaluate(chain, goals, ws, [&](int i, const glm::dvec3& e) {
    residual[3 * i] = e.x;
    residual[3 * i + 1] = e.y;
    residual[3 * i + 2] = e.z;
  });
}

GoalErrors measure_goals(const Chain& chain, Span<const Goal> goals, const Workspace& ws) {
  return evaluate(chain, goals, ws, [](int, const glm::dvec3&) {});
}

void compute_jacobian(const Chain& chain, Span<const Goal> goals, Workspace& ws,
                      Eigen::Ref<Eigen::MatrixXd> jacobian) {
  const int n = chain.joint_count();
  ws.deadline.charge(Deadline::kFlopsPerJacobianEntry * 3.0 * goals.size * chain.dof_count());
  for (int gi = 0; gi < goals.size; ++gi) {
    const Goal& g = goals[gi];
    const int k = resolve_effector(chain, g.effector);
    const double sw = std::sqrt(g.weight);
    const int row = 3 * gi;
    glm::dvec3 point(0.0), aim_axis(0.0), direction(0.0);
    double distance = 0.0;
    bool aim_at_defined = false;
    if (g.kind == GoalKind::kPosition || g.kind == GoalKind::kAimAt)
      point = effector_position(chain, ws, g.effector);
    if (g.kind == GoalKind::kAim || g.kind == GoalKind::kAimAt)
      aim_axis = glm::normalize(effector_orientation(chain, ws, g.effector) * g.aim_axis);
    if (g.kind == GoalKind::kAimAt) aim_at_defined = aim_at_direction(chain, ws, g, direction, distance);
    const GoalLinearization lin{point, aim_axis, direction, distance, aim_at_defined};
    for (int j = 0; j < n; ++j) {
      const int o = chain.dof_offset(j);
      const int cnt = chain.dof_count_of(j);
      for (int d = 0; d < cnt; ++d) {
        glm::dvec3 col(0.0);
        if (j < k && !turns(chain.joint_type(j))) {
          col = translation_column(g.kind, ws.dof_axes[o], lin);
        } else if (j < k) {
          col = rotation_column(g.kind, ws.dof_axes[o + d], point - ws.joint_origins[j], lin);
        }
        jacobian(row, o + d) = sw * col.x;
        jacobian(row + 1, o + d) = sw * col.y;
        jacobian(row + 2, o + d) = sw * col.z;
      }
    }
  }
}

void apply_step(const Chain& chain, const double* step, double max_step_angle, double* params) {
  if (chain.all_hinges() && !(max_step_angle > 0.0)) {
    // Every param an angle, nothing to cap or wrap: a plain sum, without per-joint lookups (the
    // Jacobian solvers make one trial pose per iteration with it).
    for (int j = 0; j < chain.dof_count(); ++j) params[j] += step[j];
    return;
  }
  const int n = chain.joint_count();
  for (int i = 0; i < n; ++i) {
    const int o = chain.dof_offset(i);
    const JointType type = chain.joint_type(i);
    if (is_one_dof(type)) {
      double d = step[o];
      // A slide's metres have no angle to cap.
      if (turns(type) && max_step_angle > 0.0) d = std::clamp(d, -max_step_angle, max_step_angle);
      params[o] += d;
    } else {
      glm::dvec3 d(step[o], step[o + 1], step[o + 2]);
      const double len = glm::length(d);
      if (max_step_angle > 0.0 && len > max_step_angle) d *= max_step_angle / len;
      glm::dvec3 r(params[o] + d.x, params[o + 1] + d.y, params[o + 2] + d.z);
      r = so3::wrap_rotation_vector(r);
      params[o] = r.x;
      params[o + 1] = r.y;
      params[o + 2] = r.z;
    }
  }
}

namespace {

// Projects a ball joint's local rotation onto its cone and twist limits. Returns true if changed.
bool project_ball(const JointLimits& l, glm::dquat& q) {
  if (!l.has_cone_limit && !l.has_twist_limit) return false;
  glm::dquat swing;
  double twist_angle = 0.0;
  so3::swing_twist(q, l.twist_axis, swing, twist_angle);
  bool changed = false;
  if (l.has_twist_limit && (twist_angle < l.twist_min || twist_angle > l.twist_max)) {
    twist_angle = std::clamp(twist_angle, l.twist_min, l.twist_max);
    changed = true;
  }
  if (l.has_cone_limit) {
    glm::dvec3 sv = so3::log(swing);
    const double swing_angle = glm::length(sv);
    if (swing_angle > l.cone_angle) {
      sv *= l.cone_angle / swing_angle;
      swing = so3::exp(sv);
      changed = true;
    }
  }
  if (changed) q = swing * glm::angleAxis(twist_angle, l.twist_axis);
  return changed;
}

}  // namespace

void project_joint_params(JointType type, const JointLimits& l, double* p) {
  if (is_one_dof(type)) {
    const ParamRange r = param_range(type, l);
    if (r.limited) p[0] = std::clamp(p[0], r.min, r.max);
    return;
  }
  if (!l.has_cone_limit && !l.has_twist_limit) return;
  // Surely inside, without trigonometry: neither the swing angle nor |twist| exceeds the rotation
  // angle, itself at most |r| (as ball_bounds below). The margin is far above the exp/log round
  // trip's rounding, so project_ball would change nothing there: the same params, bit for bit. A
  // warm start of 200 limited joints was 5-12 us of a budget-bound solve's set-up (issue 16, item 6).
  constexpr double kSurelyInside = 1e-9;  // rad
  const double angle = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  if ((!l.has_cone_limit || angle < l.cone_angle - kSurelyInside) &&
      (!l.has_twist_limit || (angle < l.twist_max - kSurelyInside && -angle > l.twist_min + kSurelyInside)))
    return;
  glm::dquat q = so3::exp(glm::dvec3(p[0], p[1], p[2]));
  if (project_ball(l, q)) {
    const glm::dvec3 r = so3::log(q);
    p[0] = r.x;
    p[1] = r.y;
    p[2] = r.z;
  }
}

void project_joint_to_limits(const Chain& chain, int joint, double* params) {
  if (!chain.has_limits(joint)) return;
  project_joint_params(chain.joint_type(joint), chain.limits(joint), params + chain.dof_offset(joint));
}

void project_to_limits(const Chain& chain, double* params) {
  if (!chain.any_limits()) return;
  for (int i = 0; i < chain.joint_count(); ++i) project_joint_to_limits(chain, i, params);
}

namespace {

// Which of ball `joint`'s limits it rests on at params (within kOnBound rad), and its rotation.
struct BallBounds {
  bool on_cone = false, at_max = false, at_min = false;
  glm::dvec3 r{0.0};
  glm::dquat q{1.0, 0.0, 0.0, 0.0};
  bool any() const { return on_cone || at_max || at_min; }
};

BallBounds ball_bounds(const JointLimits& l, const double* p) {
  BallBounds bounds;
  if (!l.has_cone_limit && !l.has_twist_limit) return bounds;
  constexpr double kOnBound = 1e-10;  // rad; the projection's exp/log round trip leaves ~1e-15
  const glm::dvec3 r(p[0], p[1], p[2]);
  bounds.r = r;
  // The common case first, without trigonometry: neither the swing angle nor |twist| exceeds the
  // rotation angle, itself at most |r| (cos(angle / 2) = cos(swing / 2) cos(twist / 2)).
  const double angle = glm::length(r);
  if ((!l.has_cone_limit || angle < l.cone_angle - kOnBound) &&
      (!l.has_twist_limit || (angle < l.twist_max - kOnBound && -angle > l.twist_min + kOnBound)))
    return bounds;
  const glm::dquat q = so3::exp(r);
  bounds.q = q;
  const glm::dvec3& a = l.twist_axis;
  // Which bounds it rests on, from the quaternion: the swing is the rotation left after the twist
  // (w, (v . a) a) / n, so sin^2(swing / 2) = 1 - n^2; the twist angle as so3::swing_twist's.
  const double along_axis = q.x * a.x + q.y * a.y + q.z * a.z;
  const double swing_limit = 0.5 * (l.cone_angle - kOnBound);
  bounds.on_cone = l.has_cone_limit && swing_limit > 0.0 &&
                   1.0 - q.w * q.w - along_axis * along_axis >= std::sin(swing_limit) * std::sin(swing_limit);
  if (l.has_twist_limit) {
    glm::dquat swing;
    double twist = 0.0;
    so3::swing_twist(q, a, swing, twist);
    bounds.at_max = twist >= l.twist_max - kOnBound;
    bounds.at_min = twist <= l.twist_min + kOnBound;
  }
  return bounds;
}

}  // namespace

bool ball_params_on_boundary(const JointLimits& limits, const double* p) {
  return ball_bounds(limits, p).any();
}

bool joint_params_at_limit(JointType type, const JointLimits& limits, const double* p) {
  if (!is_one_dof(type)) return ball_params_on_boundary(limits, p);
  return one_dof_blocked(type, limits, p[0], -1.0) || one_dof_blocked(type, limits, p[0], 1.0);
}

int joints_at_limit(const Chain& chain, const double* params) {
  int count = 0;
  for (int i = 0; i < chain.joint_count(); ++i)
    count += joint_params_at_limit(chain.joint_type(i), chain.limits(i), params + chain.dof_offset(i)) ? 1 : 0;
  return count;
}

bool ball_on_boundary(const Chain& chain, int joint, const double* params) {
  return chain.joint_type(joint) == JointType::kBall &&
         ball_params_on_boundary(chain.limits(joint), params + chain.dof_offset(joint));
}

int ball_blocked(const Chain& chain, int joint, const double* params, const double* direction,
                 glm::dvec3 normals[2]) {
  if (chain.joint_type(joint) != JointType::kBall) return 0;
  return ball_params_blocked(chain.limits(joint), params + chain.dof_offset(joint), direction, normals);
}

int ball_params_blocked(const JointLimits& l, const double* p, const double* direction, glm::dvec3 normals[2]) {
  // The bounds first: most joints rest on none (ball_bounds' test without trigonometry), and then
  // the step's length is not needed.
  const BallBounds bounds = ball_bounds(l, p);
  if (!bounds.any()) return 0;
  const glm::dvec3 d(direction[0], direction[1], direction[2]);
  const double tolerance = 1e-9 * glm::length(d);
  if (!(tolerance > 0.0)) return 0;
  const bool on_cone = bounds.on_cone, at_max = bounds.at_max, at_min = bounds.at_min;
  const glm::dvec3& r = bounds.r;
  const glm::dquat& q = bounds.q;
  const glm::dvec3& a = l.twist_axis;
  // Outward normals in angular-velocity space, then d(angle)/d(r) = J_l(r)^T g, since
  // w = J_l(r) dr. The swing normal is undefined at zero swing (the projection holds a zero cone)
  // and the twist's at a half-turn swing (the twist itself is undefined there).
  const glm::dmat3 jl_transposed = glm::transpose(so3::left_jacobian(r));
  const glm::dvec3 b = q * a;
  const glm::dvec3 axb = glm::cross(a, b);
  const double sin_swing = glm::length(axb), cos_swing = glm::dot(a, b);
  glm::dvec3 outward[2];
  int count = 0;
  if (on_cone && sin_swing > 1e-9) outward[count++] = glm::normalize(jl_transposed * (axb / sin_swing));
  if ((at_max || at_min) && 1.0 + cos_swing > 1e-9) {
    const glm::dvec3 n = glm::normalize(jl_transposed * (a + b));
    // On both bounds (twist_min == twist_max) every twist is blocked: the normal the step pushes along.
    outward[count++] = at_max && (!at_min || glm::dot(n, d) >= 0.0) ? n : -n;
  }
  if (count == 0) return 0;
  bool pushes_out = false;
  glm::dvec3 kept[2];
  int kept_count = 0;
  for (int k = 0; k < count; ++k) {
    const glm::dvec3& n = outward[k];
    const double along = glm::dot(n, d);
    if (along > tolerance) pushes_out = true;
    if (along > -tolerance) kept[kept_count++] = n;
  }
  if (!pushes_out) return 0;
  int out = 0;
  for (int k = 0; k < kept_count; ++k) {  // Gram-Schmidt
    glm::dvec3 n = kept[k];
    for (int m = 0; m < out; ++m) n -= glm::dot(n, normals[m]) * normals[m];
    const double len = glm::length(n);
    if (len > 1e-9) normals[out++] = n / len;
  }
  return out;
}

bool joint_within_limits(JointType type, const JointLimits& l, const double* p, double slack) {
  if (is_one_dof(type)) {
    const ParamRange r = param_range(type, l);
    return !r.limited || (p[0] >= r.min - slack && p[0] <= r.max + slack);
  }
  if (!l.has_cone_limit && !l.has_twist_limit) return true;
  const glm::dquat q = so3::exp(glm::dvec3(p[0], p[1], p[2]));
  glm::dquat swing;
  double twist_angle = 0.0;
  so3::swing_twist(q, l.twist_axis, swing, twist_angle);
  if (l.has_twist_limit && (twist_angle < l.twist_min - slack || twist_angle > l.twist_max + slack)) return false;
  return !(l.has_cone_limit && glm::length(so3::log(swing)) > l.cone_angle + slack);
}

bool within_limits(const Chain& chain, const double* params, double slack) {
  const int n = chain.joint_count();
  for (int i = 0; i < n; ++i)
    if (!joint_within_limits(chain.joint_type(i), chain.limits(i), params + chain.dof_offset(i), slack)) return false;
  return true;
}

}  // namespace ikchain
