// FABRIK: forward and backward reaching inverse kinematics.
//
// Source: Aristidou & Lasenby, "FABRIK: A fast, iterative solver for the Inverse Kinematics
// problem", Graphical Models 73(5), 2011; Alg. 1 (the two reaching stages), sec. 4 (joint
// constraints re-applied while iterating), sec. 5 (several end effectors: sub-bases).
//
// FABRIK works on positions: the points p_0..p_n (joint origins and the tip) with fixed bone
// lengths l_i = |p_{i+1} - p_i|. One iteration = one forward + one backward stage:
//  - forward reaching (tip to root, ws.points_aim): the tip is placed on its target, then each point
//    p_i is pulled to distance l_i from the point after it, along the line to its old position
//    (ws.points_current = forward kinematics of the current params);
//  - backward reaching (root to tip), fused with the conversion back to joint parameters: the root
//    stays at o_0 and each joint j, in turn, turns so that its bone points at the forward-reaching
//    point p_{j+1} (geometric::aim_chain_at_points). A ball joint takes the minimal rotation from its
//    current bone direction (so a warm start keeps its twist); a hinge the angle that best aligns
//    the next two points projected on the plane perpendicular to its axis. Each joint is projected
//    onto its limits right after its update, and the next joint starts from where the chain
//    actually is, so the constraints feed into the rest of the stage (the paper's per-joint
//    re-positioning, sec. 4.2). Forward kinematics of the resulting params then gives the exact
//    pose - points and parameters never disagree.
//    For an unconstrained ball chain this is exactly the paper's backward stage.
//  - knees and elbows (a hinge right after a ball, planar) keep their bend plane and side from the
//    warm pose: the forward stage places the hinge's point in that plane by the law of cosines
//    (keep_bend_plane), and the ball's twist before a hinge is damped toward none
//    (geometric::kTwistDamping): tracked limbs no longer flip their hinge's plane (issue 16,
//    item 18). Not in the paper, whose constraints act in the backward stage only.
//  - out of reach (one tip position goal at least the chain's length from the root), the first
//    iteration aims every bone at the target: the straight line toward it, the optimum (Alg. 1,
//    lines 4-9). Later iterations only matter under limits or hinges.
//  - a straight chain with the target straight ahead but closer is a fixed point (every forward-
//    reaching point lands on the chain's own line); an iteration that changes no parameter while
//    the goals are not met counts as stuck, like the stall rule (geometric::Progress, stuck.hpp):
//    the shared escape moves the pose and the iterations go on.
//
// Goal sets. FABRIK is a positional method:
//  - position goals on any effector are supported: the tip goal (if any) anchors the forward stage,
//    and a position goal on an intermediate effector k pins p_k to its target during the forward
//    stage (a sub-base, sec. 5; several goals on one effector pin it to their weighted mean). Goal
//    weights only matter between goals on the same effector.
//  - orientation, aim and aim-at goals on the tip (the tip frame, chain.hpp) are pursued the way
//    FABRIK's orientation extensions do it: an orientation goal T fixes the last joint's frame,
//    F = T conj(tip_rotation) (the heaviest such goal wins), hence where the last joint must be,
//    o_{n-1} = tip - F tip_offset, so the forward stage pins p_{n-1} there (after the tip). For a
//    last hinge F also fixes its axis, F axis(n-1), which the frame before it carries: the forward
//    stage pins p_{n-2} on its circle about that axis (last_hinge_circle_pin), and the backward
//    stage fits one more point, on the axis at axis_point_distance() from o_{n-1}, into every
//    joint before it. Without them a tool frame on the last hinge's origin (tip_offset 0, the
//    xArm7) left the orientation to the last joint's twist alone (docs/solvers.md). After the
//    backward stage the last joint takes the rotation that best serves every tip goal (CCD's
//    per-joint fit, geometric::fit_joint: the twist about its axis and any aim). On an
//    intermediate effector they are rejected (kInvalidInput, the message names the goal): turning
//    a middle joint to an orientation would move everything after it, which FABRIK's stages do
//    not model. Use CCD or the Jacobian solvers.
// Termination: converged on tolerance; stalled when stuck with no escape left (the shared stall
// rule measures progress against the best cost, so FABRIK's non-monotone cost on hinge chains
// needs no window of its own); otherwise the budget. The best pose seen is returned.
#include <algorithm>
#include <cmath>

#include "core/kinematics_internal.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {

