#include "ik_body.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "core/so3.hpp"
#include "ik_body_effector.hpp"
#include "ik_chain_joint.hpp"
#include "node_util.hpp"
#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;

namespace {

constexpr const char* kClass = "IKBody";
constexpr IKModifier::Traits kTraits{kClass, IKBody::kDefaultMaxIterations, "[1e-06, 1] m",
                                     /*solver_change_rebuilds=*/true, /*deterministic_is_cold_start=*/false,
                                     "IKBody: the parent is not a Skeleton3D.",
                                     "IKBody: the parent is not a Skeleton3D; make IKBody a child of a Skeleton3D."};
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string effector_label(int index, const std::string& bone) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "effectors[%d]%s%s%s", index, bone.empty() ? "" : " ('", bone.c_str(),
                bone.empty() ? "" : "')");
  return buf;
}

}  // namespace

// ---------------------------------------------------------------- registration

void IKBody::register_class(gdx::ClassRecord& record) {
  gdx::ClassBuilder<IKBody> b(record);
  b.register_class();

  b.method("set_floating_root", &IKBody::set_floating_root, {"enabled"});
  b.method("is_floating_root", &IKBody::is_floating_root);
  b.method("set_effectors", &IKBody::set_effectors, {"effectors"});
  b.method("get_effectors", &IKBody::get_effectors, {}, {nullptr, "IKBodyEffector"});
  b.method("set_joints", &IKBody::set_joints, {"joints"});
  b.method("get_joints", &IKBody::get_joints, {}, {nullptr, "IKChainJoint"});
  b.method("get_last_result", &IKBody::get_last_result);
  b.method("get_last_reason", &IKBody::get_last_reason);
  b.method("is_last_usable", &IKBody::is_last_usable);
  b.method("get_last_iterations", &IKBody::get_last_iterations);
  b.method("get_last_usec", &IKBody::get_last_usec);
  b.method("get_last_position_error", &IKBody::get_last_position_error);
  b.method("get_last_orientation_error", &IKBody::get_last_orientation_error);
  b.method("get_last_effector_position_error", &IKBody::get_last_effector_position_error, {"index"});
  b.method("get_last_effector_rotation_error", &IKBody::get_last_effector_rotation_error, {"index"});
  b.method("is_last_level_met", &IKBody::is_last_level_met, {"level"});
  b.method("solve_now", &IKBody::solve_now);
  b.method("get_body_bones", &IKBody::get_body_bones);
  b.method("setup_humanoid", &IKBody::setup_humanoid);
  b.method("_get_configuration_warnings", &IKBody::get_configuration_warnings);

  IKModifier::bind_root_bone(b);
  b.property({"floating_root", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_floating_root", "is_floating_root");
  b.property({"effectors", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING, "24/17:IKBodyEffector"},
             "set_effectors", "get_effectors");
  b.property({"joints", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING, "24/17:IKChainJoint"},
             "set_joints", "get_joints");
  b.group("Solver", "");
  IKModifier::bind_solver_settings(b, "IKBody.Solver", /*trees_only=*/true);
  IKModifier::bind_deterministic(b);

  b.virtual_method("_process_modification_with_delta",
                   gdx::gen::kVirtualHash_SkeletonModifier3D__process_modification_with_delta,
                   &IKBody::process_modification);
  b.virtual_method("_get_configuration_warnings", gdx::gen::kVirtualHash_Node__get_configuration_warnings,
                   &IKBody::get_configuration_warnings);
  b.virtual_method("_skeleton_changed", gdx::gen::kVirtualHash_SkeletonModifier3D__skeleton_changed,
                   &IKBody::skeleton_changed);
}

void IKBody::unregister_class() {}

IKBody::IKBody(gdx::ObjectPtr owner) : IKModifier(owner, kTraits) {
  options_.warm_start = true;  // the start is the animated pose (or the last solve), never the rest pose
}

// ---------------------------------------------------------------- properties

void IKBody::set_floating_root(bool on) {
  if (on == floating_root_) return;
  floating_root_ = on;
  mark_dirty();
}

void IKBody::set_effectors(const gdx::Array& effectors) {
  stop_listening_to(effectors_);  // the rebuild listens to the new ones
  effectors_ = effectors;
  mark_dirty();
}

void IKBody::set_joints(const gdx::Array& joints) {
  stop_listening_to(joints_);
  joints_ = joints;
  mark_dirty();
}

// ---------------------------------------------------------------- results

gdx::String IKBody::get_last_reason() const {
  return gdx::String(has_result_ ? reason_name(last_.summary.reason) : "not_run");
}
bool IKBody::is_last_usable() const { return has_result_ && last_.usable(); }
double IKBody::get_last_position_error() const { return last_.summary.final_position_error; }
double IKBody::get_last_orientation_error() const { return last_.summary.final_orientation_error; }

double IKBody::get_last_effector_position_error(int64_t index) const {
  if (index < 0 || index >= int64_t(effector_position_error_.size())) return kNaN;
  return effector_position_error_[size_t(index)];
}
double IKBody::get_last_effector_rotation_error(int64_t index) const {
  if (index < 0 || index >= int64_t(effector_rotation_error_.size())) return kNaN;
  return effector_rotation_error_[size_t(index)];
}
bool IKBody::is_last_level_met(int64_t level) const {
  if (!is_last_usable() || level < 1 || level > kMaxPriorityLevels) return false;
  return last_.level_met[size_t(level - 1)];
}

gdx::Dictionary IKBody::get_last_result() const {
  gdx::Dictionary d;
  auto put = [&d](const char* key, const gdx::Variant& value) { d.set(gdx::Variant(key), value); };
  put("reason", gdx::Variant(get_last_reason()));
  put("usable", gdx::Variant(is_last_usable()));
  put("iterations", gdx::Variant(get_last_iterations()));
  put("usec", gdx::Variant(get_last_usec()));
  put("position_error", gdx::Variant(get_last_position_error()));
  put("orientation_error", gdx::Variant(get_last_orientation_error()));
  put("message", gdx::Variant(last_.summary.message.c_str()));
  gdx::Array levels;
  for (int l = 1; l <= kMaxPriorityLevels; ++l) levels.push_back(gdx::Variant(is_last_level_met(l)));
  put("levels_met", gdx::Variant(levels));
  gdx::Array position_errors, rotation_errors;
  for (size_t i = 0; i < effector_position_error_.size(); ++i) {
    position_errors.push_back(gdx::Variant(effector_position_error_[i]));
    rotation_errors.push_back(gdx::Variant(effector_rotation_error_[i]));
  }
  put("effector_position_errors", gdx::Variant(position_errors));
  put("effector_rotation_errors", gdx::Variant(rotation_errors));
  return d;
}

gdx::Dictionary IKBody::solve_now() {
  run_now();
  return get_last_result();
}

gdx::PackedInt32Array IKBody::get_body_bones() {
  const gdx::Skeleton3D skel = skeleton();
  if (skel && needs_rebuild(skel)) rebuild(skel);
  gdx::PackedInt32Array out;
  if (!body_ok_) return out;
  for (int i = 0; i < mapping_.bone_count(); ++i) out.push_back(mapping_.skeleton_bone(i));
  return out;
}

// ---------------------------------------------------------------- editor

bool IKBody::validate_property(GDExtensionPropertyInfo& property) {
  if (!is_bone_property(property.name)) return false;
  bone_drop_down(property);
  return true;
}

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
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(effectors_.at(i), object);
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
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(joints_.at(i), object);
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
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(joints_.at(i), object);
    const IKChainJoint* j = IKChainJoint::from_object(object);
    mix(object, j ? j->revision() : 0);
  }
  for (int64_t i = 0; i < effectors_.size(); ++i) {
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(effectors_.at(i), object);
    const IKBodyEffector* e = IKBodyEffector::from_object(object);
    mix(object, e ? e->revision() : 0);
  }
  return h;
}

