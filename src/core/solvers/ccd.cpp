// Cyclic coordinate descent (CCD).
//
// Sources: Wang & Chen, "A combined optimization method for solving the inverse kinematics problem
// of mechanical manipulators", IEEE Trans. Robotics and Automation 7(4), 1991 (the per-joint
// closed-form optimum for position and orientation targets); Kenwright, "Inverse kinematics - cyclic
// coordinate descent (CCD)", Journal of Graphics Tools 16(4), 2012 (tip-to-root sweeps, limits
// applied per joint).
//
// One iteration = one sweep over the joints from the tip to the root. Each joint in turn takes the
// rotation that best serves the goals of the effectors after it, every other joint held fixed:
//  - each goal becomes vector pairs (current a -> desired b, seen from the joint's origin):
//    a position goal the pair (effector - o_j -> target - o_j), weight w; an orientation goal the
//    three frame axes (Q e_i -> T e_i), weight w/2 each (sum_i |w x e_i|^2 = 2|w|^2, so this
//    matches the objective's 0.5 w |angle|^2 for small errors); an aim goal (aim axis -> aim
//    direction), weight w. The joint maximises sum_g w_g b_g . R a_g (Wang & Chen's objective).
//  - a ball joint with one pair (the usual single position goal) gets the minimal rotation turning
//    a onto b; with several pairs the optimal rotation is Horn's quaternion (Horn 1987, "Closed-
//    form solution of absolute orientation using unit quaternions": the top eigenvector of a 4x4
//    symmetric matrix), taking among equally good rotations the one closest to no rotation.
//  - a hinge gets the closed-form angle about its axis (geometric::HingeFit).
// The joint's limits are applied right after its update (project_joint_to_limits), and the
// effectors after it are moved by the rotation actually applied, so one sweep costs O(n * goals)
// without recomputing forward kinematics per joint.
//
// Multi-goal sets: every goal is served at once by the weighted per-joint optimum above (each
// joint only sees goals on effectors after it). Up to kMaxGoals goals; more are rejected.
//
// Three additions to the textbook loop:
//  - A hinge right after a ball joint without cone or twist limits (a knee after its hip, an elbow
//    after its shoulder), one position goal after it: the hinge takes the angle that puts the
//    effector at the target's distance from the ball's origin (the law of cosines, as two_bone.cpp
//    and the triangulation of Mueller-Cajar & Mukundan, "Triangulation: a new algorithm for inverse
//    kinematics", IVCNZ 2007), and the ball, next in the sweep, turns the effector onto the target:
//    exact in one sweep. The textbook hinge step bends a nearly straight limb by only a small part
//    of what the distance needs each sweep, and not at all when the limb is straight with the
//    target on its line (a saddle): a tracked straight leg took a mean of 31 sweeps a frame (issue
//    16, item 13). Where no angle within the limits makes that distance (the ball's origin must
//    move first), the textbook step.
//  - Out of reach (one tip position goal at least the chain's length away) the optimum is the
//    straight chain toward the target, which CCD approaches only slowly (the lecture's CCD stopped
//    at 3.37 for an optimum of 2). The first iteration therefore aims every bone at the target,
//    root to tip (geometric::aim_chain_at_points); later sweeps only refine it under limits.
//  - CCD's fixed points include saddles: a straight chain with the target straight ahead but closer
//    gives every joint a == b in direction, so no joint moves. A sweep that moves no joint while
//    the goals are not met counts as stuck, like the stall rule (geometric::Progress, stuck.hpp):
//    the shared escape moves the pose and the sweeps go on.
// Termination: converged on tolerance; stalled when stuck with no escape left; otherwise the
// iteration budget. The best pose seen is returned.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {

