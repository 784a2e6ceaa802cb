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

// The hinge's triangle step (see the file comment; geometric::triangle_turn): hinge j right after
// a ball joint j - 1 without cone or twist limits, one position goal after it. Writes the turn
// into `turn` (rad, not yet applied); false when the step does not apply (then the classic fit).
bool triangle_turn(const Chain& chain, Span<const Goal> goals, const geometric::Tracked* tracked, int j,
                   const Workspace& ws, const double* params, double& turn) {
  if (j < 1 || chain.joint_type(j) != JointType::kHinge || chain.joint_type(j - 1) != JointType::kBall ||
      has_joint_limits(JointType::kBall, chain.limits(j - 1)) || goals.size != 1 ||
      goals[0].kind != GoalKind::kPosition || tracked[0].effector <= j)
    return false;
  return geometric::triangle_turn(ws.joint_origins[j - 1], ws.joint_origins[j],
                                  geometric::hinge_axis_in_base(chain, j, ws.joint_pre_rotations[j]),
                                  tracked[0].position, goals[0].target_position, chain.limits(j),
                                  params[chain.dof_offset(j)], turn);
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
