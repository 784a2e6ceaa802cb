// FABRIK on a tree: several end effectors by Aristidou & Lasenby's sub-base scheme.
//
// Source: Aristidou & Lasenby, "FABRIK: A fast, iterative solver for the Inverse Kinematics
// problem", Graphical Models 73(5), 2011: Alg. 1 (the two reaching stages), sec. 4.2 (constraints
// re-applied joint by joint), sec. 5 (multiple end effectors: sub-bases). The chain version,
// fabrik.cpp, explains the fused conversion back to joint parameters this file generalises.
//
// Points: every joint origin the goals depend on and every effector carrying a position goal, each
// at a fixed distance from its parent point (the bone: |offset_in_parent|, or the effector's
// |offset|). Each point carries the weight of the position goals below it (goal weight x level
// weight, tree_common.hpp: priorities as weight ratios). One iteration:
//  - forward stage (from the effectors toward the root, ws.points_forward): an effector point is placed on
//    its target (the weighted mean of its position goals), a joint point is pulled from each of its
//    children toward its old position to the bone's length, and a sub-base (a joint several
//    targeted branches meet at: the chest, the hips) takes the centroid of its branches' proposals,
//    weighted by their goals (A&L sec. 5 take the plain centroid; the weights are what makes a
//    level-1 foot outweigh a level-2 hand). A joint is pinned instead where a goal fixes it: an
//    effector at its origin with a position goal, or an effector with both a position and an
//    orientation goal (the joint sits at target - F offset, F the frame the heaviest orientation
//    goal asks for: fabrik.cpp's tip-frame pin, on every effector).
//    Where a joint is pinned with its frame (a wrist), the bone from its parent is kept within the
//    joint's cone about the pinned frame (A&L sec. 4.2's orientational constraint).
//  - backward stage (from the root, ws.points_backward): the root stays at its origin (a floating root
//    goes to the forward stage's centroid: the body moves to where its branches pull it), and every
//    point is pulled from its parent's new position to the bone's length.
//  - conversion, fused, root first: each joint turns so that the points below it best follow their
//    backward-stage positions, its ancestors already updated: a ball with one targeted child takes
//    the minimal rotation aiming that bone (twisted about it when the child is a hinge, so its plane
//    faces the points further on, as fabrik.cpp's hip -> knee, or carries a frame goal, so the
//    child's limits need not do all the turning), a ball sub-base Horn's best rotation of its
//    children (geometric::BallFit), a hinge the least-squares angle over every targeted point below
//    it (geometric::HingeFit). A joint carrying an orientation, aim or aim-at goal's effector instead
//    takes the rotation that best serves the goals on its effectors (CCD's per-joint fit, as
//    fabrik.cpp's final tip alignment), in the same pass: its descendants then hang from the frame
//    it ends with (fitted after the pass, from frames the fits before had left stale, the hips' fit
//    left every effector below off by the root's leftover turn: warm body tracking stuck there,
//    docs/full-body.md). Limits are applied right after each joint's update (turn_ball_params /
//    turn_hinge_param, the mechanism chains use), so they feed into the rest of the pass (A&L sec.
//    4.2); points and params never disagree (forward kinematics follows).
// Prismatic joints are not taken (the solver table). The posture is ignored (no null space).
// Termination and stuck poses: tree_common::Progress (the stall rule, escapes, the best pose).
#include <algorithm>
#include <cmath>

#include "core/solvers/geometric_common.hpp"
#include "core/solvers/tree_common.hpp"

namespace ikchain {
namespace {

class TreeFabrik {
 public:
  TreeFabrik(const Tree& tree, const TreeProblem& problem, const SolverOptions& o, TreeWorkspace& ws)
      : tree_(tree), problem_(problem), o_(o), ws_(ws), joints_(tree.joint_count()),
        tiny_(1e-12 * std::max(tree.total_length(), 1e-300)) {
    // Point weights: each position goal's weight on its effector point, summed up toward the root.
    std::fill(ws.point_weight.begin(), ws.point_weight.end(), 0.0);
    for (int g = 0; g < problem.goals.size; ++g) {
      const TreeGoal& tg = problem.goals[g];
      if (tg.goal.kind == GoalKind::kPosition)
        ws.point_weight[joints_ + tg.goal.effector] += tree_common::level_weight(tg.level) * tg.goal.weight;
      else
        frame_goals_ = true;
    }
    for (int e = 0; e < tree.effector_count(); ++e) ws.point_weight[tree.effector(e).joint] += ws.point_weight[joints_ + e];
    for (int j = joints_ - 1; j > 0; --j)
      if (tree.parent(j) >= 0) ws.point_weight[tree.parent(j)] += ws.point_weight[j];
  }