namespace {

constexpr int kMaxGoals = kCcdMaxGoals;
// triangle_turn() applies when the hinge can change the ball-to-effector distance by more than this
// share of |o_j - o_{j-1}| |effector - o_j| (r / (|u| |v|) in triangle_turn(): the product of the
// sines of the angles the bone before the hinge and the effector make with its axis): a hinge
// twisting about the bone before it is left to the classic fit.
constexpr double kTriangleMinShare = 1e-3;
// ... and when some angle within the limits makes that distance to this share of what the hinge can
// change it by (2 r in triangle_turn(); rounding only).
constexpr double kTriangleMaxMiss = 1e-9;

// The hinge's triangle step (see the file comment): hinge j right after a ball joint j - 1 without
// cone or twist limits, one position goal after it. Takes the hinge angle that puts the effector
// at the target's distance from the ball's origin h: with the effector f, o = o_j, v = f - o split
// into v_par (along the unit axis k) and v_perp, w = k x v_perp and u = o - h, turning the hinge by
// t gives |f(t) - h|^2 = |u + v_par|^2 + |v_perp|^2 + 2 (A cos t + B sin t), A = u.v_perp,
// B = u.w, so A cos t + B sin t = C with C = (|target - h|^2 - |u + v_par|^2 - |v_perp|^2) / 2:
// t = atan2(B, A) +- acos(C / hypot(A, B)) (clamped: the nearest distance the hinge can make).
// Of the two solutions, and the bounds, the one within the limits whose distance is nearest the
// target's, then the smaller turn. Writes the turn into `turn` (rad, not yet applied); false when
// the step does not apply or the hinge barely changes that distance (then the classic fit).
bool triangle_turn(const Chain& chain, Span<const Goal> goals, const geometric::Tracked* tracked, int j,
                   const Workspace& ws, const double* params, double& turn) {
  if (j < 1 || chain.joint_type(j) != JointType::kHinge || chain.joint_type(j - 1) != JointType::kBall ||
      has_joint_limits(JointType::kBall, chain.limits(j - 1)) || goals.size != 1 ||
      goals[0].kind != GoalKind::kPosition || tracked[0].effector <= j)
    return false;
  const glm::dvec3 h = ws.joint_origins[j - 1], o = ws.joint_origins[j];
  const glm::dvec3 k = geometric::hinge_axis_in_base(chain, j, ws.joint_pre_rotations[j]);
  const glm::dvec3 v = tracked[0].position - o;
  const glm::dvec3 v_par = k * glm::dot(k, v), v_perp = v - v_par, w = glm::cross(k, v_perp), u = o - h;
  const double a = glm::dot(u, v_perp), b = glm::dot(u, w), r = std::hypot(a, b);
  // The hinge changes the distance by at most 2 r; below this share of |u| |v| it cannot steer it.
  if (!(r > kTriangleMinShare * glm::length(u) * glm::length(v))) return false;
  const glm::dvec3 to_target = goals[0].target_position - h;
  const double c =
      0.5 * (glm::dot(to_target, to_target) - glm::dot(u + v_par, u + v_par) - glm::dot(v_perp, v_perp));
  const double phi = std::atan2(b, a), alpha = std::acos(std::clamp(c / r, -1.0, 1.0));
  const JointLimits& l = chain.limits(j);
  const double q0 = params[chain.dof_offset(j)];
  // The angle actually reached by a turn of t (the limits applied as turn_hinge applies them).
  auto reached = [&](double t) { return l.has_hinge_limit ? std::clamp(q0 + t, l.hinge_min, l.hinge_max) - q0 : t; };
  const double candidates[4] = {geometric::wrap_angle(phi + alpha), geometric::wrap_angle(phi - alpha),
                                l.hinge_min - q0, l.hinge_max - q0};
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
  // A distance the hinge cannot make within its limits (the target beyond its reach from h, or
  // inside it): the ball's origin must move first, which the classic fit leaves room for (set
  // straight or fully folded here, a limb on its bound would ask for the stuck escape every sweep).
  return best_miss <= kTriangleMaxMiss * r;
}

// One tip-to-root sweep. ws holds forward kinematics of params on entry (the origins and frames
// before joint j do not change while joints >= j move). Returns the largest rotation applied (rad).
double sweep(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
             geometric::Tracked* tracked, double* params) {
  const int n = chain.joint_count();
  geometric::track_goals(chain, goals, ws, tracked);
  double largest = 0.0;
  for (int j = n - 1; j >= 0; --j) {
    if (ws.deadline.spent_after_joints(n - 1 - j)) break;  // the time budget, within a long sweep
    ws.deadline.charge(Deadline::kFlopsPerFit);
    const glm::dvec3 origin = ws.joint_origins[j];
    double triangle = 0.0;
    const glm::dquat applied =
        triangle_turn(chain, goals, tracked, j, ws, params, triangle)
            ? glm::angleAxis(geometric::turn_hinge(chain, j, triangle, options.max_step_angle, params),
                             geometric::hinge_axis_in_base(chain, j, ws.joint_pre_rotations[j]))
            : geometric::fit_joint(chain, goals, tracked, j, origin, ws.joint_pre_rotations[j],
                                   options.max_step_angle, params);
    largest = std::max(largest, glm::length(so3::log(applied)));
    for (int g = 0; g < goals.size; ++g) {
      if (tracked[g].effector <= j) continue;
      tracked[g].position = origin + applied * (tracked[g].position - origin);
      tracked[g].orientation = glm::normalize(applied * tracked[g].orientation);
    }
  }
  return largest;
}

}  // namespace

SolverStatus solve_ccd(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
                       double* params) {
  SolverStatus status;
  // solve() checked what CCD takes (no prismatic joints, at most kMaxGoals goals).
  geometric::Tracked tracked[kMaxGoals];
  const int n = chain.joint_count();
  // One tip position goal at or beyond full reach: straighten toward it first (see above).
  geometric::Progress progress(chain, goals, options, ws, params);
  status.reason = TerminationReason::kMaxIterations;
  // The time budget before every iteration: here before the first, in stop_after_iteration()
  // after each (kMaxIterations).
  while (status.iterations < options.max_iterations && !(status.iterations == 0 && ws.deadline.spent())) {
    double moved = INFINITY;
    if (status.iterations == 0 && progress.out_of_reach()) {
      for (int k = 1; k <= n; ++k) ws.points_aim[k] = goals[0].target_position;
      geometric::aim_chain_at_points(chain, ws, ws.points_aim.data(), options.max_step_angle, params, nullptr,
                                     &ws.deadline);
    } else {
      moved = sweep(chain, goals, options, ws, tracked, params);
    }
    ++status.iterations;
    if (progress.stop_after_iteration(params, moved, status.reason)) break;
  }
  progress.finish(status.reason, params);
  status.escapes = progress.escapes();
  return status;
}

}  // namespace ikchain
