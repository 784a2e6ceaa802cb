// The solvers' side of the kinematics: goal residual rows, the goal Jacobian and its columns, the
// step update, and the limits' active set (which joints a step must not push out). The public side
// (forward kinematics, effectors, goal errors, projection onto limits) is ikchain/kinematics.hpp.
#pragma once
#include <Eigen/Dense>

#include "ikchain/kinematics.hpp"

namespace ikchain {

// kAimAt: the unit direction from the goal's effector to its point and the distance; false when
// the effector sits on the point (nearer than aim_at_on_point_radius: no direction to aim along,
// the goal is met). Valid after forward_kinematics().
bool aim_at_direction(const Chain& chain, const Workspace& ws, const Goal& goal, glm::dvec3& direction,
                      double& distance);

// One goal's error (desired - current, unweighted; goal.hpp) for an effector at this position and
// orientation (base space); kAimAt counts as met nearer to its point than on_point_radius (m).
// Chains and trees measure goals with it.
glm::dvec3 goal_error_at(const Goal& goal, const glm::dvec3& effector_position, const glm::dquat& effector_orientation,
                         double on_point_radius);

// Base-frame rotation axis of every DOF: ws.dof_axes. For a ball joint these are the columns of
// pre_rotation * J_l(r), so that d(params) maps exactly to angular velocity in the base frame.
// Valid after forward_kinematics().
void compute_dof_axes(const Chain& chain, const double* params, Workspace& ws);

// Residual rows e_g * sqrt(w_g) into `residual` (3 per goal, desired - current), after
// forward_kinematics(). Returns the errors.
GoalErrors evaluate_goals(const Chain& chain, Span<const Goal> goals, const Workspace& ws,
                          Eigen::Ref<Eigen::VectorXd> residual);

// Jacobian of the weighted residual rows w.r.t. params (d current / d params, i.e. the sign that
// makes J * dparams ~= the achieved change of the effectors), 3 rows per goal.
// Needs forward_kinematics() and compute_dof_axes().
void compute_jacobian(const Chain& chain, Span<const Goal> goals, const Workspace& ws,
                      Eigen::Ref<Eigen::MatrixXd> jacobian);

// What a goal's Jacobian columns depend on besides the DOF (compute_jacobian, the tree's Jacobian).
struct GoalLinearization {
  glm::dvec3 point{0.0};      // kPosition, kAimAt: the effector's position
  glm::dvec3 aim_axis{0.0};   // kAim, kAimAt: its aim axis in base space (unit)
  glm::dvec3 direction{0.0};  // kAimAt: unit direction to the point, when aim_at_defined
  double distance = 0.0;      // kAimAt: distance to the point
  bool aim_at_defined = false;
};
// The column of a rotational DOF turning about base-frame axis w, with `lever` = effector - the
// joint's origin: the change of the goal's "current" side per radian.
inline glm::dvec3 rotation_column(GoalKind kind, const glm::dvec3& w, const glm::dvec3& lever,
                                  const GoalLinearization& lin) {
  switch (kind) {
    case GoalKind::kPosition: return glm::cross(w, lever);
    case GoalKind::kOrientation: return w;
    // Only the part of the rotation perpendicular to the axis turns it.
    case GoalKind::kAim: return w - lin.aim_axis * glm::dot(lin.aim_axis, w);
    // As kAim, plus the turn of the direction to the point as the effector moves
    // (d x dx / distance, dx = w x lever): with it, -J^T e is the exact gradient of 0.5 angle^2
    // (d(angle) = -n.w + (d x n).dx / distance, n = unit e).
    case GoalKind::kAimAt:
      if (!lin.aim_at_defined) return glm::dvec3(0.0);
      return w - lin.aim_axis * glm::dot(lin.aim_axis, w) +
             glm::cross(lin.direction, glm::cross(w, lever)) / lin.distance;
  }
  return glm::dvec3(0.0);
}
// The column of a translational DOF (a slide, a floating root) along base-frame direction w: it
// moves the effector by w and turns nothing.
inline glm::dvec3 translation_column(GoalKind kind, const glm::dvec3& w, const GoalLinearization& lin) {
  if (kind == GoalKind::kPosition) return w;
  if (kind == GoalKind::kAimAt && lin.aim_at_defined) return glm::cross(lin.direction, w) / lin.distance;
  return glm::dvec3(0.0);
}

// params += step, capping any joint's rotation at max_step_angle (0 = none) and keeping ball
// rotation vectors at angle <= pi. `step` has dof_count entries.
void apply_step(const Chain& chain, const double* step, double max_step_angle, double* params);

// A limited 1-DOF joint (hinge, slide: is_one_dof(type)) at `value` resting on a bound of its range
// (param_range, within 1e-12) that a change with the sign of `direction` would push out.
inline bool one_dof_blocked(JointType type, const JointLimits& l, double value, double direction) {
  const ParamRange r = param_range(type, l);
  if (!r.limited) return false;
  constexpr double kOnBound = 1e-12;
  return (value <= r.min + kOnBound && direction < 0.0) || (value >= r.max - kOnBound && direction > 0.0);
}
// ball_blocked and ball_on_boundary (below) for a ball joint's own params `p`.
int ball_params_blocked(const JointLimits& limits, const double* p, const double* direction, glm::dvec3 normals[2]);
bool ball_params_on_boundary(const JointLimits& limits, const double* p);
// The one blocked test of every joint type, for its own params `p` and its entries of a step
// `direction` (joint_dof_count(type) of each): 1 for a 1-DOF joint one_dof_blocked() freezes (its
// DOF must not move), for a ball the number of outward normals ball_params_blocked() writes to
// `normals` (those directions must not move); 0 when nothing blocks.
inline int joint_params_blocked(JointType type, const JointLimits& limits, const double* p, const double* direction,
                                glm::dvec3 normals[2]) {
  if (is_one_dof(type)) return one_dof_blocked(type, limits, p[0], direction[0]) ? 1 : 0;
  return ball_params_blocked(limits, p, direction, normals);
}
// True when a joint rests on one of its limits: a 1-DOF joint at a bound (one_dof_blocked's test,
// either way), a ball on its cone or a twist bound (ball_params_on_boundary). `p`: its own params.
bool joint_params_at_limit(JointType type, const JointLimits& limits, const double* p);

// True when joint `joint` is a limited hinge (or prismatic joint) resting on a bound (within 1e-12 rad) and a change of
// its angle by `direction` (its sign is what counts) would push it out: the active set of the
// Jacobian solvers' limit-aware steps and of BFGS's projected steps (ball joints: ball_blocked).
inline bool hinge_blocked(const Chain& chain, int joint, const double* params, double direction) {
  if (!is_one_dof(chain.joint_type(joint))) return false;
  return one_dof_blocked(chain.joint_type(joint), chain.limits(joint), params[chain.dof_offset(joint)], direction);
}
// The same active set for a ball joint's cone and twist limits. A limit the joint rests on (swing
// angle at cone_angle, twist angle at a bound, within 1e-10 rad) blocks a step of the joint's
// rotation vector whose component along the limit's outward normal is positive. The normals are
// exact gradients of the swing and twist angles mapped into rotation-vector space through the left
// Jacobian: with b = q a (a = twist_axis), d swing = ((a x b) / |a x b|) . w and
// d twist = ((a + b) / (1 + a . b)) . w for a local angular velocity w = J_l(r) dr.
// `direction` is the joint's 3 DOF entries of the step. When it pushes out of at least one limit,
// writes an orthonormal basis of the normals to remove from the joint's step - the blocked ones
// and any it is already tangent to (within 1e-9 relative: the ones an earlier pass removed, so that
// removing the set again is idempotent) - into `normals`, and returns their count (1 or 2);
// returns 0 when nothing blocks. A step freed of these components slides along the boundary.
int ball_blocked(const Chain& chain, int joint, const double* params, const double* direction,
                 glm::dvec3 normals[2]);
// True when ball `joint` rests on its cone or a twist bound (ball_blocked's test, whatever the step).
bool ball_on_boundary(const Chain& chain, int joint, const double* params);
// Removes the component along unit `normal` (rotation-vector space) from the 3 DOF columns
// o..o+2 of the first `rows` rows of `jacobian`, J <- J (I - n n^T): a minimum-norm or damped step
// solved over the result has no component along n. For a hinge the same is zeroing its column.
inline void remove_ball_direction(Eigen::MatrixXd& jacobian, int rows, int o, const glm::dvec3& normal) {
  double* c0 = jacobian.col(o).data();
  double* c1 = jacobian.col(o + 1).data();
  double* c2 = jacobian.col(o + 2).data();
  for (int r = 0; r < rows; ++r) {
    const double v = c0[r] * normal.x + c1[r] * normal.y + c2[r] * normal.z;
    c0[r] -= v * normal.x;
    c1[r] -= v * normal.y;
    c2[r] -= v * normal.z;
  }
}
}  // namespace ikchain
