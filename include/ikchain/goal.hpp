// What a solve tries to achieve. All goals are in the chain's base space.
//
// Residuals (what the solvers drive to zero), 3 rows per goal, e = desired - current:
//   kPosition:    target_position - effector position                      (m)
//   kOrientation: log(target_orientation * conj(effector orientation))      (rad, rotation vector in the base frame)
//   kAim:         rotation vector turning the effector's aim_axis (its own frame) onto
//                 aim_direction, angle in [0, pi]                           (rad)
//   kAimAt:       the same with aim_direction = normalize(target_position - effector position),
//                 recomputed from the current pose (a turret or a head looking at a point)  (rad);
//                 0 when the effector sits on the point (no direction to aim along;
//                 kAimAtOnPoint in kinematics.hpp says how near that is)
// The objective is 0.5 * sum_g weight_g * |e_g|^2.
#pragma once
#include <array>
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace ikchain {

enum class GoalKind : uint8_t { kPosition = 0, kOrientation = 1, kAim = 2, kAimAt = 3 };

struct Goal {
  GoalKind kind = GoalKind::kPosition;
  // Which effector: 1..joint_count, joint_count = the tip (see chain.hpp). 0 means "the tip".
  int effector = 0;
  double weight = 1.0;  // > 0, relative importance (dimensionless)
  glm::dvec3 target_position{0.0};                   // kPosition, kAimAt: point in base space (m)
  glm::dquat target_orientation{1.0, 0.0, 0.0, 0.0};  // kOrientation (unit quaternion)
  glm::dvec3 aim_axis{0.0, 1.0, 0.0};                 // kAim, kAimAt: axis in the effector's frame
  glm::dvec3 aim_direction{0.0, 1.0, 0.0};            // kAim: desired direction (base frame) of aim_axis

  static Goal position(const glm::dvec3& p, int effector = 0, double weight = 1.0) {
    Goal g;
    g.kind = GoalKind::kPosition;
    g.target_position = p;
    g.effector = effector;
    g.weight = weight;
    return g;
  }
  static Goal orientation(const glm::dquat& q, int effector = 0, double weight = 1.0) {
    Goal g;
    g.kind = GoalKind::kOrientation;
    g.target_orientation = q;
    g.effector = effector;
    g.weight = weight;
    return g;
  }
  static Goal aim(const glm::dvec3& axis_local, const glm::dvec3& direction, int effector = 0,
                  double weight = 1.0) {
    Goal g;
    g.kind = GoalKind::kAim;
    g.aim_axis = axis_local;
    g.aim_direction = direction;
    g.effector = effector;
    g.weight = weight;
    return g;
  }
  // A 6-D pose of one effector as its two goals: position and orientation. The orientation goal
  // weighs characteristic_length^2 times the position goal, so that one radian of orientation
  // error costs as much as characteristic_length metres of position error (the objective adds
  // w_p |dp|^2 + w_o |angle|^2). A principled default is the chain's length (pose_goals() in
  // kinematics.hpp uses it): a radian then counts like the whole arm's reach, the distance the
  // tip sweeps when the chain turns by a radian about its root. Larger favours orientation.
  static std::array<Goal, 2> pose(const glm::dvec3& position_in_base, const glm::dquat& orientation_in_base,
                                  double characteristic_length, int effector = 0, double weight = 1.0) {
    return {Goal::position(position_in_base, effector, weight),
            Goal::orientation(orientation_in_base, effector, weight * characteristic_length * characteristic_length)};
  }

  // The effector's axis_local (its own frame) points at point_in_base.
  static Goal aim_at(const glm::dvec3& point_in_base, const glm::dvec3& axis_local, int effector = 0,
                     double weight = 1.0) {
    Goal g;
    g.kind = GoalKind::kAimAt;
    g.target_position = point_in_base;
    g.aim_axis = axis_local;
    g.effector = effector;
    g.weight = weight;
    return g;
  }
};

}  // namespace ikchain
