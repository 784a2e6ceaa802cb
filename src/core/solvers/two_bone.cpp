// Analytic two-bone IK (shoulder-elbow-wrist, hip-knee-ankle): exact in one step.
//
// The tip's distance from the root o_0 depends only on the elbow (joint 1); the root (joint 0) then
// turns the whole triangle root-elbow-tip so that the tip lies on the root->target ray. The
// triangle follows from the law of cosines, |tip - o_0|^2 = l1^2 + l2^2 + 2 u.v (u = bone 1 =
// o_1 - o_0, v = bone 2 = tip - o_1); see e.g. Kenwright, "Two-Joint Inverse Kinematics" (2012),
// and ozz-animation's IKTwoBoneJob for the same decomposition with a pole ("mid axis") vector.
//
//  1. d = |target - o_0| clamped to [|l1 - l2|, l1 + l2]: beyond reach the chain ends straight
//     toward the target (distance |target - o_0| - L, the best reach); too close it folds as far
//     as it can (|l1 - l2| from the root, toward the target).
//  2. Elbow. A ball elbow turns bone 2 by the minimal rotation, within the current bend plane
//     (plane of u, v), to the exterior angle acos((d^2 - l1^2 - l2^2) / (2 l1 l2)). A straight or
//     folded elbow has no bend plane: it bends away from the pole (the elbow then lies on the
//     pole's side of the root-tip line, and step 3 need not twist the limb about that line), else
//     toward the target, else along a perpendicular of the root's rest frame (stable frame to
//     frame). A hinge elbow can only turn about its axis w: u.R(phi)v = A + B cos(phi) + C sin(phi),
//     solved for phi in closed form; of the two solutions the one within the hinge limits (clamped
//     when none is) that gives the closest distance wins, ties going to the smaller change
//     (continuity) - from a straight start with a pole, to the one that bends away from the pole.
//  3. Root. Without a pole: the minimal rotation taking tip - o_0 onto the target direction (the
//     bend plane turns as little as possible - "keep the current bend plane"). With a pole
//     (options.use_pole, pole_in_base): the rotation taking the frame
//     (tip direction, elbow side) onto (target direction, pole side), which puts the elbow in the
//     plane root-target-pole on the pole's side. A pole on the root-target line gives no plane: the
//     no-pole rule applies. A hinge root can only turn about its axis: it turns to the angle that
//     best aims the tip (exact only when the target lies on the circle it can sweep; best effort).
// Limits are applied to each joint right after its update; with active limits the pose is a best
// effort and the result reports the measured error. Iterations = 1. When the pose after the step is
// worse than the start (only possible with limits or a hinge root), the start is kept.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {

