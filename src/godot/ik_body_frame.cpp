// IKBody's per-frame path: the incoming (animated) pose, the effectors' goals at their priority
// levels, the coupled solve of the tree, the write-back. Allocates nothing (buffers sized at rebuild).
#include "ik_body.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "ik_body_effector.hpp"
#include "node_util.hpp"

namespace ikchain::godot {

// ---------------------------------------------------------------- solving

void IKBody::report_runtime(const std::string& message) {
  ++reports_this_frame_;
  for (const std::string& r : runtime_reported_)
    if (r == message) return;
  gdx::print_error(message.c_str(), "IKBody::_process_modification_with_delta", __FILE__, __LINE__);
  runtime_reported_.push_back(message);
}

void IKBody::set_invalid_result(const char* message) {
  has_result_ = true;
  last_ = TreeSolveResult();
  last_.summary.reason = TerminationReason::kInvalidInput;
  last_.summary.message = Message::format("%s", message);
  std::fill(effector_position_error_.begin(), effector_position_error_.end(), kNaN);
  std::fill(effector_rotation_error_.begin(), effector_rotation_error_.end(), kNaN);
}

bool IKBody::run(const gdx::Skeleton3D& skel) {
  if (needs_rebuild(skel)) rebuild(skel);  // allocates, but only when something changed
  // A problem is printed once when it starts, not every frame; again after a frame without any.
  if (reports_this_frame_ == 0) runtime_reported_.clear();
  reports_this_frame_ = 0;
  if (!body_ok_) {
    set_invalid_result(body_problems_.empty() ? "IKBody: the body is not configured."
                                              : body_problems_.front().message.c_str());
    return false;
  }
  // The incoming pose: the animation's (Skeleton3D restores it before the modifiers run).
  const int n = mapping_.bone_count();
  static_assert(sizeof(BonePose) == 10 * sizeof(double), "BonePose is compared bitwise: no padding");
  bool pose_as_recorded = anim_params_current_;
  for (int i = 0; i < n; ++i) {
    const int bone = mapping_.skeleton_bone(i);
    BonePose& p = bone_poses_[size_t(i)];
    p.position = gdx::to_glm(skel.get_bone_pose_position(bone));
    p.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bone));
    p.scale = gdx::to_glm(skel.get_bone_pose_scale(bone));
    pose_as_recorded = pose_as_recorded && std::memcmp(&p, &mapping_.bone_pose(i), sizeof(BonePose)) == 0;
  }
  // The same bits as the poses anim_params_ came from (no animation playing): update_pose() and
  // params_from_pose() would give what they gave then, so they are skipped.
  if (!pose_as_recorded) {
    anim_params_current_ = false;
    const PoseUpdate update = mapping_.update_pose(bone_poses_);
    if (!update.error.empty()) {
      report_runtime(std::string("IKBody: ") + update.error.c_str() + "; the animated pose is kept this frame.");
      set_invalid_result(update.error.c_str());
      return false;
    }
    if (update.shape_changed) workspace_.reset(mapping_.tree(), int(goals_.size()));  // same sizes: no reallocation
    mapping_.params_from_pose(anim_params_.data());
    anim_params_current_ = true;
  }
  // Warm start: the animated pose; while it stays the same (no animation playing), the last
  // solution, which tracks moving targets smoothly. `deterministic`: always the animated pose,
  // so the output depends on this frame's inputs alone.
  const bool animation_still = anim_params_ == previous_anim_params_;
  params_ = (!deterministic_ && have_last_ && animation_still) ? last_params_ : anim_params_;
  previous_anim_params_ = anim_params_;

  const glm::dmat4 base_bone = base_bone_ >= 0 ? gdx::to_glm(skel.get_bone_global_pose(base_bone_)) : glm::dmat4(1.0);
  const glm::dmat4 skeleton_global = gdx::to_glm(skel.get_global_transform());
  // A skeleton standing still keeps its base frame: made again when an input changed a bit.
  if (!base_current_ || std::memcmp(&skeleton_global, &base_skeleton_global_, sizeof(glm::dmat4)) != 0 ||
      std::memcmp(&base_bone, &base_bone_in_skeleton_, sizeof(glm::dmat4)) != 0) {
    base_current_ = false;
    if (!BaseFrame::make(skeleton_global, base_bone, base_)) {
      const char* bad = "IKBody: the skeleton's global transform (or the root bone's parent pose) is not invertible: "
                        "a zero scale? The animated pose is kept this frame.";
      report_runtime(bad);
      set_invalid_result(bad);
      return false;
    }
    base_skeleton_global_ = skeleton_global;
    base_bone_in_skeleton_ = base_bone;
    base_current_ = true;
  }
  const BaseFrame& base = base_;

  // The posture task pulls the freedom the effectors leave toward the incoming (animated) pose,
  // poles applied: the smallest correction of the animation. Never toward the last solution: that
  // would keep whatever bend an earlier frame needed (a reach's spine, a crouch's pelvis) for as
  // long as nothing else moves it (test_ik_body::reach_and_return_leaves_no_bend_behind).
  posture_ = anim_params_;
  const bool warm = params_ != anim_params_;
  // Poles: the start pose's limb planes turned toward them (the posture's too).
  const gdx::Node self = gdx::Node::unchecked(owner_);
  for (const Slot& slot : slots_) {
    if (slot.pole_end < 0 || !slot.effector->is_enabled()) continue;
    const gdx::Node3D pole = gdx::Node3D::cast(self.get_node_or_null(slot.effector->pole_target()));
    if (!pole || !pole.is_inside_tree()) {
      report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                     ": pole_target does not point to a Node3D in the scene tree; the pole is ignored until it is "
                     "back.");
      continue;
    }
    const glm::dvec3 pole_in_tree =
        mapping_.point_in_tree(base.point_in_base(glm::dvec3(gdx::to_glm(pole.get_global_transform())[3])));
    if (!within_magnitude(pole_in_tree)) {
      report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                     ": pole_target's position is not finite (or absurdly far); the pole is ignored until it is "
                     "back.");
      continue;
    }
    mapping_.swivel_toward_pole(slot.pole_end, pole_in_tree, posture_.data(), workspace_);
    if (warm) mapping_.swivel_toward_pole(slot.pole_end, pole_in_tree, params_.data(), workspace_);
  }
  if (!warm) params_ = posture_;

  // The animated effector poses: what an effector with influence < 1 blends from. Computed when
  // the first such effector asks (most rigs have none); solve_tree() runs its own FK.
  const Tree& tree = mapping_.tree();
  bool animated_fk = false;
  auto animated_poses = [&]() {
    if (!animated_fk) tree_forward_kinematics(tree, anim_params_.data(), workspace_);
    animated_fk = true;
  };
  int goal_count = 0;
  look_goals_.clear();  // capacity: one per slot (rebuild), so no allocation
  std::fill(effector_position_error_.begin(), effector_position_error_.end(), kNaN);
  std::fill(effector_rotation_error_.begin(), effector_rotation_error_.end(), kNaN);
  for (int s = 0; s < int(slots_.size()); ++s) {
    const Slot& slot = slots_[size_t(s)];
    const IKBodyEffector& e = *slot.effector;
    const double wp = e.get_position_weight(), wr = e.get_rotation_weight();
    if (!(wp > 0.0) && !(wr > 0.0)) continue;  // a configuration warning says so
    gdx::Transform3D target_global = e.get_target_transform();
    if (!e.is_using_target_transform()) {
      if (e.target().is_empty()) continue;  // a configuration warning says so
      const gdx::Node3D node = gdx::Node3D::cast(self.get_node_or_null(e.target()));
      if (!node || !node.is_inside_tree()) {
        report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                       ": target does not point to a Node3D in the scene tree (freed or moved?); the effector "
                       "follows the animation until it is back. Set its target to a Node3D.");
        continue;
      }
      target_global = node.get_global_transform();
    }
    const glm::dmat4 target_m = gdx::to_glm(target_global);
    if (!finite(target_m)) {
      report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                     ": the target's transform is not finite (NaN or inf); the effector follows the animation "
                     "until it is finite again.");
      continue;
    }
    const double influence = e.get_influence();
    const int level =
        int(std::clamp<int64_t>(e.get_priority(), IKBodyEffector::kMinPriority, IKBodyEffector::kMaxPriority));
    if (slot.look) {
      if (!(wr > 0.0)) continue;  // a configuration warning says so
      // Aim the bone's look_axis at the target's origin; with influence < 1 the aimed point turns
      // only that share of the way from where the animation looks.
      const glm::dvec3 target = mapping_.point_in_tree(base.point_in_base(glm::dvec3(target_m[3])));
      if (!within_magnitude(target)) {
        report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                       ": the target is absurdly far (beyond 1e50 m); the effector follows the animation.");
        continue;
      }
      const glm::dvec3 axis = glm::normalize(glm::dvec3(gdx::to_glm(e.get_look_axis())));
      glm::dvec3 point = target;
      if (influence < 1.0) {
        animated_poses();
        const glm::dvec3 origin = tree_effector_position(tree, workspace_, slot.core_effector);
        const glm::dvec3 facing = tree_effector_orientation(tree, workspace_, slot.core_effector) * axis;
        const glm::dvec3 to_target = target - origin;
        const double distance = glm::length(to_target);
        if (distance > 1e-9) {
          const glm::dvec3 wanted = to_target / distance;
          glm::dvec3 about = glm::cross(facing, wanted);
          const double sine = glm::length(about);
          const double angle = std::atan2(sine, glm::dot(facing, wanted));
          if (sine > 1e-12) point = origin + glm::angleAxis(influence * angle, about / sine) * facing * distance;
        }
      }
      const double length = std::max(tree.lever(slot.core_effector), 1e-3);
      goals_[size_t(goal_count)] = {Goal::aim_at(point, axis, slot.core_effector, wr * length * length), level};
      goal_slot_[size_t(goal_count)] = s;
      goal_rotation_[size_t(goal_count)] = 1;
      if (!slot.look_bones.empty()) look_goals_.push_back(goal_count);
      ++goal_count;
      continue;
    }
    if (wp > 0.0) {
      const glm::dvec3 target = mapping_.point_in_tree(base.point_in_base(glm::dvec3(target_m[3])));
      glm::dvec3 goal = target;
      if (!(influence >= 1.0)) {
        animated_poses();
        goal = glm::mix(tree_effector_position(tree, workspace_, slot.core_effector), target, influence);
      }
      if (!within_magnitude(goal)) {
        report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                       ": the target is absurdly far (beyond 1e50 m); the effector follows the animation.");
        continue;
      }
      goals_[size_t(goal_count)] = {Goal::position(goal, slot.core_effector, wp), level};
      goal_slot_[size_t(goal_count)] = s;
      goal_rotation_[size_t(goal_count)] = 0;
      ++goal_count;
    }
    glm::dquat target_rotation_global;
    if (wr > 0.0 && rotation_of_basis(glm::dmat3(target_m), target_rotation_global)) {
      const glm::dquat target = base.rotation_in_base(target_rotation_global);
      glm::dquat goal = target;
      if (!(influence >= 1.0)) {
        animated_poses();
        goal = godot_slerp(tree_effector_orientation(tree, workspace_, slot.core_effector), target, influence);
      }
      // A radian counts like the longest lever it swings, in metres (Tree::lever; rotation_weight 1).
      const double length = std::max(tree.lever(slot.core_effector), 1e-3);
      goals_[size_t(goal_count)] = {Goal::orientation(goal, slot.core_effector, wr * length * length), level};
      goal_slot_[size_t(goal_count)] = s;
      goal_rotation_[size_t(goal_count)] = 1;
      ++goal_count;
    }
  }
  if (goal_count == 0) {
    set_invalid_result("IKBody: no effector has a usable target this frame; the animated pose is kept.");
    return false;
  }
  // Looks with shares: the start pose and the posture (the incoming pose, poles applied) turned
  // toward each look, a set share per bone (the solver then only corrects what the other effectors
  // disturb, and the posture keeps the shares).
  for (int g : look_goals_) {
    const Slot& slot = slots_[size_t(goal_slot_[size_t(g)])];
    const Goal& goal = goals_[size_t(g)].goal;
    const Span<const int> bones(slot.look_bones.data(), int(slot.look_bones.size()));
    const Span<const double> shares(slot.look_shares.data(), int(slot.look_shares.size()));
    mapping_.spread_look(bones, shares, goal.aim_axis, goal.target_position, posture_.data(), workspace_);
    mapping_.spread_look(bones, shares, goal.aim_axis, goal.target_position, params_.data(), workspace_);
  }

  TreeProblem problem;
  problem.goals = Span<const TreeGoal>(goals_.data(), goal_count);
  problem.posture = Span<const double>(posture_.data(), int(posture_.size()));
  problem.posture_stiffness = Span<const double>(posture_stiffness_.data(), int(posture_stiffness_.size()));
  // A frame stops a few posture steps after its goals are met instead of waiting for the posture
  // to settle (~20 iterations a frame at stiffness 0.1): a tracking frame goes on from there the
  // next frame; a `deterministic` one (from the incoming pose) gets the same steps every time.
  // The first frame with no solution to go on from settles once: left unsettled, its posture's
  // rest took the next frames' steps as motion the targets did not make (the replayed boxer's head
  // 6.7 cm in its second frame, 0.1 cm in the recording). A settle the time budget cut goes on in
  // the next frames until one ends it (at 100 us the set-up humanoid crept 8 mm a frame after it).
  const bool settling = !deterministic_ && (!have_last_ || !settled_);
  problem.posture_iterations = settling ? 0 : kPostureIterations;
  last_ = solve_tree(resolved_solver(), tree, problem, options_, workspace_, params_);
  has_result_ = true;
  last_goal_count_ = goal_count;
  if (!last_.usable()) {
    report_runtime(std::string("IKBody: the solver refused the frame: ") + last_.summary.message.c_str() +
                   "; the animated pose is kept.");
    have_last_ = false;
    return false;
  }
  glm::dvec3 root_position(0.0);
  if (!mapping_.pose_from_params(params_.data(), rotations_, root_position)) {
    const char* bad = "IKBody: the solver produced a non-finite pose; the animated pose is kept.";
    report_runtime(bad);
    set_invalid_result(bad);
    have_last_ = false;
    return false;
  }
  for (int i = 0; i < n; ++i)
    skel.set_bone_pose_rotation(mapping_.skeleton_bone(i), gdx::from_glm(rotations_[size_t(i)]));
  if (mapping_.floating_root()) skel.set_bone_pose_position(mapping_.skeleton_bone(0), gdx::from_glm(root_position));
  last_params_ = params_;
  have_last_ = true;
  if (settling) settled_ = !last_.summary.budget_exhausted;
  for (int g = 0; g < goal_count; ++g) {
    const int index = slots_[size_t(goal_slot_[size_t(g)])].index;
    std::vector<double>& errors = goal_rotation_[size_t(g)] ? effector_rotation_error_ : effector_position_error_;
    errors[size_t(index)] = last_.goal_error[size_t(g)];
  }
  return true;
}

}  // namespace ikchain::godot