void IKBody::rebuild(const gdx::Skeleton3D& skel) {
  dirty_ = false;
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
    posture_stiffness_.assign(size_t(dofs), kPostureStiffness);
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
  for (int i = 0; i < n; ++i) {
    const int bone = mapping_.skeleton_bone(i);
    BonePose& p = bone_poses_[size_t(i)];
    p.position = gdx::to_glm(skel.get_bone_pose_position(bone));
    p.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bone));
    p.scale = gdx::to_glm(skel.get_bone_pose_scale(bone));
  }
  const PoseUpdate update = mapping_.update_pose(bone_poses_);
  if (!update.error.empty()) {
    report_runtime(std::string("IKBody: ") + update.error.c_str() + "; the animated pose is kept this frame.");
    set_invalid_result(update.error.c_str());
    return false;
  }
  if (update.shape_changed) workspace_.reset(mapping_.tree(), int(goals_.size()));  // same sizes: no reallocation

  mapping_.params_from_pose(anim_params_.data());
  // Warm start: the animated pose; while it stays the same (no animation playing), the last
  // solution, which tracks moving targets smoothly. `deterministic`: always the animated pose,
  // so the output depends on this frame's inputs alone.
  const bool animation_still = anim_params_ == previous_anim_params_;
  params_ = (!deterministic_ && have_last_ && animation_still) ? last_params_ : anim_params_;
  previous_anim_params_ = anim_params_;

  const glm::dmat4 base_bone = base_bone_ >= 0 ? gdx::to_glm(skel.get_bone_global_pose(base_bone_)) : glm::dmat4(1.0);
  BaseFrame base;
  if (!BaseFrame::make(gdx::to_glm(skel.get_global_transform()), base_bone, base)) {
    const char* bad = "IKBody: the skeleton's global transform (or the root bone's parent pose) is not invertible: a "
                      "zero scale? The animated pose is kept this frame.";
    report_runtime(bad);
    set_invalid_result(bad);
    return false;
  }

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
    const gdx::Node3D pole = gdx::Node3D::cast(self.get_node_or_null(slot.effector->get_pole_target()));
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

  // The animated effector poses: what an effector with influence < 1 blends from.
  const Tree& tree = mapping_.tree();
  tree_forward_kinematics(tree, anim_params_.data(), workspace_);
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
      if (e.get_target().is_empty()) continue;  // a configuration warning says so
      const gdx::Node3D node = gdx::Node3D::cast(self.get_node_or_null(e.get_target()));
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
      const glm::dvec3 origin = tree_effector_position(tree, workspace_, slot.core_effector);
      const glm::dvec3 target = mapping_.point_in_tree(base.point_in_base(glm::dvec3(target_m[3])));
      if (!within_magnitude(target)) {
        report_runtime("IKBody: " + effector_label(slot.index, slot.bone) +
                       ": the target is absurdly far (beyond 1e50 m); the effector follows the animation.");
        continue;
      }
      const glm::dvec3 axis = glm::normalize(glm::dvec3(gdx::to_glm(e.get_look_axis())));
      glm::dvec3 point = target;
      if (influence < 1.0) {
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
      const double length = std::max(tree.reach_from_root(slot.core_effector), 1e-3);
      goals_[size_t(goal_count)] = {Goal::aim_at(point, axis, slot.core_effector, wr * length * length), level};
      goal_slot_[size_t(goal_count)] = s;
      goal_rotation_[size_t(goal_count)] = 1;
      if (!slot.look_bones.empty()) look_goals_.push_back(goal_count);
      ++goal_count;
      continue;
    }
    if (wp > 0.0) {
      const glm::dvec3 animated = tree_effector_position(tree, workspace_, slot.core_effector);
      const glm::dvec3 target = mapping_.point_in_tree(base.point_in_base(glm::dvec3(target_m[3])));
      const glm::dvec3 goal = influence >= 1.0 ? target : glm::mix(animated, target, influence);
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
    if (wr > 0.0 && has_rotation(glm::dmat3(target_m))) {
      const glm::dquat animated = tree_effector_orientation(tree, workspace_, slot.core_effector);
      const glm::dquat target = base.rotation_in_base(target_m);
      const glm::dquat goal = influence >= 1.0 ? target : godot_slerp(animated, target, influence);
      // A radian counts like the effector's reach from the root in metres (rotation_weight 1).
      const double length = std::max(tree.reach_from_root(slot.core_effector), 1e-3);
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
  // Tracking frames start from the last solution and go on toward the posture frame after frame, so
  // a frame stops a few posture steps after its goals are met instead of waiting for the posture to
  // settle (~20 iterations a frame at stiffness 0.1). `deterministic` frames all start from the
  // incoming pose: they let it settle, so the output depends on this frame's inputs alone.
  problem.posture_iterations = deterministic_ ? 0 : kTrackingPostureIterations;
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
  for (int g = 0; g < goal_count; ++g) {
    const int index = slots_[size_t(goal_slot_[size_t(g)])].index;
    std::vector<double>& errors = goal_rotation_[size_t(g)] ? effector_rotation_error_ : effector_position_error_;
    errors[size_t(index)] = last_.goal_error[size_t(g)];
  }
  return true;
}

}  // namespace ikchain::godot

