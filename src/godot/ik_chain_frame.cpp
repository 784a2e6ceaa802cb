// IKChain's per-frame path: read the bone poses, build the goals in the chain's base space, solve,
// write the rotations back. Allocates nothing (the buffers are sized at rebuild).
#include "ik_chain.hpp"

#include <algorithm>
#include <cmath>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "node_util.hpp"

namespace ikchain::godot {

namespace {

// Per-frame runtime problems: constant text, so reporting them allocates nothing.
constexpr const char* kBadTarget =
    "IKChain: the target's transform is not finite; this frame was skipped and the last pose kept.";
constexpr const char* kBadBase =
    "IKChain: the skeleton's global transform (or the base bone's pose) is not invertible: a zero scale? This frame "
    "was skipped and the last pose kept.";
constexpr const char* kNonFinite = "IKChain: the solver produced a non-finite rotation; the pose was left unchanged.";
// Problems that do not stop the frame: reported once per spell (IKChain::Spell).
constexpr const char* kBadPole =
    "IKChain: pole_target's global position is not finite or absurdly far (more than 1e6 chain lengths from the "
    "root bone); the pole is ignored until it is back. Move pole_target near the limb, on the side the knee or "
    "elbow should point to.";
constexpr const char* kBadTargetBasis =
    "IKChain: the target's basis is degenerate (a zero scale?), so it has no rotation: the tip's orientation goal "
    "(use_target_rotation) is skipped, its position still reached, until the basis is valid. Give the target a "
    "non-zero scale, or turn off use_target_rotation.";
constexpr const char* kBadGoalBasis =
    "IKChain: the target of an orientation goal (goals[], kind Orientation) has a degenerate basis (a zero "
    "scale?), so it has no rotation: that goal is skipped until the basis is valid. Give its target a non-zero "
    "scale.";
// A pole farther than this many chain lengths from the root gives no usable direction (its
// perpendicular part drowns in rounding): treated like a non-finite one.
constexpr double kMaxPoleDistanceInChainLengths = 1e6;

}  // namespace

// ---------------------------------------------------------------- solving

void IKChain::report_runtime(const char* message) {
  for (const std::string& r : runtime_reported_)
    if (r == message) return;
  gdx::print_error(message, "IKChain::_process_modification_with_delta", __FILE__, __LINE__);
  runtime_reported_.emplace_back(message);
}

void IKChain::Spell::report(const char* message) {
  if (reported) return;
  gdx::print_error(message, "IKChain::_process_modification_with_delta", __FILE__, __LINE__);
  reported = true;
}

void IKChain::set_invalid_result(const char* message) {
  // The modification did nothing this frame: a defined result, the pose is left as it was.
  has_result_ = true;
  last_ = SolveResult();
  last_.reason = TerminationReason::kInvalidInput;
  last_.message = Message::format("%s", message);
  solver_refused_ = false;
}

bool IKChain::assemble_goals(const gdx::Skeleton3D& skel) {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  gdx::Transform3D target_global = target_transform_;
  if (!use_target_transform_) {
    const gdx::Node3D target = gdx::Node3D::cast(self.get_node_or_null(target_));
    if (!target || !target.is_inside_tree()) {
      set_invalid_result("IKChain: target does not point to a Node3D in the scene tree.");
      return false;
    }
    target_global = target.get_global_transform();
  }
  const glm::dmat4 base_bone =
      base_bone_ >= 0 ? gdx::to_glm(skel.get_bone_global_pose(base_bone_)) : glm::dmat4(1.0);
  BaseFrame base;
  const char* bad = !finite(target_global) ? kBadTarget
                    : !BaseFrame::make(gdx::to_glm(skel.get_global_transform()), base_bone, base) ? kBadBase
                                                                                                  : nullptr;
  if (bad != nullptr) {
    report_runtime(bad);
    set_invalid_result(bad);
    return false;
  }
  const glm::dmat4 target_m = gdx::to_glm(target_global);
  const glm::dvec3 target_in_base = base.point_in_base(glm::dvec3(target_m[3]));
  const double length = mapping_.chain().total_length();

  goal_count_ = 0;
  bool bad_target_basis = false;
  if (goal_mode_ == GOAL_MODE_AIM) {
    goal_buffer_[size_t(goal_count_++)] =
        Goal::aim_at(target_in_base, mapping_.aim_axis_in_effector(gdx::to_glm(aim_axis_)), 0, 1.0);
  } else {
    goal_buffer_[size_t(goal_count_++)] = Goal::position(target_in_base, 0, 1.0);
    if (use_target_rotation_ && rotation_weight_ > 0.0) {
      if (has_rotation(glm::dmat3(target_m))) {
        // rotation_weight 1: a radian of orientation error costs as much as one chain length of
        // position error.
        goal_buffer_[size_t(goal_count_++)] = Goal::orientation(
            mapping_.effector_orientation_for_tip_bone(base.rotation_in_base(target_m)), 0,
            rotation_weight_ * length * length);
      } else {
        bad_target_basis = true;
      }
    }
  }
  // A spell ends on any frame without the problem (also when the spoiled part is no longer asked for).
  if (bad_target_basis)
    target_basis_spell_.report(kBadTargetBasis);
  else
    target_basis_spell_.clear();
  bool bad_goal_basis = false;
  for (const ExtraGoal& e : extra_goals_) {
    const gdx::Node3D node = gdx::Node3D::cast(self.get_node_or_null(e.target));
    if (!node) continue;  // a configuration warning says so
    const glm::dmat4 m = gdx::to_glm(node.get_global_transform());
    Goal g;
    switch (e.kind) {
      case GoalKind::kPosition: g = Goal::position(base.point_in_base(glm::dvec3(m[3])), e.effector, e.weight); break;
      case GoalKind::kOrientation:
        // Like the tip's orientation goal: rotation_weight scales every orientation goal.
        if (!(rotation_weight_ > 0.0)) continue;
        if (!has_rotation(glm::dmat3(m))) {
          bad_goal_basis = true;
          continue;
        }
        g = Goal::orientation(base.rotation_in_base(m), e.effector, e.weight * rotation_weight_ * length * length);
        break;
      default:
        g = Goal::aim_at(base.point_in_base(glm::dvec3(m[3])), e.axis_in_effector, e.effector,
                         e.weight * length * length);
        break;
    }
    goal_buffer_[size_t(goal_count_++)] = g;
  }

  if (bad_goal_basis)
    goal_basis_spell_.report(kBadGoalBasis);
  else
    goal_basis_spell_.clear();

  options_.use_pole = false;
  bool bad_pole = false;
  if (!pole_target_.is_empty()) {
    const gdx::Node3D pole = gdx::Node3D::cast(self.get_node_or_null(pole_target_));
    if (pole) {  // a missing node is a configuration warning
      const glm::dvec3 pole_in_base = base.point_in_base(glm::dvec3(gdx::to_glm(pole.get_global_transform())[3]));
      const glm::dvec3 root_in_base = bone_poses_[0].position;  // root_bone's origin, in its parent
      const double reach = kMaxPoleDistanceInChainLengths * std::max(length, 1e-6);
      if (so3::finite(pole_in_base) && glm::all(glm::lessThanEqual(glm::abs(pole_in_base - root_in_base),
                                                                    glm::dvec3(reach)))) {
        options_.use_pole = true;
        options_.pole_in_base = pole_in_base;
      } else {
        bad_pole = true;  // the solve goes on without the pole
      }
    }
  }
  if (bad_pole)
    pole_spell_.report(kBadPole);
  else
    pole_spell_.clear();
  return true;
}

bool IKChain::run(const gdx::Skeleton3D& skel) {
  if (needs_rebuild(skel)) rebuild(skel);  // allocates, but only when something changed
  if (!chain_ok_) {
    set_invalid_result(chain_problems_.empty() ? "IKChain: the chain is not configured."
                                               : chain_problems_.front().message.c_str());
    return false;
  }
  // The bones' current poses: an animation may have moved a chain bone's position or scale.
  const int n = mapping_.joint_count();
  for (int i = 0; i < mapping_.bone_count(); ++i) {
    const int bone = mapping_.skeleton_bone(i);
    BonePose& p = bone_poses_[size_t(i)];
    p.position = gdx::to_glm(skel.get_bone_pose_position(bone));
    p.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bone));
    p.scale = gdx::to_glm(skel.get_bone_pose_scale(bone));
    if (i < n) old_rotations_[size_t(i)] = p.rotation;
  }
  const PoseUpdate update = mapping_.update_pose(bone_poses_);
  if (!update.error.empty()) {
    report_runtime(update.error.c_str());
    set_invalid_result(update.error.c_str());
    return false;
  }
  if (!assemble_goals(skel)) {
    if (have_good_pose_)
      for (int i = 0; i < n; ++i)
        skel.set_bone_pose_rotation(mapping_.skeleton_bone(i), gdx::from_glm(new_rotations_[size_t(i)]));
    return false;
  }

  if (deterministic_) {
    params_.setZero();
  } else if (!params_from_last_solve_) {
    mapping_.params_from_rotations(old_rotations_, params_.data());
  }
  last_solver_ = resolved_solver();
  last_ = solve(last_solver_, mapping_.chain(), Span<const Goal>(goal_buffer_.data(), goal_count_), options_,
                workspace_, params_);
  has_result_ = true;
  solver_refused_ = !last_.usable();
  params_from_last_solve_ = !solver_refused_;
  if (solver_refused_) {
    report_runtime(last_.message.c_str());
    return false;
  }
  if (!mapping_.rotations_from_params(params_.data(), new_rotations_)) {
    params_from_last_solve_ = false;
    have_good_pose_ = false;
    report_runtime(kNonFinite);
    set_invalid_result(kNonFinite);
    return false;
  }
  for (int i = 0; i < n; ++i)
    skel.set_bone_pose_rotation(mapping_.skeleton_bone(i), gdx::from_glm(new_rotations_[size_t(i)]));
  have_good_pose_ = true;

  // The error of the pose the skeleton ends with: the skeleton blends our rotations with the
  // previous ones by `influence`, and a non-uniform scale makes the rigid chain approximate.
  const double influence = gdx::SkeletonModifier3D::unchecked(owner_).get_influence();
  const Span<const Goal> goals(goal_buffer_.data(), goal_count_);
  if (influence < 1.0) {
    written_ = mapping_.measure_blended_pose(old_rotations_, new_rotations_, influence, goals, blended_rotations_);
  } else if (mapping_.has_non_uniform_scale()) {
    written_ = mapping_.measure_pose(new_rotations_, goals);
  } else {
    written_.combined = last_.final_error;
    written_.max_position = last_.final_position_error;
    written_.max_orientation = last_.final_orientation_error;
  }
  clear_runtime_reports();
  return true;
}

}  // namespace ikchain::godot
