// IKChain's configuration: the bones, joint settings and goals checked against the skeleton (the
// warnings, each with its fix) and the chain rebuilt from them.
#include "ik_chain.hpp"

#include <algorithm>
#include <string>

#include "binding/classes.hpp"
#include "binding/math.hpp"
#include "ik_chain_goal.hpp"
#include "ik_chain_joint.hpp"
#include "node_util.hpp"

namespace ikchain::godot {

void IKChain::collect_chain_problems(const gdx::Skeleton3D& skel, std::vector<Problem>& problems,
                                     SkeletonChainDesc* desc) const {
  if (!skel) {
    problems.push_back({"parent", "IKChain: the parent is not a Skeleton3D; make IKChain a child of a Skeleton3D."});
    return;
  }
  auto bone_index = [&](const char* prop, const std::string& name) -> int {
    if (name.empty()) {
      problems.push_back({prop, std::string("IKChain: ") + prop + " is empty; pick a bone of the parent Skeleton3D "
                                "in the " + prop + " property."});
      return -1;
    }
    const int idx = int(skel.find_bone(text(name)));
    if (idx < 0)
      problems.push_back({prop, std::string("IKChain: ") + prop + " '" + name +
                                    "' is not a bone of the parent Skeleton3D; pick one from the " + prop +
                                    " drop-down."});
    return idx;
  };
  const int root = bone_index("root_bone", root_bone_);
  const int tip = bone_index("tip_bone", tip_bone_);
  if (root < 0 || tip < 0) return;

  // Bones: tip up to root (then reversed, root first).
  std::vector<int> bones{tip};
  const int64_t bone_count = skel.get_bone_count();
  int b = tip;
  while (b != root && b >= 0 && int64_t(bones.size()) <= bone_count) {
    b = int(skel.get_bone_parent(b));
    if (b >= 0) bones.push_back(b);
  }
  if (b != root || tip == root) {
    problems.push_back({"tip_bone", "IKChain: tip_bone '" + tip_bone_ + "' is not a descendant of root_bone '" +
                                        root_bone_ + "'; pick a tip_bone below root_bone (the joints are root_bone "
                                        "down to tip_bone's parent, the effector is tip_bone's origin)."});
    return;
  }
  std::reverse(bones.begin(), bones.end());
  const size_t joint_count = extend_tip_bone_ ? bones.size() : bones.size() - 1;

  // Joint settings by bone name; each resource must name a chain bone, once.
  std::vector<const IKChainJoint*> settings(bones.size(), nullptr);
  for (int64_t i = 0; i < joints_.size(); ++i) {
    const gdx::ObjectPtr object = object_at(joints_, i);
    const IKChainJoint* joint = IKChainJoint::from_object(object);
    const std::string where = "IKChain: joints[" + std::to_string(i) + "]";
    if (joint == nullptr) {
      problems.push_back({"joints", where + " is not an IKChainJoint; create one with New IKChainJoint or remove "
                                    "the element."});
      continue;
    }
    const int bone = int(skel.find_bone(joint->get_bone_name()));
    size_t k = 0;
    while (k < joint_count && bones[k] != bone) ++k;
    if (k == joint_count) {
      problems.push_back({"joints", where + " names bone '" + joint->bone_name() +
                                        "', which is not a joint of this chain; set its bone_name to one of the "
                                        "bones from root_bone to tip_bone's parent" +
                                        (extend_tip_bone_ ? " (or tip_bone)." : ".")});
      continue;
    }
    if (settings[k] != nullptr) {
      problems.push_back({"joints", where + " sets bone '" + joint->bone_name() +
                                        "' a second time; remove one of the two."});
      continue;
    }
    settings[k] = joint;
  }

  if (!solver_is_auto()) {
    const SolverInfo& info = solver_info(choice_kind());
    if (info.joint_count != 0 && size_t(info.joint_count) != joint_count)
      problems.push_back({"solver", std::string("IKChain: solver ") + info.display_name + " needs exactly " +
                                        std::to_string(info.joint_count) + " joints (root_bone, its child, then "
                                        "tip_bone), this chain has " + std::to_string(joint_count) +
                                        "; change root_bone/tip_bone or pick another solver."});
  }
  if (desc == nullptr) return;
  desc->bones.clear();
  desc->extend_tip_bone = extend_tip_bone_;
  desc->tip_extension_axis = TipAxis(tip_extension_axis_);
  desc->tip_extension_length = tip_extension_length_;
  for (size_t i = 0; i < bones.size(); ++i) {
    ChainBoneDesc bone;
    bone.name = skel.get_bone_name(bones[i]).utf8();
    bone.skeleton_bone = bones[i];
    bone.rest_basis_in_parent = gdx::to_glm(skel.get_bone_rest(bones[i]).basis);
    bone.pose.position = gdx::to_glm(skel.get_bone_pose_position(bones[i]));
    bone.pose.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bones[i]));
    bone.pose.scale = gdx::to_glm(skel.get_bone_pose_scale(bones[i]));
    if (const IKChainJoint* j = settings[i]) bone.joint = j->settings();
    desc->bones.push_back(std::move(bone));
  }
}