// ---------------------------------------------------------------- humanoid set-up

namespace ikchain::godot {

namespace {

constexpr double kDeg = so3::kPi / 180.0;

// The bones setup_humanoid() uses: Godot's SkeletonProfileHumanoid names.
constexpr const char* kHumanoidBones[] = {
    "Hips",         "Spine",        "Chest",        "UpperChest",    "Neck",          "Head",
    "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",     "RightUpperLeg", "RightLowerLeg", "RightFoot",
    "LeftShoulder", "LeftUpperArm", "LeftLowerArm", "LeftHand",      "RightShoulder", "RightUpperArm",
    "RightLowerArm", "RightHand"};

// A new instance of one of our resource classes, held by the returned Variant.
gdx::Variant new_resource(const char* class_name, gdx::ObjectPtr& object) {
  const gdx::StringName name{std::string_view(class_name)};
  object = gdx::gde.classdb_construct_object2(name.ptr());
  return gdx::Variant::from_object(object);
}

// A bone's rest in skeleton space (the rests composed up its parents).
glm::dmat4 global_rest(const gdx::Skeleton3D& skel, int bone) {
  glm::dmat4 m(1.0);
  const int64_t count = skel.get_bone_count();
  for (int64_t steps = 0; bone >= 0 && steps <= count; ++steps) {
    m = gdx::to_glm(skel.get_bone_rest(bone)) * m;
    bone = int(skel.get_bone_parent(bone));
  }
  return m;
}

}  // namespace

bool IKBody::setup_humanoid() {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    IKCHAIN_PRINT_ERROR("IKBody.setup_humanoid(): the parent is not a Skeleton3D; make IKBody a child of a Skeleton3D "
                        "that uses Godot's humanoid bone names (SkeletonProfileHumanoid). Nothing was changed.");
    return false;
  }
  std::string missing;
  for (const char* bone : kHumanoidBones)
    if (skel.find_bone(gdx::String(bone)) < 0) missing += std::string(missing.empty() ? "" : ", ") + bone;
  if (!missing.empty()) {
    const std::string message =
        "IKBody.setup_humanoid(): the skeleton lacks the humanoid bones " + missing +
        "; it needs Godot's SkeletonProfileHumanoid names (retarget the model on import with a BoneMap). Nothing "
        "was changed.";
    IKCHAIN_PRINT_ERROR(message.c_str());
    return false;
  }
  auto bone_of = [&](const char* name) { return int(skel.find_bone(gdx::String(name))); };

