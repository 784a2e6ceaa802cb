// What the page's two flat objects, WebChain (web_chain.hpp) and WebTree (web_tree.hpp), share:
// the solver settings they expose, the checks on arrays the page hands in, joint limits from plain
// numbers, per-frame goal updates and the frames layout. One copy, so the two JS classes cannot
// drift apart. Header only: web_tree.cpp is also compiled natively for the core tests.
#pragma once
#include <cmath>
#include <string>

#include "ikchain/ikchain.hpp"

namespace ikchain {
namespace web {

// The settings both objects take from the page (validated by the solve, which names a bad field).
// bindings.cpp binds them once for both JS classes (bind_options()).
class WebOptions {
 public:
  void set_max_iterations(int n) { options_.max_iterations = n; }
  void set_tolerances(double position, double orientation) {
    options_.position_tolerance = position;
    options_.orientation_tolerance = orientation;
  }
  void set_warm_start(bool on) { options_.warm_start = on; }
  void set_time_budget_usec(double usec) { options_.time_budget_usec = usec; }
  // The core's safety cap on a solve's CPU time (SolverOptions::time_cap_usec, 0 = none).
  void set_time_cap_usec(double usec) { options_.time_cap_usec = usec; }
  const SolverOptions& options() const { return options_; }

 protected:
  SolverOptions options_;
};

// "" when `values` holds `expected` finite numbers, one per DOF; else a message starting with
// `what` (the caller keeps its previous state).
inline std::string check_dof_values(const char* what, const double* values, int count, int expected) {
  if (count != expected)
    return std::string(what) + ": expected " + std::to_string(expected) + " values (one per DOF), got " +
           std::to_string(count);
  for (int i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return std::string(what) + ": value " + std::to_string(i) + " is not finite";
  return "";
}

// A hinge's range (rad) when `limited`; otherwise the limits stay off.
inline void set_hinge_limits(JointLimits& limits, bool limited, double min_angle, double max_angle) {
  limits.has_hinge_limit = limited;
  if (limited) {
    limits.hinge_min = min_angle;
    limits.hinge_max = max_angle;
  }
}

// A ball's cone and twist range (rad) when `limited`; otherwise the limits stay off.
inline void set_ball_limits(JointLimits& limits, bool limited, double cone_angle, double twist_min,
                            double twist_max) {
  limits.has_cone_limit = limited;
  limits.has_twist_limit = limited;
  if (limited) {
    limits.cone_angle = cone_angle;
    limits.twist_min = twist_min;
    limits.twist_max = twist_max;
  }
}

// The per-frame updates of an existing goal both objects offer (CRTP: `Object::goal_at(index)` is
// goal `index`, or null). Each returns false, and sets nothing, when `index` is not a goal of
// that kind. bindings.cpp binds them once for both JS classes (bind_common()).
template <class Object>
class WebGoalUpdates {
 public:
  bool set_goal_position(int index, double x, double y, double z) {
    Goal* g = goal_of_kind(index, GoalKind::kPosition);
    if (g) g->target_position = glm::dvec3(x, y, z);
    return g != nullptr;
  }
  bool set_goal_orientation(int index, double qx, double qy, double qz, double qw) {
    Goal* g = goal_of_kind(index, GoalKind::kOrientation);
    if (g) g->target_orientation = glm::dquat(qw, qx, qy, qz);
    return g != nullptr;
  }
  bool set_goal_aim_direction(int index, double x, double y, double z) {
    Goal* g = goal_of_kind(index, GoalKind::kAim);
    if (g) g->aim_direction = glm::dvec3(x, y, z);
    return g != nullptr;
  }

 private:
  Goal* goal_of_kind(int index, GoalKind kind) {
    Goal* g = static_cast<Object*>(this)->goal_at(index);
    return g && g->kind == kind ? g : nullptr;
  }
};

// The goals the page adds, from plain numbers (quaternions x, y, z, w as three.js orders them).
inline Goal orientation_goal(double qx, double qy, double qz, double qw, int effector, double weight) {
  return Goal::orientation(glm::dquat(qw, qx, qy, qz), effector, weight);
}
inline Goal aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y, double dir_z,
                     int effector, double weight) {
  return Goal::aim(glm::dvec3(axis_x, axis_y, axis_z), glm::dvec3(dir_x, dir_y, dir_z), effector, weight);
}

// The frames layout the page reads: per joint its origin (x, y, z) and orientation (x, y, z, w)
// from out[0], then points (x, y, z) from out[7 n]. Returns where the points start.
inline double* write_joint_frames(const glm::dvec3* origins, const glm::dquat* orientations, int n, double* out) {
  for (int i = 0; i < n; ++i, out += 7) {
    const glm::dvec3& o = origins[i];
    const glm::dquat& q = orientations[i];
    out[0] = o.x, out[1] = o.y, out[2] = o.z;
    out[3] = q.x, out[4] = q.y, out[5] = q.z, out[6] = q.w;
  }
  return out;
}
inline void write_point(const glm::dvec3& p, double* out) { out[0] = p.x, out[1] = p.y, out[2] = p.z; }

}  // namespace web
}  // namespace ikchain
