// Cyclic coordinate descent on a tree.
//
// The chain CCD (ccd.cpp; Wang & Chen 1991, Kenwright 2012) generalised to several end effectors:
// one iteration = one sweep over the joints from the last to the first. Joints are stored parents
// first (tree.hpp), so this visits every joint after all of its descendants: leaf to root, one
// branch after another. Each joint in turn takes the rotation that best serves the goals on the
// effectors it supports (its subtree), every other joint held fixed, exactly as a chain joint
// serves the goals after it: the goals become weighted vector pairs seen from the joint's origin
// (geometric::goal_pairs), a ball takes Horn's optimal rotation (geometric::BallFit), a hinge the
// closed-form angle (geometric::HingeFit). Each pair's weight is the goal's weight times its
// level's (tree_common.hpp: priorities as weight ratios), so where branches pull a shared joint (a
// spine) different ways, the higher level's effectors win. The joint's limits are applied right
// after its update (turn_ball_params / turn_hinge_param: the mechanism chains use), and the goals'
// effectors in its subtree are moved by the rotation actually applied, so a sweep costs
// O(joints x goals) without recomputing forward kinematics: a joint's update moves only joints
// after it in the order, which the sweep has already visited.
// A hinge right after a ball without limits (IKBody's humanoid: knees after free hips, elbows
// after free shoulders), the only goal on the effectors it supports a position goal (or a pose goal
// whose rotation a free ball below takes: WristCentres), takes the
// chain CCD's triangle step instead of the classic fit (geometric::triangle_turn, ccd.cpp's file
// comment): the angle that puts the effector at the target's distance from the ball's origin, which
// the ball then turns onto the target. From straight legs the classic fit needed a mean of 46.9
// sweeps a frame (TreeCcd.BendsStraightLegsInFewIterations; now 1.0). The body bench's trees have
// no hinges: its ccd rows do not change.
// A floating root also translates, after its rotation: by the weighted mean of the position goals'
// remaining offsets (the translation that best serves them all; a wrist centre's for a partnered
// position goal, as every joint above the ball serves it).
// Prismatic joints are not taken (the solver table). The posture is ignored (no null space).
// Termination and stuck poses: tree_common::Progress (the stall rule, escapes, the best pose).
#include <cmath>

#include "core/solvers/geometric_common.hpp"
#include "core/solvers/tree_common.hpp"

namespace ikchain {
namespace {

// Pose goals on an effector whose own joint is a free ball (IKBody's humanoid: position and rotation
// on the foot or hand bone, no limits there): that ball can take any rotation, so the joints above
// it serve the position of its origin (the wrist centre) where the effector lands on its target at
// the target rotation, and leave the rotation to it (the decoupling of a spherical wrist, Pieper
// 1968). Without it the hips, knees and spine weighed the feet's rotations against their positions
// in every fit (TreeCcd.BendsStraightLegsWithFootRotationGoalsInFewIterations: 64 sweeps, the cap,
// feet up to 106 mm off).
struct WristCentres {
  int partner[kMaxTreeGoals];          // the position goal's orientation goal and back, or -1
  glm::dvec3 target[kMaxTreeGoals];    // for a partnered position goal: the wrist centre's target