  // Effectors: contacts at level 1 (the hips only softly), hands at 2, the head's look at 3.
  struct EffectorSpec {
    const char* bone;
    int64_t priority;
    double position_weight, rotation_weight;
  };
  constexpr EffectorSpec kEffectors[] = {{"Hips", 1, 0.1, 0.1},     {"LeftFoot", 1, 1.0, 1.0},
                                         {"RightFoot", 1, 1.0, 1.0}, {"LeftHand", 2, 1.0, 0.0},
                                         {"RightHand", 2, 1.0, 0.0}, {"Head", 3, 0.0, 1.0}};
  gdx::Array effectors;
  for (const EffectorSpec& spec : kEffectors) {
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKBodyEffector", object);
    IKBodyEffector* e = IKBodyEffector::from_object(object);
    if (e == nullptr) return false;
    e->set_bone_name(gdx::String(spec.bone));
    e->set_priority(spec.priority);
    e->set_position_weight(spec.position_weight);
    e->set_rotation_weight(spec.rotation_weight);
    if (std::string_view(spec.bone) == "Head") {
      // Ready to look (turn on look_at): the turn spread over head, neck, upper chest, chest, spine.
      gdx::Array shares;
      for (double share : {0.35, 0.25, 0.15, 0.15, 0.1}) shares.push_back(gdx::Variant(share));
      e->set_look_shares(shares);
    }
    effectors.push_back(held);
  }