  // One iteration (ws holds the forward kinematics of params on entry); returns the largest
  // parameter change.
  double iterate(double* params);

 private:
  double weight(int point) const { return ws_.point_weight[point]; }
  double bone(int point) const {
    return point < joints_ ? glm::length(tree_.offset_in_parent(point))
                           : glm::length(tree_.effector(point - joints_).offset);
  }
  int parent_point(int point) const { return point < joints_ ? tree_.parent(point) : tree_.effector(point - joints_).joint; }

  // The target of effector e's position goals (weighted mean) and, when it also has an orientation
  // goal, the frame its joint must have (the heaviest such goal).
  bool effector_targets(int e, glm::dvec3& position, glm::dquat& frame, bool& has_frame) const {
    double w = 0.0, frame_w = 0.0;
    glm::dvec3 sum(0.0);
    for (int g = 0; g < problem_.goals.size; ++g) {
      const Goal& goal = problem_.goals[g].goal;
      if (goal.effector != e) continue;
      if (goal.kind == GoalKind::kPosition) {
        sum += goal.weight * goal.target_position;
        w += goal.weight;
      } else if (goal.kind == GoalKind::kOrientation && goal.weight > frame_w) {
        frame_w = goal.weight;
        frame = so3::normalized(goal.target_orientation) * glm::conjugate(tree_.effector(e).rotation);
      }
    }
    has_frame = frame_w > 0.0;
    if (!(w > 0.0)) return false;
    position = sum / w;
    return true;
  }

  // The frame joint j must have where an effector on it is pinned with an orientation goal (the
  // forward stage's pin); false when none is.
  bool pinned_frame(int j, glm::dquat& frame) const {
    for (int e = 0; e < tree_.effector_count(); ++e) {
      glm::dvec3 target;
      bool has_frame = false;
      if (tree_.effector(e).joint == j && weight(joints_ + e) > 0.0 && effector_targets(e, target, frame, has_frame) &&
          has_frame)
        return true;
    }
    return false;
  }
  // Joint j carries an effector with an orientation, aim or aim-at goal.
  bool carries_frame_goal(int j) const {
    for (int g = 0; g < problem_.goals.size; ++g) {
      const Goal& goal = problem_.goals[g].goal;
      if (goal.kind != GoalKind::kPosition && tree_.effector(goal.effector).joint == j) return true;
    }
    return false;
  }
  // Ball j's twist axis continues the bone from its parent (rest_rotation * twist_axis along
  // offset_in_parent, as a limb's joints in a T-pose): its swing is then the angle between that
  // bone and the bone after it.
  bool twist_axis_along_bone(int j) const {
    const glm::dvec3 offset = tree_.offset_in_parent(j);
    const double length = glm::length(offset);
    return tree_.joint_type(j) == JointType::kBall && length > tiny_ &&
           glm::dot(tree_.rest_rotation(j) * tree_.limits(j).twist_axis, offset) > (1.0 - 1e-9) * length;
  }
  // The pairs (geometric::goal_pairs, weighted by level) of every goal on joint j's effectors, with
  // the effectors moved rigidly by `motion` about `pivot` (from `pivot_old`, where ws's frames have
  // it) and seen from `pivot`.
  template <typename AddPair>
  void frame_goal_pairs(int j, const glm::dvec3& pivot_old, const glm::dvec3& pivot, const glm::dquat& motion,
                        AddPair&& add) const {
    geometric::Tracked tracked;
    for (int g = 0; g < problem_.goals.size; ++g) {
      const TreeGoal& tg = problem_.goals[g];
      if (tree_.effector(tg.goal.effector).joint != j) continue;
      tracked.position = pivot + motion * (tree_effector_position(tree_, ws_, tg.goal.effector) - pivot_old);
      tracked.orientation = motion * tree_effector_orientation(tree_, ws_, tg.goal.effector);
      tracked.aim_at_on_point = tree_aim_at_on_point(tree_, tg.goal);
      const double lw = tree_common::level_weight(tg.level);
      geometric::goal_pairs(tg.goal, tracked, pivot,
                            [&](const glm::dvec3& a, const glm::dvec3& b, double w) { add(a, b, lw * w); });
    }
  }