  WristCentres(const Tree& tree, const TreeProblem& problem) {
    const int goals = problem.goals.size;
    for (int g = 0; g < goals; ++g) partner[g] = -1;
    for (int g = 0; g < goals; ++g) {
      const Goal& position = problem.goals[g].goal;
      if (position.kind != GoalKind::kPosition) continue;
      const int joint = tree.effector(position.effector).joint;
      if (tree.joint_type(joint) != JointType::kBall || has_joint_limits(JointType::kBall, tree.limits(joint))) continue;
      for (int o = 0; o < goals; ++o) {
        const Goal& orientation = problem.goals[o].goal;
        if (orientation.kind != GoalKind::kOrientation || orientation.effector != position.effector || partner[o] >= 0)
          continue;
        partner[g] = o;
        partner[o] = g;
        target[g] = centre(tree, position.effector, position.target_position, orientation.target_orientation);
        break;
      }
    }
  }
  // Where effector e's joint origin is when e is at `position` with `orientation`.
  static glm::dvec3 centre(const Tree& tree, int e, const glm::dvec3& position, const glm::dquat& orientation) {
    const TreeEffectorDesc& d = tree.effector(e);
    return position - (so3::normalized(orientation) * glm::conjugate(d.rotation)) * d.offset;
  }
  // Goal g seen from joint j, above its effector's joint (the ball): a partnered orientation goal
  // is the ball's alone; a partnered position goal is its wrist centre's.
  bool left_to_the_ball(const Tree& tree, const TreeProblem& problem, int g, int j) const {
    return partner[g] >= 0 && problem.goals[g].goal.kind == GoalKind::kOrientation &&
           tree.effector(problem.goals[g].goal.effector).joint != j;
  }
  // Goal g's point seen from joint j: a partnered position goal above its ball is its wrist
  // centre's (current: from the tracked pose; target: the centre's target), any other goal its
  // effector's (`current`, `target` as given). True when it is the centre's.
  bool centre_pair(const Tree& tree, const TreeProblem& problem, const geometric::Tracked& tracked, int g, int j,
                   glm::dvec3& current, glm::dvec3& target) const {
    if (partner[g] < 0 || problem.goals[g].goal.kind != GoalKind::kPosition ||
        tree.effector(problem.goals[g].goal.effector).joint == j)
      return false;
    current = centre(tree, tracked.effector, tracked.position, tracked.orientation);
    target = this->target[g];
    return true;
  }
};

// The chain's triangle step (ccd.cpp, geometric::triangle_turn) on a tree: hinge j right after a
// ball without limits (a knee after its hip, an elbow after its shoulder, as IKBody's humanoid has
// them), the only goal on the effectors it supports a position goal (a partnered one: its wrist
// centre, WristCentres). Writes the turn (rad, not yet applied) into `turn`; false when the step
// does not apply (then the classic fit).
bool triangle_turn(const Tree& tree, const TreeProblem& problem, const WristCentres& wrists,
                   const geometric::Tracked* tracked, const TreeWorkspace& ws, int j, const glm::dvec3& axis, double q0,
                   double& turn) {
  const int parent = tree.parent(j);
  if (parent < 0 || tree.joint_type(parent) != JointType::kBall ||
      has_joint_limits(JointType::kBall, tree.limits(parent)))
    return false;
  int only = -1;
  for (int g = 0; g < problem.goals.size; ++g) {
    const Goal& goal = problem.goals[g].goal;
    if (!tree.supports(goal.effector, j) || wrists.left_to_the_ball(tree, problem, g, j)) continue;
    if (only >= 0 || goal.kind != GoalKind::kPosition) return false;
    only = g;
  }
  if (only < 0) return false;
  glm::dvec3 current = tracked[only].position, target = problem.goals[only].goal.target_position;
  wrists.centre_pair(tree, problem, tracked[only], only, j, current, target);
  return geometric::triangle_turn(ws.joint_origins[parent], ws.joint_origins[j], axis, current, target, tree.limits(j), q0,
                                  turn);
}

double sweep(const Tree& tree, const TreeProblem& problem, const WristCentres& wrists, const SolverOptions& o,
             TreeWorkspace& ws, geometric::Tracked* tracked, double* params) {
  const int goals = problem.goals.size;
  for (int g = 0; g < goals; ++g) {
    const Goal& goal = problem.goals[g].goal;
    tracked[g].effector = goal.effector;
    tracked[g].position = tree_effector_position(tree, ws, goal.effector);
    tracked[g].orientation = tree_effector_orientation(tree, ws, goal.effector);
    tracked[g].aim_at_on_point = tree_aim_at_on_point(tree, goal);
  }
  double largest = 0.0;
  for (int j = tree.joint_count() - 1; j >= 0; --j) {
    if (ws.deadline.spent_after_joints(tree.joint_count() - 1 - j)) break;  // the time budget, within a sweep
    const glm::dvec3 origin = ws.joint_origins[j];
    const glm::dquat& pre = ws.joint_pre_rotations[j];
    double* p = params + tree.dof_offset(j);
    glm::dquat applied = geometric::kIdentity;
    auto each_goal = [&](auto&& add) {
      bool any = false;
      for (int g = 0; g < goals; ++g) {
        const TreeGoal& tg = problem.goals[g];
        if (!tree.supports(tg.goal.effector, j) || wrists.left_to_the_ball(tree, problem, g, j)) continue;
        any = true;
        const double lw = tree_common::level_weight(tg.level);
        glm::dvec3 centre, centre_target;
        if (wrists.centre_pair(tree, problem, tracked[g], g, j, centre, centre_target)) {
          add(centre - origin, centre_target - origin, lw * tg.goal.weight);
          continue;
        }
        geometric::goal_pairs(tg.goal, tracked[g], origin,
                              [&](const glm::dvec3& a, const glm::dvec3& b, double w) { add(a, b, lw * w); });
      }
      return any;
    };
    if (tree.joint_type(j) == JointType::kBall) {
      geometric::BallFit fit;
      each_goal([&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(a, b, w); });
      if (fit.pairs > 0) applied = geometric::turn_ball_params(tree.limits(j), pre, fit.rotation(), o.max_step_angle, p);
    } else {
      const glm::dvec3 axis = pre * tree.axis(j);
      double turn = 0.0;
      if (triangle_turn(tree, problem, wrists, tracked, ws, j, axis, p[0], turn)) {
        applied = glm::angleAxis(geometric::turn_hinge_param(tree.limits(j), turn, o.max_step_angle, p), axis);
      } else {
        geometric::HingeFit fit;
        if (each_goal([&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(axis, a, b, w); }))
          applied = glm::angleAxis(geometric::turn_hinge_param(tree.limits(j), fit.angle(), o.max_step_angle, p), axis);
      }
    }
    largest = std::max(largest, glm::length(so3::log(applied)));
    glm::dvec3 shift(0.0);
    if (j == 0 && tree.floating_root()) {  // the root's translation, after its rotation (see above)
      glm::dvec3 sum(0.0);
      double weight = 0.0;
      for (int g = 0; g < goals; ++g) {
        const TreeGoal& tg = problem.goals[g];
        if (tg.goal.kind != GoalKind::kPosition) continue;
        const double w = tree_common::level_weight(tg.level) * tg.goal.weight;
        glm::dvec3 current = tracked[g].position, target = tg.goal.target_position;
        wrists.centre_pair(tree, problem, tracked[g], g, j, current, target);
        sum += w * (target - (origin + applied * (current - origin)));
        weight += w;
      }
      if (weight > 0.0) shift = sum / weight;
      for (int d = 0; d < 3; ++d) params[d] += shift[d];
      largest = std::max(largest, glm::length(shift));
    }
    for (int g = 0; g < goals; ++g) {
      if (!tree.supports(tracked[g].effector, j)) continue;
      tracked[g].position = origin + applied * (tracked[g].position - origin) + shift;
      tracked[g].orientation = glm::normalize(applied * tracked[g].orientation);
    }
  }
  return largest;
}

}  // namespace

TreeSolverStatus solve_tree_ccd(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                TreeWorkspace& ws, double* params) {
  TreeSolverStatus status;
  geometric::Tracked tracked[kMaxTreeGoals];
  const WristCentres wrists(tree, problem);
  tree_common::Progress progress(tree, problem, options, ws, params);
  status.reason = TerminationReason::kMaxIterations;
  if (progress.met()) {
    status.reason = TerminationReason::kConverged;
    return status;
  }
  while (status.iterations < options.max_iterations && !(status.iterations == 0 && ws.deadline.spent())) {
    const double moved = sweep(tree, problem, wrists, options, ws, tracked, params);
    ++status.iterations;
    if (progress.stop_after_iteration(params, moved, status.reason)) break;
  }
  progress.finish(status.reason, params);
  status.escapes = progress.escapes();
  return status;
}

}  // namespace ikchain