namespace {

// Hinge elbow: the change of angle phi about the unit base-frame axis `w` making |u + R(phi) v| closest
// to d, within the hinge limits. u.R(phi)v = A + B cos(phi) + C sin(phi) (Rodrigues).
// `away`: when nonzero (a straight start with a pole), a unit direction perpendicular to u that the
// lower bone should bend toward, so that the elbow ends on the other side - the pole's - of the
// root-tip line; between two equally close solutions it decides instead of the smaller change.
double hinge_elbow_delta(const Chain& chain, const glm::dvec3& w, const glm::dvec3& u,
                         const glm::dvec3& v, double d, const double* params, const glm::dvec3& away) {
  const double l1 = glm::length(u), l2 = glm::length(v);
  const double A = glm::dot(u, w) * glm::dot(v, w);
  const double B = glm::dot(u, v) - A;
  const double C = glm::dot(u, glm::cross(w, v));
  const double R = std::hypot(B, C);
  if (!(R > 1e-12 * l1 * l2)) return 0.0;  // the hinge cannot change the distance (axis along a bone)
  const double K = 0.5 * (d * d - l1 * l1 - l2 * l2);
  const double psi = std::atan2(C, B);
  const double a = std::acos(std::clamp((K - A) / R, -1.0, 1.0));
  const double current = params[chain.dof_offset(1)];
  const JointLimits& lim = chain.limits(1);
  const bool limited = chain.has_limits(1);
  double best_delta = 0.0, best_error = INFINITY, best_side = 0.0;
  for (double candidate : {psi + a, psi - a}) {
    double delta = geometric::wrap_angle(candidate);
    if (limited) delta = std::clamp(current + delta, lim.hinge_min, lim.hinge_max) - current;
    const double dist2 = l1 * l1 + l2 * l2 + 2.0 * (A + B * std::cos(delta) + C * std::sin(delta));
    const double error = std::abs(std::sqrt(std::max(dist2, 0.0)) - d);
    const double tie = 1e-12 * (l1 + l2);
    // The lower bone turned by delta (Rodrigues about w), toward `away` or not.
    const double side = glm::dot(v * std::cos(delta) + glm::cross(w, v) * std::sin(delta) +
                                     w * (glm::dot(w, v) * (1.0 - std::cos(delta))),
                                 away);
    const bool better_tie = glm::dot(away, away) > 0.0 ? side > best_side + tie
                                : std::abs(delta) < std::abs(best_delta);
    if (error < best_error - tie || (error <= best_error + tie && better_tie)) {
      best_error = std::min(best_error, error);
      best_delta = delta;
      best_side = side;
    }
  }
  return best_delta;
}

// Rotation taking the orthonormal pair (x, y) onto (x_to, y_to).
glm::dquat frame_rotation(const glm::dvec3& x, const glm::dvec3& y, const glm::dvec3& x_to,
                          const glm::dvec3& y_to) {
  const glm::dmat3 from(x, y, glm::cross(x, y));
  const glm::dmat3 to(x_to, y_to, glm::cross(x_to, y_to));
  return glm::normalize(glm::quat_cast(to * glm::transpose(from)));
}

}  // namespace