namespace {

constexpr int kMaxGoals = kFabrikMaxGoals;

// Weighted mean of the position goals on effector k (1..n); false when there are none.
bool pinned_target(const Chain& chain, Span<const Goal> goals, int k, glm::dvec3& out) {
  double weight = 0.0;
  glm::dvec3 sum(0.0);
  for (int g = 0; g < goals.size; ++g) {
    if (goals[g].kind != GoalKind::kPosition || resolve_effector(chain, goals[g].effector) != k) continue;
    sum += goals[g].weight * goals[g].target_position;
    weight += goals[g].weight;
  }
  if (!(weight > 0.0)) return false;
  out = sum / weight;
  return true;
}

// The last joint's frame Q_{n-1} = T conj(tip_rotation) that the heaviest tip orientation goal T
// asks for; false when there is none.
bool last_frame_target(const Chain& chain, Span<const Goal> goals, glm::dquat& out) {
  const int n = chain.joint_count();
  const Goal* heaviest = nullptr;
  for (int g = 0; g < goals.size; ++g)
    if (goals[g].kind == GoalKind::kOrientation && resolve_effector(chain, goals[g].effector) == n &&
        (!heaviest || goals[g].weight > heaviest->weight))
      heaviest = &goals[g];
  if (!heaviest) return false;
  out = so3::normalized(heaviest->target_orientation) * glm::conjugate(chain.tip_rotation());
  return true;
}

// How far along the last hinge's axis (from its origin) the point standing for the axis's direction
// lies: the mean bone length, so in the backward stage's least-squares fits it counts like the
// chain's own points.
double axis_point_distance(const Chain& chain) { return chain.total_length() / chain.joint_count(); }

// p_{n-2} pinned for a last hinge whose axis the orientation goal fixes (last_frame, in base):
// o_{n-2} = o_{n-1} - pre_{n-1} u with u = conj(rest_rotation) offset_translation of the last joint,
// and pre_{n-1} = Q_{n-1} R(axis, -theta): a circle about the target axis through o_{n-1}. The pin
// is its point nearest the old p_{n-2} (the forward stage's "pull toward the old position").
glm::dvec3 last_hinge_circle_pin(const Chain& chain, const glm::dquat& last_frame, const glm::dvec3& last_origin,
                                 const glm::dvec3& old_point, const glm::dvec3& old_last_origin) {
  const int j = chain.joint_count() - 1;
  const glm::dvec3 axis_local = chain.axis(j);
  const glm::dvec3 u = glm::conjugate(chain.rest_rotation(j)) * chain.offset_translation(j);
  const double along = glm::dot(u, axis_local);
  const double radius = glm::length(u - axis_local * along);
  const glm::dvec3 axis = last_frame * axis_local;
  const glm::dvec3 center = last_origin - axis * along;
  glm::dvec3 out_dir;
  if (!geometric::perpendicular_part(old_point - center, axis, 1e-12 * chain.total_length(), out_dir) &&
      !geometric::perpendicular_part(old_point - old_last_origin, axis, 1e-12 * chain.total_length(), out_dir))
    out_dir = geometric::any_perpendicular(axis);
  return center + out_dir * radius;
}

// The cosine below which a bone counts as perpendicular to a hinge's axis (keep_bend_plane).
constexpr double kPlanarCosine = 1e-6;

// Which hinges keep_bend_plane() places: hinge i right after a ball; or the last joint, a hinge
// right after a hinge that follows a ball (an elbow after an upper arm hinged to a collarbone ball:
// the ball's twist about the bone between them swivels the middle hinge's plane, so the two still
// aim bone i - 1 anywhere about o_{i-1}). Applied to more hinges after hinges (every one, or every
// one after a hinge after a ball), FABRIK reached fewer targets on limited hinge and mixed chains
// (the 7-hinge chain of FABRIK.LimitsNeverViolatedAndFeasibleTargetsReached 0.807 -> 0.777; the
// mixed7_restarts golden row no longer converged).
bool keeps_bend_plane(const Chain& chain, int i) {
  const int n = chain.joint_count();
  if (i < 1 || chain.joint_type(i) != JointType::kHinge) return false;
  if (chain.joint_type(i - 1) == JointType::kBall) return true;
  return i == n - 1 && i >= 2 && chain.joint_type(i - 1) == JointType::kHinge &&
         chain.joint_type(i - 2) == JointType::kBall;
}

// A knee's or elbow's bend plane and side kept from the warm pose (issue 16, items 13 and 18). A
// position goal leaves a limb free to swivel about the line from its hip h = o_{i-1} to its target;
// the textbook forward stage picks the swivel from where the target moved (it pulls b_i toward its
// old place along the line from b_{i+1}), and the ball's twist in the backward stage
// (aim_chain_at_points) then turned the hinge's plane there: by up to 180 deg in one frame for a
// straight limb bending by a degree or two. For hinge i (keeps_bend_plane) whose bones are both
// perpendicular to its axis k (a planar limb), b_i goes instead into the plane through h that
// contains the line from h to b_{i+1} and is nearest the current bend plane (normal: k without its
// part along that line), on the side of that line the hinge bends to now (straight: the side its
// bound allows), at l_{i-1} from h and l_i from b_{i+1} (the law of cosines, as two_bone.cpp: the
// backward stage then only turns the limb in that plane, and a ball + hinge limb reaches in one
// iteration). Where no triangle closes (b_{i+1} beyond l_{i-1} + l_i from h, or nearer than their
// difference), the textbook point projected into that plane and mirrored to that side. The other
// hinges, and non-planar ones, keep the textbook point.
void keep_bend_plane(const Chain& chain, const Workspace& ws, const double* params, int i, glm::dvec3& b_i,
                     const glm::dvec3& b_next) {
  const int n = chain.joint_count();
  if (!keeps_bend_plane(chain, i)) return;
  const glm::dvec3 h = ws.joint_origins[i - 1], o = ws.joint_origins[i];
  const glm::dvec3 next = i + 1 < n ? ws.joint_origins[i + 1] : ws.tip;
  const glm::dvec3 k = geometric::hinge_axis_in_base(chain, i, ws.joint_pre_rotations[i]);
  const glm::dvec3 before = o - h, after = next - o;
  const double lb = glm::length(before), la = glm::length(after);
  if (!(lb > 0.0) || !(la > 0.0) || std::abs(glm::dot(k, before)) > kPlanarCosine * lb ||
      std::abs(glm::dot(k, after)) > kPlanarCosine * la)
    return;
  const double tiny = 1e-12 * chain.total_length();
  const double reach = glm::length(b_next - h);
  if (!(reach > tiny)) return;
  const glm::dvec3 line = (b_next - h) / reach;
  glm::dvec3 normal;
  if (!geometric::perpendicular_part(k, line, kPlanarCosine, normal)) return;  // k along the line
  const glm::dvec3 x = b_i - normal * glm::dot(normal, b_i - h);
  // The side: the sign of k . (before x after) now; straight, the one the hinge's bound allows.
  const double bend = glm::dot(k, glm::cross(before, after)) / (lb * la);
  double side = 0.0;
  if (std::abs(bend) > geometric::Progress::kStraightSine)
    side = bend > 0.0 ? 1.0 : -1.0;
  else if (hinge_blocked(chain, i, params, -1.0))
    side = 1.0;
  else if (hinge_blocked(chain, i, params, 1.0))
    side = -1.0;
  // In the plane, off the line toward the side: for k . (before x after) > 0 the hinge's origin
  // lies on the side of line x normal (before = x - h, after = b_next - x, both in the plane).
  const glm::dvec3 off_line = glm::cross(line, normal);
  const double x_side = glm::dot(off_line, x - h);
  const double sign = side != 0.0 ? side : (x_side >= 0.0 ? 1.0 : -1.0);
  // Where the hinge's origin must be for the limb to reach b_next from h (the law of cosines, as
  // two_bone.cpp): at l_{i-1} from h and l_i from b_next. Out of that range, the textbook point
  // in the plane (mirrored to the side).
  const double l1 = chain.bone_length(i - 1), l2 = chain.bone_length(i);
  if (reach <= l1 + l2 && reach >= std::abs(l1 - l2)) {
    const double along = (reach * reach + l1 * l1 - l2 * l2) / (2.0 * reach);
    const double height = std::sqrt(std::max(l1 * l1 - along * along, 0.0));
    b_i = h + line * along + off_line * (sign * height);
    return;
  }
  const glm::dvec3 rel = x - h;
  const glm::dvec3 mirrored = x_side * sign < 0.0 ? h + line * (2.0 * glm::dot(line, rel)) - rel : x;
  const glm::dvec3 dir = mirrored - b_next;
  const double len = glm::length(dir);
  if (len > tiny) b_i = b_next + dir * (l2 / len);
}

// Forward reaching stage into ws.points_aim[1..n] from the current points ws.points_current. `last_frame`:
// the last joint's target frame (last_frame_target), or null.
void forward_reaching(const Chain& chain, Span<const Goal> goals, const glm::dquat* last_frame, const double* params,
                      Workspace& ws) {
  const int n = chain.joint_count();
  const glm::dvec3* a = ws.points_current.data();
  glm::dvec3* b = ws.points_aim.data();
  if (!pinned_target(chain, goals, n, b[n])) b[n] = a[n];
  const bool last_hinge = chain.joint_type(n - 1) == JointType::kHinge;
  for (int i = n - 1; i >= 1; --i) {
    glm::dvec3 pin;
    if (pinned_target(chain, goals, i, pin)) {
      b[i] = pin;
      continue;
    }
    if (last_frame && i == n - 1) {  // the tip offset seen from the target frame
      b[i] = b[n] - *last_frame * chain.tip_offset();
      continue;
    }
    if (last_frame && last_hinge && i == n - 2) {
      b[i] = last_hinge_circle_pin(chain, *last_frame, b[n - 1], a[i], a[n - 1]);
      continue;
    }
    glm::dvec3 dir = a[i] - b[i + 1];
    double len = glm::length(dir);
    if (!(len > 1e-12 * chain.total_length())) {  // on top of each other: keep the old bone direction
      dir = a[i] - a[i + 1];
      len = glm::length(dir);
    }
    b[i] = len > 0.0 ? b[i + 1] + dir * (chain.bone_length(i) / len) : b[i + 1];
    keep_bend_plane(chain, ws, params, i, b[i], b[i + 1]);
  }
}

}  // namespace