  void forward_stage();
  void backward_stage();
  void convert(double* params);
  void fit_frame_goals(int j, const glm::dvec3& origin, const glm::dquat& pre, const glm::dquat& moved, double* q) const;

  const Tree& tree_;
  const TreeProblem& problem_;
  const SolverOptions& o_;
  TreeWorkspace& ws_;
  const int joints_;
  const double tiny_;
  bool frame_goals_ = false;
};

// Into ws.points_forward (ws.points_backward accumulates the children's weighted proposals); ws.points_current holds
// the current points.
void TreeFabrik::forward_stage() {
  const glm::dvec3* a = ws_.points_current.data();
  glm::dvec3* b = ws_.points_forward.data();
  glm::dvec3* acc = ws_.points_backward.data();
  std::fill(ws_.points_backward.begin(), ws_.points_backward.end(), glm::dvec3(0.0));
  std::fill(ws_.points_forward.begin(), ws_.points_forward.begin() + joints_, glm::dvec3(INFINITY));  // not pinned
  // A proposal for `point`'s parent: pulled from b[point] toward the parent's old position.
  auto propose = [&](int point) {
    const int p = parent_point(point);
    if (p < 0) return;
    glm::dvec3 dir = a[p] - b[point];
    double len = glm::length(dir);
    if (!(len > tiny_)) {  // on top of each other: keep the old bone direction
      dir = a[p] - a[point];
      len = glm::length(dir);
    }
    // A joint whose frame a goal pins (a wrist): the bone from its parent within the joint's cone
    // about the pinned frame's twist axis, or no frame within its limits turns it that way (A&L
    // sec. 4.2, the orientational constraint, applied where the forward stage leaves the pin). The
    // textbook pull kept a tracked forearm where the last frame had it while the hand turned, until
    // the wrist needed more swing than its cone has (body bench, Boxing_Toes: hands 5-60 deg off).
    glm::dquat frame;
    if (point < joints_ && len > 0.0 && tree_.limits(point).has_cone_limit && twist_axis_along_bone(point) &&
        pinned_frame(point, frame)) {
      const JointLimits& l = tree_.limits(point);
      const glm::dvec3 axis = frame * l.twist_axis;  // the bone after the joint
      const glm::dvec3 bone_in = -dir / len;         // parent -> joint
      glm::dvec3 side;
      if (glm::dot(bone_in, axis) < std::cos(l.cone_angle)) {
        if (!geometric::perpendicular_part(bone_in, axis, 1e-12, side)) side = geometric::any_perpendicular(axis);
        dir = -len * (std::cos(l.cone_angle) * axis + std::sin(l.cone_angle) * side);
      }
    }
    acc[p] += weight(point) * (len > 0.0 ? b[point] + dir * (bone(point) / len) : b[point]);
  };
  for (int e = 0; e < tree_.effector_count(); ++e) {
    const int point = joints_ + e;
    glm::dvec3 target;
    glm::dquat frame;
    bool has_frame = false;
    if (!(weight(point) > 0.0) || !effector_targets(e, target, frame, has_frame)) continue;
    b[point] = target;
    const int j = tree_.effector(e).joint;
    if (has_frame) {
      b[j] = target - frame * tree_.effector(e).offset;  // pinned
    } else if (bone(point) <= tiny_) {
      b[j] = target;  // the effector is the joint's origin: pinned
    }
    propose(point);
  }
  for (int j = joints_ - 1; j >= 0; --j) {
    if (!(weight(j) > 0.0)) continue;
    if (!std::isfinite(b[j].x)) b[j] = acc[j] / weight(j);  // the (weighted) centroid of the branches
    propose(j);
  }
}

// Into ws.points_backward, from the root.
void TreeFabrik::backward_stage() {
  const glm::dvec3* b = ws_.points_forward.data();
  glm::dvec3* c = ws_.points_backward.data();
  const int points = joints_ + tree_.effector_count();
  for (int k = 0; k < points; ++k) {
    if (!(weight(k) > 0.0)) continue;
    const int p = parent_point(k);
    if (p < 0) {
      c[k] = (k == 0 && tree_.floating_root()) ? b[k] : ws_.points_current[k];
      continue;
    }
    const glm::dvec3 dir = b[k] - c[p];
    const double len = glm::length(dir);
    c[k] = len > tiny_ ? c[p] + dir * (bone(k) / len) : c[p] + (ws_.points_current[k] - ws_.points_current[p]);
  }
}

// Root first: each joint turned so the targeted points below it follow ws.points_backward. ws's frames
// are overwritten joint by joint with the new pose (a joint's old frame is read before).
void TreeFabrik::convert(double* params) {
  const glm::dvec3* a = ws_.points_current.data();
  const glm::dvec3* c = ws_.points_backward.data();
  const int points = joints_ + tree_.effector_count();
  for (int j = 0; j < joints_; ++j) {
    // The time budget within a long conversion: the joints after keep their params (FK follows).
    if (ws_.deadline.spent_after_joints(j)) break;
    const int p = tree_.parent(j);
    const glm::dquat parent_q = p < 0 ? geometric::kIdentity : ws_.joint_orientations[p];
    glm::dvec3 origin = p < 0 ? tree_.offset_in_parent(j) : ws_.joint_origins[p] + parent_q * tree_.offset_in_parent(j);
    if (j == 0 && tree_.floating_root()) {
      if (weight(0) > 0.0) {
        const glm::dvec3 t = c[0] - origin;
        params[0] = t.x, params[1] = t.y, params[2] = t.z;
      }
      origin += glm::dvec3(params[0], params[1], params[2]);
    }
    const glm::dquat pre = glm::normalize(parent_q * tree_.rest_rotation(j));
    // The rigid motion of j's subtree caused by its ancestors' updates.
    const glm::dquat moved = glm::normalize(pre * glm::conjugate(ws_.joint_pre_rotations[j]));
    const glm::dvec3 old_origin = a[j];
    auto current = [&](int k) { return moved * (a[k] - old_origin); };  // from the new origin
    double* q = params + tree_.dof_offset(j);
    if (frame_goals_ && carries_frame_goal(j)) {
      fit_frame_goals(j, origin, pre, moved, q);
    } else if (weight(j) > 0.0) {
      if (tree_.joint_type(j) == JointType::kBall) {
        // The targeted children: joints hanging from j and effectors on j.
        int children = 0, only = -1;
        geometric::BallFit fit;
        for (int k = j + 1; k < points; ++k) {
          if (!(weight(k) > 0.0) || parent_point(k) != j) continue;
          const glm::dvec3 from = current(k), to = c[k] - origin;
          if (glm::length(from) <= tiny_) continue;
          ++children;
          only = k;
          fit.add(from, to, weight(k));
        }
        if (children == 1) {
          const glm::dvec3 aim = c[only] - origin;
          const glm::dquat applied = geometric::turn_ball_params(
              tree_.limits(j), pre, geometric::rotation_between(current(only), aim), o_.max_step_angle, q);
          // The twist about the new bone leaves the child's point where it is but turns what hangs
          // from it, so the ball also twists by the angle that best serves that:
          //  - a hinge child bends only in its own plane: it should face the points further on
          //    (fabrik.cpp's reason). Undamped here: the chain's damping (kTwistDamping, for
          //    straight limbs on a hinge bound) cost the tree's cold solves (the golden
          //    nolimits_five_6d row ended 2.7e-4 off instead of 2.1e-5) and its warm tracking
          //    (TreeFabrik.WarmTrackingOfAMovingBodyTargetIsNotWorseThanCold: 1328 frames, 1361 without).
          //  - a child whose frame a goal fixes (a wrist): without this it must turn the rest of the
          //    way itself, within its limits, while the minimal rotations leave the ball's twist
          //    wherever the frames before put it. Tracked, that twist drifts frame to frame (holonomy:
          //    a bone led around a loop by minimal rotations comes back twisted) until the wrist
          //    hits its twist bound: the body bench's Boxing_Toes hands ended 5-60 deg off. Damped
          //    toward none as chains do (geometric::damped_twist_angle; undamped: warm success
          //    93.45 % instead of 94.39 %, position p99 20 mm instead of 3 mm).
          if (only < joints_ && glm::length(aim) > tiny_) {
            const glm::dvec3 axis = glm::normalize(aim);
            geometric::HingeFit twist;
            double angle = 0.0;
            if (tree_.joint_type(only) == JointType::kHinge) {
              for (int k = only + 1; k < points; ++k)
                if (weight(k) > 0.0 && tree_common::is_ancestor_or_self(tree_, only, k < joints_ ? k : parent_point(k)))
                  twist.add(axis, applied * current(k), c[k] - origin, 1.0);
              angle = twist.angle();
            } else if (frame_goals_ && carries_frame_goal(only)) {
              frame_goal_pairs(only, old_origin, origin, glm::normalize(applied * moved),
                               [&](const glm::dvec3& a, const glm::dvec3& b, double w) { twist.add(axis, a, b, w); });
              angle = geometric::damped_twist_angle(twist);
            }
            if (twist.scale > 0.0)
              geometric::turn_ball_params(tree_.limits(j), pre, glm::angleAxis(angle, axis), o_.max_step_angle, q);
          }
        } else if (children > 1) {
          geometric::turn_ball_params(tree_.limits(j), pre, fit.rotation(), o_.max_step_angle, q);
        }
      } else {
        const glm::dvec3 axis = pre * tree_.axis(j);
        geometric::HingeFit fit;
        for (int k = j + 1; k < points; ++k)
          if (weight(k) > 0.0 && tree_common::is_ancestor_or_self(tree_, j, k < joints_ ? k : parent_point(k)))
            fit.add(axis, current(k), c[k] - origin, 1.0);
        geometric::turn_hinge_param(tree_.limits(j), fit.angle(), o_.max_step_angle, q);
      }
    }
    glm::dquat orientation = pre;
    if (tree_.joint_type(j) == JointType::kBall)
      orientation = pre * so3::exp(glm::dvec3(q[0], q[1], q[2]));
    else
      orientation = pre * glm::angleAxis(q[0], tree_.axis(j));
    ws_.joint_origins[j] = origin;
    ws_.joint_pre_rotations[j] = pre;
    ws_.joint_orientations[j] = glm::normalize(orientation);
  }
}

// Turns joint j (its new origin `origin` and frame before its motion `pre`; `moved`: the rigid
// motion of its subtree since ws's frames) to the rotation that best serves the goals on its
// effectors (geometric::goal_pairs, as CCD's per-joint fit and fabrik.cpp's final tip alignment).
void TreeFabrik::fit_frame_goals(int j, const glm::dvec3& origin, const glm::dquat& pre, const glm::dquat& moved,
                                 double* q) const {
  const glm::dvec3 old_origin = ws_.joint_origins[j];
  if (tree_.joint_type(j) == JointType::kBall) {
    geometric::BallFit fit;
    frame_goal_pairs(j, old_origin, origin, moved, [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(a, b, w); });
    if (fit.pairs > 0) geometric::turn_ball_params(tree_.limits(j), pre, fit.rotation(), o_.max_step_angle, q);
  } else {
    const glm::dvec3 axis = pre * tree_.axis(j);
    geometric::HingeFit fit;
    frame_goal_pairs(j, old_origin, origin, moved, [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(axis, a, b, w); });
    geometric::turn_hinge_param(tree_.limits(j), fit.angle(), o_.max_step_angle, q);
  }
}

double TreeFabrik::iterate(double* params) {
  const int dofs = tree_.dof_count();
  std::copy(params, params + dofs, ws_.params_trial.data());
  for (int j = 0; j < joints_; ++j) ws_.points_current[j] = ws_.joint_origins[j];
  for (int e = 0; e < tree_.effector_count(); ++e) ws_.points_current[joints_ + e] = tree_effector_position(tree_, ws_, e);
  forward_stage();
  backward_stage();
  convert(params);  // leaves ws holding the new pose's frames
  double moved = 0.0;
  for (int d = 0; d < dofs; ++d) moved = std::max(moved, std::abs(params[d] - ws_.params_trial[d]));
  return moved;
}

}  // namespace

TreeSolverStatus solve_tree_fabrik(const Tree& tree, const TreeProblem& problem, const SolverOptions& options,
                                   TreeWorkspace& ws, double* params) {
  TreeSolverStatus status;
  TreeFabrik fabrik(tree, problem, options, ws);
  tree_common::Progress progress(tree, problem, options, ws, params);
  status.reason = TerminationReason::kMaxIterations;
  if (progress.met()) {
    status.reason = TerminationReason::kConverged;
    return status;
  }
  while (status.iterations < options.max_iterations && !(status.iterations == 0 && ws.deadline.spent())) {
    const double moved = fabrik.iterate(params);
    ++status.iterations;
    if (progress.stop_after_iteration(params, moved, status.reason)) break;
  }
  progress.finish(status.reason, params);
  status.escapes = progress.escapes();
  return status;
}

}  // namespace ikchain
