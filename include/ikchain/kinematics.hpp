// Forward kinematics of a chain, its effectors, goal errors and joint limits: what a caller reads
// a pose with. The Jacobian, the residual rows and the limits' active set are the solvers' own
// (src/core/kinematics_internal.hpp).
#pragma once
#include <array>

#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "ikchain/options.hpp"
#include "ikchain/so3.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

namespace ikchain {

// Fills ws.joint_origins, joint_orientations, joint_pre_rotations and ws.tip from params.
void forward_kinematics(const Chain& chain, const double* params, Workspace& ws);

// Local rotation R_i(params) of joint i (excluding its rest rotation). Inline: FK's inner loop.
inline glm::dquat joint_motion(const Chain& chain, int joint, const double* params) {
  const double* p = params + chain.dof_offset(joint);
  if (chain.joint_type(joint) == JointType::kPrismatic) return glm::dquat(1.0, 0.0, 0.0, 0.0);
  if (chain.joint_type(joint) == JointType::kHinge) {
    double s, c;
    so3::fast_sincos(0.5 * p[0], s, c);
    const glm::dvec3& a = chain.axis(joint);  // unit length (ChainBuilder)
    return glm::dquat(c, s * a.x, s * a.y, s * a.z);
  }
  return so3::exp(glm::dvec3(p[0], p[1], p[2]));
}

// Effector k in 1..n (0 = the tip); see chain.hpp. Valid after forward_kinematics().
int resolve_effector(const Chain& chain, int effector);
glm::dvec3 effector_position(const Chain& chain, const Workspace& ws, int effector);
// The frame of the bone ending at the effector; for the tip, the tip (tool) frame (chain.hpp).
glm::dquat effector_orientation(const Chain& chain, const Workspace& ws, int effector);
// kAimAt counts as met when the effector sits on the point: nearer to it than kAimAtOnPoint *
// (the chain's length + the point's distance from the base). Nearer, the direction to aim along
// would be mostly rounding: the positions it is taken from carry a few ulps of their magnitude,
// and the angle's error is that over the distance.
constexpr double kAimAtOnPoint = 1e-6;
// That radius for `goal` on `chain` (m): kAimAtOnPoint * (chain length + |point|).
double aim_at_on_point_radius(const Chain& chain, const Goal& goal);

// Goal::pose with the chain's length as the characteristic length, times rotation_weight (1: a
// radian of orientation error counts like one chain length of position error).
inline std::array<Goal, 2> pose_goals(const Chain& chain, const glm::dvec3& position_in_base,
                                      const glm::dquat& orientation_in_base, int effector = 0,
                                      double rotation_weight = 1.0) {
  return Goal::pose(position_in_base, orientation_in_base, rotation_weight * chain.total_length(), effector);
}

struct GoalErrors {
  double cost = 0.0;               // 0.5 * sum_g w_g |e_g|^2
  double combined = 0.0;           // sqrt(sum_g w_g |e_g|^2)
  double max_position = 0.0;       // worst position goal (m)
  double max_orientation = 0.0;    // worst orientation/aim goal (rad)
  bool within(const SolverOptions& o) const {
    return max_position <= o.position_tolerance && max_orientation <= o.orientation_tolerance;
  }
};

// The errors of `goals` (GoalErrors), after forward_kinematics().
GoalErrors measure_goals(const Chain& chain, Span<const Goal> goals, const Workspace& ws);

// Joint-space limits (hinge range, cone swing, twist range), one joint at a time: the one mechanism
// chains and trees share. `p` points at the joint's own params (1 or 3).
void project_joint_params(JointType type, const JointLimits& limits, double* p);
bool joint_within_limits(JointType type, const JointLimits& limits, const double* p, double slack = 1e-9);
// Joint-space limits (hinge range, cone swing, twist range): project params onto the feasible set.
void project_to_limits(const Chain& chain, double* params);
// The same for one joint (CCD and FABRIK apply limits joint by joint).
void project_joint_to_limits(const Chain& chain, int joint, double* params);
// How many of the chain's joints rest on a limit (joint_params_at_limit) at params.
int joints_at_limit(const Chain& chain, const double* params);
// True when every joint respects its limits within `slack` (rad).
bool within_limits(const Chain& chain, const double* params, double slack = 1e-9);

}  // namespace ikchain
