// IKBody's configuration: effectors, supporting bones, joints, poles and looks checked against the
// skeleton (one pass for the warnings and the rebuild), and the body rebuilt from them.
#include "ik_body.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "binding/classes.hpp"
#include "binding/math.hpp"
#include "ik_body_effector.hpp"
#include "ik_chain_joint.hpp"
#include "node_util.hpp"

namespace ikchain::godot {

// ---------------------------------------------------------------- configuration

void IKBody::configure(const gdx::Skeleton3D& skel, std::vector<Problem>& problems, SkeletonTreeDesc* desc,
                       std::vector<Slot>* slots, std::vector<gdx::Variant>* held) const {
  if (!skel) {
    problems.push_back({"parent", "IKBody: the parent is not a Skeleton3D; make IKBody a child of a Skeleton3D."});
    return;
  }
  const int bone_count = int(skel.get_bone_count());
  int root = -1;
  if (root_bone_.empty()) {
    problems.push_back({"root_bone", "IKBody: root_bone is empty; pick the bone the body hangs from (the hips), or "
                                     "call setup_humanoid()."});
  } else {
    root = int(skel.find_bone(text(root_bone_)));
    if (root < 0)
      problems.push_back({"root_bone", "IKBody: root_bone '" + root_bone_ +
                                           "' is not a bone of the parent Skeleton3D; pick one from the list."});
  }
  if (!solver_is_auto() && !solver_info(choice_kind()).trees)
    problems.push_back({"solver", std::string("IKBody: solver ") + solver_info(choice_kind()).display_name +
                                      " does not solve trees; pick Auto or a solver the list offers."});

  std::vector<int> parents(size_t(bone_count), -1);
  for (int i = 0; i < bone_count; ++i) parents[size_t(i)] = int(skel.get_bone_parent(i));

  // Effectors: each usable one becomes a slot; each problem names the element and the fix.
  std::vector<Slot> found;
  std::vector<int> effector_bones;
  const int64_t count = effectors_.size();
  for (int64_t i = 0; i < count; ++i) {
    const gdx::ObjectPtr object = object_at(effectors_, i);
    IKBodyEffector* e = IKBodyEffector::from_object(object);
    const std::string where = effector_label(int(i), e ? e->bone_name() : std::string());
    if (e == nullptr) {
      problems.push_back({"effectors", "IKBody: " + where + " is empty or not an IKBodyEffector; assign an "
                                                             "IKBodyEffector or remove the element.",
                          false});
      continue;
    }
    if (!e->is_enabled()) continue;
    if (e->bone_name().empty()) {
      problems.push_back(
          {"effectors", "IKBody: " + where + " has no bone_name; set it to a bone under root_bone.", false});
      continue;
    }
    const int bone = int(skel.find_bone(text(e->bone_name())));
    if (bone < 0) {
      problems.push_back({"effectors", "IKBody: " + where + ": bone '" + e->bone_name() +
                                           "' is not in the skeleton; set bone_name to one of its bones.",
                          false});
      continue;
    }
    bool duplicate = false;
    for (const Slot& s : found) {
      if (s.bone != e->bone_name()) continue;
      problems.push_back({"effectors", "IKBody: " + where + " names the same bone as effectors[" +
                                           std::to_string(s.index) + "]; only the first is used: remove one, or "
                                                                     "disable it.",
                          false});
      duplicate = true;
      break;
    }
    if (duplicate) continue;
    if (root >= 0) {
      std::vector<int> ignored;
      int outside = -1;
      const int one[1] = {bone};
      supporting_bones(Span<const int>(parents), root, Span<const int>(one, 1), ignored, outside);
      if (outside >= 0) {
        problems.push_back({"effectors", "IKBody: " + where + ": bone '" + e->bone_name() +
                                             "' is not under root_bone '" + root_bone_ +
                                             "', so the body cannot move it; pick a bone under root_bone or a "
                                             "root_bone above it.",
                            false});
        continue;
      }
    }
    if (e->get_priority() < IKBodyEffector::kMinPriority || e->get_priority() > IKBodyEffector::kMaxPriority) {
      const int64_t used =
          std::clamp<int64_t>(e->get_priority(), IKBodyEffector::kMinPriority, IKBodyEffector::kMaxPriority);
      problems.push_back({"effectors", "IKBody: " + where + ": priority " + std::to_string(e->get_priority()) +
                                           " is out of range 1..4 (1 = highest); it is used as " +
                                           std::to_string(used) + ". Set priority between 1 and 4.",
                          false});
    }
    if (!(e->get_position_weight() > 0.0) && !(e->get_rotation_weight() > 0.0))
      problems.push_back({"effectors", "IKBody: " + where + ": position_weight and rotation_weight are both 0, so it "
                                                            "pursues nothing; set one of them above 0, or disable it.",
                          false});
    if (!e->is_using_target_transform() && e->get_target().is_empty())
      problems.push_back({"effectors", "IKBody: " + where + " has no target; set target to a Node3D (or turn on "
                                                            "use_target_transform). It is skipped until then.",
                          false});
    Slot s;
    if (e->is_look_at()) {
      s.look = true;
      if (!(e->get_rotation_weight() > 0.0))
        problems.push_back({"effectors", "IKBody: " + where + ": look_at aims the bone with rotation_weight, which is "
                                                              "0; set rotation_weight above 0.",
                            false});
      const gdx::Array shares = e->get_look_shares();
      // How many bones the look can spread over: this bone and its ancestors up to root_bone.
      int chain = 0;
      for (int b = bone, steps = 0; b >= 0 && steps <= bone_count; b = parents[size_t(b)], ++steps) {
        ++chain;
        if (b == root) break;
      }
      bool bad = false;
      for (int64_t k = 0; k < shares.size(); ++k) {
        double v = 0.0;
        if (!gdx::variant_to(shares.at(k), v) || !std::isfinite(v) || v < 0.0) {
          v = 0.0;
          bad = true;
        }
        if (k < chain) s.look_share_list.push_back(v);
      }
      if (bad)
        problems.push_back({"effectors", "IKBody: " + where + ": look_shares holds a negative, non-finite or "
                                                              "non-number entry; it is used as 0. Make every share a "
                                                              "number >= 0.",
                            false});
      if (shares.size() > chain)
        problems.push_back({"effectors", "IKBody: " + where + ": look_shares has " + std::to_string(shares.size()) +
                                             " entries, but only " + std::to_string(chain) +
                                             " bones lead from it up to root_bone; the extra shares are ignored. "
                                             "Remove them.",
                            false});
      double sum = 0.0;
      for (double v : s.look_share_list) sum += v;
      if (!s.look_share_list.empty() && !(sum > 0.0)) {
        problems.push_back({"effectors", "IKBody: " + where + ": look_shares are all 0; the solver spreads the "
                                                              "look alone. Give the bones that turn a share above 0.",
                            false});
        s.look_share_list.clear();
      }
    }
    s.effector = e;
    s.skeleton_bone = bone;
    s.index = int(i);
    s.bone = e->bone_name();
    s.core_effector = int(found.size());
    found.push_back(s);
    effector_bones.push_back(bone);
    if (held) held->push_back(gdx::Variant::copy_of(effectors_.at(i)));
  }
  if (root < 0) return;
  if (found.empty()) {
    problems.push_back({"effectors", "IKBody: no enabled effector under root_bone; add an IKBodyEffector to "
                                     "effectors (or call setup_humanoid())."});
    return;
  }

  std::vector<int> order;
  int outside = -1;
  supporting_bones(Span<const int>(parents), root, Span<const int>(effector_bones), order, outside);
  if (order.empty()) return;  // (every effector was checked above)

  // Joints: each IKChainJoint names its bone.
  std::vector<const IKChainJoint*> joint_of(size_t(bone_count), nullptr);
  for (int64_t i = 0; i < joints_.size(); ++i) {
    const gdx::ObjectPtr object = object_at(joints_, i);
    const IKChainJoint* j = IKChainJoint::from_object(object);
    const std::string where = "joints[" + std::to_string(i) + "]";
    if (j == nullptr) {
      problems.push_back({"joints", "IKBody: " + where + " is empty or not an IKChainJoint; assign one or remove the "
                                                         "element.",
                          false});
      continue;
    }
    const int bone = int(skel.find_bone(text(j->bone_name())));
    if (bone < 0) {
      problems.push_back({"joints", "IKBody: " + where + ": bone '" + j->bone_name() +
                                        "' is not in the skeleton; set bone_name to one of its bones.",
                          false});
      continue;
    }
    if (joint_of[size_t(bone)] != nullptr) {
      problems.push_back({"joints", "IKBody: " + where + " names bone '" + j->bone_name() +
                                        "' again; only the first is used: remove one.",
                          false});
      continue;
    }
    joint_of[size_t(bone)] = j;
  }
  // A pole turns a limb about the line from its upper bone (the effector bone's grandparent, a
  // ball joint of the body) to the effector bone.
  for (Slot& s : found) {
    if (s.effector->get_pole_target().is_empty()) continue;
    const int mid = parents[size_t(s.skeleton_bone)];
    const int upper = (s.skeleton_bone == root || mid < 0 || mid == root) ? -1 : parents[size_t(mid)];
    const bool hinge = upper >= 0 && joint_of[size_t(upper)] != nullptr &&
                       joint_of[size_t(upper)]->settings().type == JointType::kHinge;
    if (upper < 0 || hinge) {
      problems.push_back({"effectors", "IKBody: " + effector_label(s.index, s.bone) +
                                           ": pole_target needs a limb: the bone must be at least two bones below "
                                           "root_bone, its grandparent a ball joint (the upper arm or leg). Clear "
                                           "pole_target or move the effector to the limb's end.",
                          false});
      continue;
    }
    s.pole_end = 0;  // a pole to resolve against the mapping
  }
  if (desc == nullptr) return;
  desc->floating_root = floating_root_;
  desc->bones.clear();
  std::vector<int> index_of(size_t(bone_count), -1);
  for (size_t k = 0; k < order.size(); ++k) {
    const int b = order[k];
    index_of[size_t(b)] = int(k);
    TreeBoneDesc bone;
    bone.name = skel.get_bone_name(b).utf8();
    bone.skeleton_bone = b;
    bone.parent = k == 0 ? -1 : index_of[size_t(parents[size_t(b)])];
    // The body is built from the rests (what the configuration is); the pose of each frame, which
    // an animation may spoil for a while, reshapes it per frame (SkeletonTree::update_pose).
    const glm::dmat4 rest = gdx::to_glm(skel.get_bone_rest(b));
    bone.rest_basis_in_parent = glm::dmat3(rest);
    bone.pose.position = glm::dvec3(rest[3]);
    bone.pose.rotation = rotation_of_basis(bone.rest_basis_in_parent);
    bone.pose.scale = glm::dvec3(glm::length(glm::dvec3(rest[0])), glm::length(glm::dvec3(rest[1])),
                                 glm::length(glm::dvec3(rest[2])));
    if (joint_of[size_t(b)] != nullptr) bone.joint = joint_of[size_t(b)]->settings();
    desc->bones.push_back(bone);
  }
  desc->effector_bones.clear();
  for (int b : effector_bones) desc->effector_bones.push_back(index_of[size_t(b)]);
  if (slots) *slots = found;
}

gdx::PackedStringArray IKBody::get_configuration_warnings() {
  const gdx::Skeleton3D skel = skeleton();
  // The rebuild the next frame would do anyway, done now: what the builder rejects comes from the
  // node's own body (body_problems_), not from a body built for the warnings alone.
  if (skel ? needs_rebuild(skel) : (dirty_ || built_skeleton_id_ != 0)) rebuild(skel);
  std::vector<Problem> problems;
  configure(skel, problems, nullptr, nullptr, nullptr);  // the rebuild's pass, for what changed since
  if (!scale_note_.empty()) problems.push_back({"root_bone", scale_note_, false});
  for (const Problem& p : body_problems_) {
    bool seen = false;
    for (const Problem& q : problems) seen = seen || q.message == p.message;
    if (!seen) problems.push_back(p);
  }
  gdx::PackedStringArray out;
  for (const Problem& p : problems) out.push_back(text(p.message));
  return out;
}

// ---------------------------------------------------------------- building

bool IKBody::needs_rebuild(const gdx::Skeleton3D& skel) const {
  if (dirty_ || skel.instance_id() != built_skeleton_id_ || skel.get_version() != built_skeleton_version_ ||
      effectors_.size() != effector_array_size_ || joints_.size() != built_joints_size_)
    return true;
  // A resource emitted `changed`: a target or a weight (read every frame) needs no rebuild.
  if (!resources_touched_) return false;
  resources_touched_ = false;
  return resource_revision() != built_revision_;
}

uint64_t IKBody::resource_revision() const {
  uint64_t h = 0;
  auto mix = [&h](gdx::ObjectPtr object, uint64_t revision) {
    h = h * 1099511628211ull + uint64_t(reinterpret_cast<uintptr_t>(object)) + revision;
  };
  for (int64_t i = 0; i < joints_.size(); ++i) {
    const gdx::ObjectPtr object = object_at(joints_, i);
    const IKChainJoint* j = IKChainJoint::from_object(object);
    mix(object, j ? j->revision() : 0);
  }
  for (int64_t i = 0; i < effectors_.size(); ++i) {
    const gdx::ObjectPtr object = object_at(effectors_, i);
    const IKBodyEffector* e = IKBodyEffector::from_object(object);
    mix(object, e ? e->revision() : 0);
  }
  return h;
}

void IKBody::rebuild(const gdx::Skeleton3D& skel) {
  dirty_ = false;
  anim_params_current_ = false;
  base_current_ = false;
  const bool was_ok = body_ok_;
  body_ok_ = false;
  body_problems_.clear();
  scale_note_.clear();
  slots_.clear();
  held_.clear();
  if (skel && skel.instance_id() != built_skeleton_id_) watch_skeleton(skel);
  built_skeleton_id_ = skel.instance_id();
  built_skeleton_version_ = skel ? skel.get_version() : -1;
  built_revision_ = resource_revision();
  resources_touched_ = false;
  built_joints_size_ = joints_.size();
  // Edits of these resources tell this node (and no other).
  listen_to(joints_);
  listen_to(effectors_);
  effector_array_size_ = int(effectors_.size());
  effector_position_error_.assign(size_t(effector_array_size_), kNaN);
  effector_rotation_error_.assign(size_t(effector_array_size_), kNaN);

  SkeletonTreeDesc desc;
  std::vector<Problem> problems;
  configure(skel, problems, &desc, &slots_, &held_);
  for (const Problem& p : problems)
    if (p.fatal) body_problems_.push_back(p);
  bool built = false;
  if (body_problems_.empty() && !desc.bones.empty()) {
    const Message error = mapping_.build(desc);
    if (!error.empty())
      body_problems_.push_back({"joints", std::string("IKBody: cannot build the body: ") + error.c_str()});
    built = error.empty();
    if (Message w = mapping_.scale_warning(); built && !w.empty()) scale_note_ = std::string("IKBody: ") + w.c_str();
  }
  if (built) {
    base_bone_ = int(skel.get_bone_parent(mapping_.skeleton_bone(0)));
    const int n = mapping_.bone_count();
    const int dofs = mapping_.tree().dof_count();
    const int max_goals = 2 * int(slots_.size());
    workspace_.reset(mapping_.tree(), max_goals);
    goals_.assign(size_t(max_goals), TreeGoal());
    goal_slot_.assign(size_t(max_goals), 0);
    goal_rotation_.assign(size_t(max_goals), 0);
    bone_poses_.assign(size_t(n), BonePose());
    rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
    params_ = Eigen::VectorXd::Zero(dofs);
    anim_params_ = Eigen::VectorXd::Zero(dofs);
    previous_anim_params_ = Eigen::VectorXd::Constant(dofs, kNaN);
    last_params_ = Eigen::VectorXd::Zero(dofs);
    posture_stiffness_.assign(size_t(dofs), JointSettings().posture_stiffness);
    mapping_.posture_stiffness(posture_stiffness_.data());
    posture_ = Eigen::VectorXd::Zero(dofs);
    for (Slot& slot : slots_)
      slot.pole_end = slot.pole_end < 0 ? -1 : mapping_.bone_of(slot.skeleton_bone);
    for (Slot& slot : slots_)
      if (slot.pole_end >= 0 && mapping_.pole_upper_bone(slot.pole_end) < 0) slot.pole_end = -1;
    // A look's bones: its bone and the ancestors its shares name, root-most first.
    for (Slot& slot : slots_) {
      slot.look_bones.clear();
      slot.look_shares.clear();
      if (!slot.look || slot.look_share_list.empty()) continue;
      int b = mapping_.bone_of(slot.skeleton_bone);
      for (size_t k = 0; k < slot.look_share_list.size() && b >= 0; ++k, b = mapping_.tree().parent(b)) {
        slot.look_bones.insert(slot.look_bones.begin(), b);
        slot.look_shares.insert(slot.look_shares.begin(), slot.look_share_list[k]);
      }
    }
    look_goals_.assign(slots_.size(), 0);
    look_goals_.clear();
    have_last_ = false;
    body_ok_ = true;
  } else {
    slots_.clear();
    held_.clear();
  }
  if (body_ok_ != was_ok) gdx::Node::unchecked(owner_).update_configuration_warnings();
}

SolverKind IKBody::resolved_solver() const {
  // Auto: damped least squares, the coupled solver with priority levels.
  return solver_is_auto() ? SolverKind::kDLS : choice_kind();
}

}  // namespace ikchain::godot