  // Joints: knees and elbows as hinges with human ranges, bending the way the rest pose says;
  // spine, chest and neck with cones.
  gdx::Array joints;
  auto add_hinge = [&](const char* bone, const char* child, bool bends_forward) {
    const glm::dmat4 rest = global_rest(skel, bone_of(bone));
    const glm::dvec3 axis_in_skeleton = glm::normalize(glm::dvec3(rest[0]));  // the bone's +X
    const glm::dvec3 child_in_bone = gdx::to_glm(skel.get_bone_rest(bone_of(child)).origin);
    const glm::dvec3 along = glm::dmat3(rest) * child_in_bone;
    // +X turns the child toward axis x along; the character faces +Z: knees bend it back, elbows forward.
    const double forward = glm::cross(axis_in_skeleton, along).z;
    const double sign = (forward > 0.0) == bends_forward ? 1.0 : -1.0;
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKChainJoint", object);
    IKChainJoint* j = gdx::instance_of<IKChainJoint>(object, gdx::String("IKChainJoint"));
    if (j == nullptr) return;
    j->set_bone_name(gdx::String(bone));
    j->set_type(IKChainJoint::JOINT_HINGE);
    j->set_hinge_axis(gdx::from_glm(glm::dvec3(sign, 0.0, 0.0)));
    j->set_hinge_limit_enabled(true);
    j->set_hinge_min(0.0);
    j->set_hinge_max(150.0 * kDeg);
    joints.push_back(held);
  };
  auto add_cone = [&](const char* bone, double cone_deg, double twist_deg, double motion_cost) {
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKChainJoint", object);
    IKChainJoint* j = gdx::instance_of<IKChainJoint>(object, gdx::String("IKChainJoint"));
    if (j == nullptr) return;
    j->set_bone_name(gdx::String(bone));
    j->set_cone_limit_enabled(true);
    j->set_cone_angle(cone_deg * kDeg);
    j->set_twist_limit_enabled(true);
    j->set_twist_min(-twist_deg * kDeg);
    j->set_twist_max(twist_deg * kDeg);
    j->set_motion_cost(motion_cost);
    joints.push_back(held);
  };
  add_hinge("LeftLowerLeg", "LeftFoot", false);
  add_hinge("RightLowerLeg", "RightFoot", false);
  add_hinge("LeftLowerArm", "LeftHand", true);
  add_hinge("RightLowerArm", "RightHand", true);
  // The spine bends reluctantly (motion cost 2): arms reach first, the spine joins when they cannot.
  add_cone("Spine", 30.0, 30.0, 2.0);
  add_cone("Chest", 30.0, 30.0, 2.0);
  add_cone("UpperChest", 30.0, 30.0, 2.0);
  add_cone("Neck", 40.0, 60.0, 1.0);

  set_root_bone(gdx::String("Hips"));
  set_floating_root(true);
  set_joints(joints);
  set_effectors(effectors);
  gdx::Object(owner_).notify_property_list_changed();
  return true;
}

}  // namespace ikchain::godot