SolverStatus solve_fabrik(const Chain& chain, Span<const Goal> goals, const SolverOptions& options,
                          Workspace& ws, double* params) {
  SolverStatus status;
  // solve() checked what the solver table says FABRIK takes (no prismatic joints, orientation and
  // aim goals on the tip only, at most kMaxGoals goals with them).
  const int n = chain.joint_count();
  bool tip_frame_goals = false;
  for (int g = 0; g < goals.size; ++g) tip_frame_goals = tip_frame_goals || goals[g].kind != GoalKind::kPosition;
  glm::dquat last_frame;
  const bool has_last_frame = last_frame_target(chain, goals, last_frame);
  const bool fit_last_axis = has_last_frame && chain.joint_type(n - 1) == JointType::kHinge;
  // The last hinge's axis point, from its origin: where it is now (the axis at the current pose)
  // and where the target frame wants it (the same offset along last_frame's axis).
  const double axis_distance = fit_last_axis ? axis_point_distance(chain) : 0.0;
  const glm::dvec3 desired_axis_offset =
      fit_last_axis ? last_frame * chain.axis(n - 1) * axis_distance : glm::dvec3(0.0);
  geometric::Tracked tracked[kMaxGoals];
  geometric::Progress progress(chain, goals, options, ws, params);
  status.reason = TerminationReason::kMaxIterations;
  // The time budget before every iteration: here before the first, in stop_after_iteration()
  // after each (kMaxIterations).
  while (status.iterations < options.max_iterations && !(status.iterations == 0 && ws.deadline.spent())) {
    if (status.iterations == 0 && progress.out_of_reach()) {
      for (int k = 1; k <= n; ++k) ws.points_aim[k] = goals[0].target_position;
    } else {
      for (int k = 0; k < n; ++k) ws.points_current[k] = ws.joint_origins[k];
      ws.points_current[n] = ws.tip;
      forward_reaching(chain, goals, has_last_frame ? &last_frame : nullptr, params, ws);
    }
    std::copy(params, params + chain.dof_count(), ws.params_trial.data());
    geometric::PointPair axis_point;  // the last hinge's axis: where it is, where the goal wants it
    if (fit_last_axis) {
      axis_point.old_in_base =
          ws.joint_origins[n - 1] +
          geometric::hinge_axis_in_base(chain, n - 1, ws.joint_pre_rotations[n - 1]) * axis_distance;
      axis_point.desired_in_base = ws.points_aim[n - 1] + desired_axis_offset;
    }
    geometric::aim_chain_at_points(chain, ws, ws.points_aim.data(), options.max_step_angle, params,
                                   fit_last_axis ? &axis_point : nullptr, &ws.deadline);
    if (tip_frame_goals && !ws.deadline.hit) {  // final alignment of the last joint (see above)
      forward_kinematics(chain, params, ws);
      geometric::track_goals(chain, goals, ws, tracked);
      geometric::fit_joint(chain, goals, tracked, n - 1, ws.joint_origins[n - 1], ws.joint_pre_rotations[n - 1],
                           options.max_step_angle, params);
    }
    ++status.iterations;
    double moved = 0.0;
    for (int d = 0; d < chain.dof_count(); ++d)
      moved = std::max(moved, std::abs(params[d] - ws.params_trial[d]));
    if (progress.stop_after_iteration(params, moved, status.reason)) break;
  }
  progress.finish(status.reason, params);
  status.escapes = progress.escapes();
  return status;
}

}  // namespace ikchain