SolverStatus solve_two_bone(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                            Workspace& ws, double* params) {
  SolverStatus status;
  // solve() checked what two-bone takes (2 rotational joints, one position goal on the tip).
  status.iterations = 1;
  const glm::dvec3 target = goals[0].target_position;
  const glm::dvec3 pole = options.pole_in_base;
  forward_kinematics(chain, params, ws);
  geometric::BestPose best;
  best.init(chain, ws, params, measure_goals(chain, goals, ws).cost);

  const glm::dvec3 root = ws.joint_origins[0];
  const double l1 = chain.bone_length(0), l2 = chain.bone_length(1);
  const double tiny = 1e-12 * chain.total_length();
  const glm::dquat rest_frame = ws.joint_pre_rotations[0];  // pose-independent (the base's)
  const glm::dvec3 to_target = target - root;
  const double dist = glm::length(to_target);
  // The target direction; a target on the root leaves it free: keep the tip's (or elbow's) one.
  glm::dvec3 dir = rest_frame * glm::dvec3(0, 1, 0);
  if (dist > tiny) dir = to_target / dist;
  else if (glm::length(ws.tip - root) > tiny) dir = glm::normalize(ws.tip - root);
  else if (glm::length(ws.joint_origins[1] - root) > tiny) dir = glm::normalize(ws.joint_origins[1] - root);
  const double d = std::clamp(dist, std::abs(l1 - l2), l1 + l2);

  // 2. Elbow: set |tip - o_0| = d.
  if (l1 > tiny && l2 > tiny) {
    const glm::dvec3 u = ws.joint_origins[1] - root;
    const glm::dvec3 v = ws.tip - ws.joint_origins[1];
    const glm::dquat& pre1 = ws.joint_pre_rotations[1];
    const glm::dvec3 u_dir = u / l1;
    glm::dvec3 side;
    // A straight (or folded) elbow has no bend plane of its own. With a pole, the lower bone bends
    // away from the pole as the limb will see it once the root has swung it onto the target
    // direction (the pole's offset from the root-target line, turned back by that minimal swing):
    // the elbow then ends on the pole's side of the line and the root's turn below is that swing
    // plus a turn within the bend plane, no twist about the limb. (Bending toward the pole put the
    // elbow on the far side, and the root then turned the limb 180 deg about the line: positions
    // right, the upper bone twisted, knee caps facing backwards - issue 16, item 17.)
    const bool straight = !geometric::perpendicular_part(v, u_dir, tiny, side);
    glm::dvec3 away(0.0);
    bool pole_side_known = false;
    if (straight && options.use_pole) {
      const glm::dvec3 limb = glm::length(ws.tip - root) > tiny ? ws.tip - root : u;
      glm::dvec3 pole_off;
      if (geometric::perpendicular_part(pole - root, dir, tiny, pole_off)) {
        const glm::dvec3 seen = glm::conjugate(geometric::rotation_between(limb, dir)) * pole_off;
        pole_side_known = geometric::perpendicular_part(-seen, u_dir, tiny, away);
      }
    }
    if (chain.joint_type(1) == JointType::kBall) {
      if (pole_side_known) {
        side = away;
      } else if (straight && !geometric::perpendicular_part(to_target, u_dir, tiny, side) &&
                 !geometric::perpendicular_part(rest_frame * glm::dvec3(1, 0, 0), u_dir, 1e-6, side)) {
        side = geometric::any_perpendicular(u_dir);
      }
      const double cos_bend = std::clamp((d * d - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0);
      const double sin_bend = std::sqrt(std::max(0.0, 1.0 - cos_bend * cos_bend));
      const glm::dvec3 v_new = l2 * (cos_bend * u_dir + sin_bend * side);
      geometric::turn_ball(chain, 1, pre1, geometric::rotation_between(v, v_new), 0.0, params);
    } else {
      const glm::dvec3 w = geometric::hinge_axis_in_base(chain, 1, pre1);
      geometric::turn_hinge(chain, 1, hinge_elbow_delta(chain, w, u, v, d, params, away), 0.0, params);
    }
    forward_kinematics(chain, params, ws);
  }

  // 3. Root: turn the triangle onto the target direction (and the pole plane).
  {
    const glm::dvec3 p = ws.tip - root;
    const glm::dvec3 u = ws.joint_origins[1] - root;
    const glm::dquat& pre0 = ws.joint_pre_rotations[0];
    if (chain.joint_type(0) == JointType::kBall) {
      glm::dquat turn = geometric::rotation_between(p, dir);
      glm::dvec3 pole_side, elbow_side;
      if (options.use_pole && geometric::perpendicular_part(pole - root, dir, tiny, pole_side)) {
        const double plen = glm::length(p);
        if (plen > tiny && geometric::perpendicular_part(u, p / plen, tiny, elbow_side))
          turn = frame_rotation(p / plen, elbow_side, dir, pole_side);
        else if (!(plen > tiny))  // tip on the root: only the elbow's direction is left to choose
          turn = geometric::rotation_between(u, pole - root);
      }
      geometric::turn_ball(chain, 0, pre0, turn, 0.0, params);
    } else {
      const glm::dvec3 w = geometric::hinge_axis_in_base(chain, 0, pre0);
      geometric::HingeFit fit;
      fit.add(w, p, dir, 1.0);
      geometric::turn_hinge(chain, 0, fit.angle(), 0.0, params);
    }
  }

  forward_kinematics(chain, params, ws);
  const GoalErrors err = measure_goals(chain, goals, ws);
  if (!best.offer(chain, ws, params, err.cost) && err.cost > best.cost) {
    best.restore(chain, ws, params);
    forward_kinematics(chain, params, ws);
  }
  status.reason = measure_goals(chain, goals, ws).within(options) ? TerminationReason::kConverged
                                                                  : TerminationReason::kStalled;
  return status;
}

}  // namespace ikchain