void IKChain::collect_goal_problems(std::vector<Problem>& problems) const {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  if (use_target_transform_) {
    // target_transform (global space, set by a script) drives the chain; target is ignored.
    if (!finite(target_transform_))
      problems.push_back({"target_transform", "IKChain: target_transform is not finite; set it to a finite "
                                              "transform (global space)."});
  } else if (target_.is_empty()) {
    problems.push_back({"target", "IKChain: target is empty; set it to the Node3D the tip should reach, or turn on "
                                  "use_target_transform and set target_transform from a script."});
  } else if (!gdx::Node3D::cast(self.get_node_or_null(target_))) {
    problems.push_back({"target", "IKChain: target '" + target_.to_string().utf8() +
                                      "' does not point to a Node3D; set it to the Node3D the tip should reach, or "
                                      "clear it and drive target_transform from a script."});
  }
  if (!pole_target_.is_empty() && !gdx::Node3D::cast(self.get_node_or_null(pole_target_)))
    problems.push_back({"pole_target", "IKChain: pole_target '" + pole_target_.to_string().utf8() +
                                           "' does not point to a Node3D; set it to a Node3D or clear it."});
  if (goal_mode_ == GOAL_MODE_AIM && !(glm::length(gdx::to_glm(aim_axis_)) > 1e-9))
    problems.push_back({"aim_axis", "IKChain: aim_axis is zero; set the tip bone's axis that should point at the "
                                    "target, e.g. (0, 1, 0)."});
  // What the chosen solver can pursue (the core's solver table); Auto always picks one that can.
  const SolverInfo* info = solver_is_auto() ? nullptr : &solver_info(choice_kind());
  const bool orientation = (goal_mode_ == GOAL_MODE_AIM) || (use_target_rotation_ && rotation_weight_ > 0.0);
  if (info != nullptr && orientation && !info->orientation_goals)
    problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                      " only reaches a position; turn off use_target_rotation (or goal_mode Aim), or "
                                      "pick another solver (Auto picks one that can)."});
}

void IKChain::resolve_goals(const SkeletonChain& chain, std::vector<ExtraGoal>* goals, std::vector<Problem>& problems,
                            std::vector<Problem>& unmovable) const {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  const SolverInfo* info = solver_is_auto() ? nullptr : &solver_info(choice_kind());
  for (int64_t i = 0; i < goals_.size(); ++i) {
    const gdx::ObjectPtr object = object_at(goals_, i);
    const IKChainGoal* goal = IKChainGoal::from_object(object);
    const std::string where = "IKChain: goals[" + std::to_string(i) + "]";
    if (goal == nullptr) {
      problems.push_back({"goals", where + " is not an IKChainGoal; create one with New IKChainGoal or remove the "
                                   "element."});
      continue;
    }
    // A missing target only skips the goal per frame (the node may appear later).
    if (!gdx::Node3D::cast(self.get_node_or_null(goal->get_target())))
      problems.push_back({"goals", where + " (bone '" + goal->bone_name() +
                                       "'): target does not point to a Node3D; set its target (a path relative to "
                                       "this IKChain)."});
    if (info != nullptr && !info->several_goals)
      problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                        " takes no extra goals; remove goals[" + std::to_string(i) +
                                        "] or pick another solver."});
    else if (info != nullptr && goal->get_kind() != IKChainGoal::KIND_POSITION &&
             !info->intermediate_orientation_goals)
      problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                        " pursues orientation and aim goals on the tip only; make goals[" +
                                        std::to_string(i) + "] a position goal or pick another solver."});
    if (!chain.valid()) continue;
    int chain_bone = -1;
    for (int k = 0; k < chain.bone_count(); ++k)
      if (chain.bone_name(k) == goal->bone_name()) chain_bone = k;
    ExtraGoal e;
    e.kind = goal->goal_kind();
    e.weight = goal->get_weight();
    e.target = goal->get_target();
    // A position goal pulls the bone's origin (effector k); an orientation or aim goal turns the
    // bone's own frame, which the core exposes as the orientation of effector k + 1.
    e.effector = e.kind == GoalKind::kPosition
                     ? chain.effector_of_bone(chain_bone)
                     : (chain_bone >= 0 && chain_bone < chain.joint_count() ? chain_bone + 1 : -1);
    if (e.effector <= 0) {
      unmovable.push_back({"goals", where + " names bone '" + goal->bone_name() +
                                        "', which this goal cannot move (not in the chain" +
                                        (e.kind == GoalKind::kPosition ? ", or the root bone whose origin is fixed"
                                                                       : "") +
                                        "); set its bone_name to a bone of the chain."});
      continue;
    }
    e.axis_in_effector = gdx::to_glm(goal->get_aim_axis());
    if (goals != nullptr) goals->push_back(e);
  }
}

void IKChain::configure(const gdx::Skeleton3D& skel, bool build, Config& c) {
  collect_chain_problems(skel, c.fatal, &c.desc);
  if (build) {
    mapping_built_ = false;
    // Built whenever there are bones, even past other problems, so that what the builder rejects
    // (limits, lengths) shows with them.
    if (!c.desc.bones.empty()) {
      const Message built = mapping_.build(c.desc);
      if (!built.empty()) c.fatal.push_back({"joints", std::string("IKChain: cannot build the chain: ") + built.c_str()});
      mapping_built_ = built.empty();
    }
  }
  collect_goal_problems(c.notes);
  // Goals resolve against the chain these settings build (the warnings' pass runs after the rebuild).
  static const SkeletonChain kNoChain;
  resolve_goals(mapping_built_ ? mapping_ : kNoChain, &c.goals, c.notes, c.fatal);
}

gdx::PackedStringArray IKChain::get_configuration_warnings() {
  const gdx::Skeleton3D skel = skeleton();
  // The rebuild the next frame would do anyway, done now: the warnings read the node's own chain.
  if (skel ? needs_rebuild(skel) : (dirty_ || built_skeleton_id_ != 0)) rebuild(skel);
  Config c;
  configure(skel, /*build=*/false, c);
  std::vector<Problem> problems = std::move(c.fatal);
  problems.insert(problems.end(), c.notes.begin(), c.notes.end());
  if (chain_ok_ && mapping_.has_non_uniform_scale()) problems.push_back({"root_bone", mapping_.scale_warning().c_str()});
  // The chain as last built: what the builder rejected (limits, lengths) and what the solver refused.
  for (const Problem& p : chain_problems_) {
    bool seen = false;
    for (const Problem& q : problems) seen = seen || q.message == p.message;
    if (!seen) problems.push_back(p);
  }
  if (solver_refused_)
    problems.push_back({"solver", std::string("IKChain: the solver refused the last frame: ") + last_.message.c_str()});
  gdx::PackedStringArray out;
  for (const Problem& p : problems) out.push_back(text(p.message));
  return out;
}

// ---------------------------------------------------------------- building

bool IKChain::needs_rebuild(const gdx::Skeleton3D& skel) const {
  return dirty_ || skel.instance_id() != built_skeleton_id_ || skel.get_version() != built_skeleton_version_ ||
         joints_.size() != built_joints_size_ || goals_.size() != built_goals_size_ ||
         // A bone renamed under our chain (the version does not count renames in every engine).
         (chain_ok_ && (skel.find_bone(root_bone_name_) != root_bone_index_ ||
                        skel.find_bone(tip_bone_name_) != tip_bone_index_)) ||
         ancestry_changed(skel);
}

bool IKChain::ancestry_changed(const gdx::Skeleton3D& skel) const {
  const int64_t count = skel.get_bone_count();
  for (const auto& [bone, parent] : built_ancestry_)
    if (bone >= count || skel.get_bone_parent(bone) != parent) return true;
  return false;
}

void IKChain::record_ancestry(const gdx::Skeleton3D& skel) {
  built_ancestry_.clear();
  if (!skel || tip_bone_.empty()) return;
  const int64_t count = skel.get_bone_count();
  const int root = root_bone_.empty() ? -1 : int(skel.find_bone(text(root_bone_)));
  int bone = int(skel.find_bone(text(tip_bone_)));
  // Bounded by the bone count: a parent cycle cannot hang the walk.
  for (int64_t steps = 0; bone >= 0 && bone < count && steps <= count; ++steps) {
    const int parent = int(skel.get_bone_parent(bone));
    built_ancestry_.emplace_back(bone, parent);
    if (bone == root) break;
    bone = parent;
  }
}

void IKChain::rebuild(const gdx::Skeleton3D& skel) {
  dirty_ = false;
  const bool was_ok = chain_ok_;
  const size_t old_problem_count = chain_problems_.size();
  chain_ok_ = false;
  chain_problems_.clear();
  if (skel && skel.instance_id() != built_skeleton_id_) watch_skeleton(skel);
  built_skeleton_id_ = skel.instance_id();
  built_skeleton_version_ = skel ? skel.get_version() : -1;
  built_joints_size_ = joints_.size();
  built_goals_size_ = goals_.size();
  // Edits of these resources mark this node dirty (and no other).
  listen_to(joints_);
  listen_to(goals_);
  record_ancestry(skel);

  Config config;
  configure(skel, /*build=*/true, config);
  chain_problems_ = std::move(config.fatal);  // the notes only show as warnings (the chain runs without them)
  const SkeletonChainDesc& desc = config.desc;
  if (chain_problems_.empty()) {
    const int n = mapping_.joint_count();
    const int bones = mapping_.bone_count();
    base_bone_ = int(skel.get_bone_parent(desc.bones.front().skeleton_bone));
    root_bone_name_ = text(root_bone_);
    tip_bone_name_ = text(tip_bone_);
    root_bone_index_ = desc.bones.front().skeleton_bone;
    tip_bone_index_ = desc.bones.back().skeleton_bone;
    // Extra goals: effector and frame of each IKChainGoal (a goal on a bone the chain cannot move
    // is a fatal problem of the pass).
    extra_goals_ = std::move(config.goals);
    const int max_goals = 2 + int(extra_goals_.size());
    workspace_.reset(mapping_.chain(), max_goals);
    goal_buffer_.assign(size_t(max_goals), Goal());
    params_ = Eigen::VectorXd::Zero(mapping_.chain().dof_count());
    params_from_last_solve_ = false;
    have_good_pose_ = false;
    bone_poses_.assign(size_t(bones), BonePose());
    old_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
    new_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
    blended_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
    chain_ok_ = true;
  }
  if (chain_ok_ != was_ok || chain_problems_.size() != old_problem_count) settings_changed();
}

SolverKind IKChain::resolved_solver() const {
  if (!solver_is_auto()) return choice_kind();
  // Auto: the analytic solver when it is exact for the chain and goals (2 free ball joints, one
  // position goal); otherwise damped least squares, the fastest of the robust solvers in the
  // benchmark (docs/benchmarks.md), which pursues every goal kind and respects limits.
  const Chain& chain = mapping_.chain();
  const bool position_only = goal_count_ == 1 && goal_buffer_[0].kind == GoalKind::kPosition;
  if (chain.joint_count() == 2 && position_only && !chain.any_limits() &&
      chain.joint_type(0) == JointType::kBall && chain.joint_type(1) == JointType::kBall)
    return SolverKind::kTwoBone;
  return SolverKind::kDLS;
}

}  // namespace ikchain::godot
