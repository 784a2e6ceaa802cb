#include "ik_chain.hpp"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <memory>

#include "binding/engine.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "core/so3.hpp"

namespace ikchain::godot {

using gdx::call;
using gdx::ObjectPtr;
using M = gdx::gen::Method;
namespace hint = gdx::gen::PropertyHint;
namespace usage = gdx::gen::PropertyUsageFlags;

namespace {

// StringNames the instances compare against; allocated at SCENE init, freed at deinit.
struct Names {
  gdx::StringName root_bone{"root_bone"};
  gdx::StringName tip_bone{"tip_bone"};
  gdx::StringName bone_list_changed{"bone_list_changed"};
  gdx::StringName rest_updated{"rest_updated"};
  gdx::StringName on_skeleton_bones_changed{"_on_skeleton_bones_changed"};
};
Names* g_names = nullptr;

constexpr const char* kSolverHint = "Two Bone,CCD,Jacobian Pseudo-Inverse,Damped Least Squares,BFGS,FABRIK";

// Messages of the per-frame checks: constant text, so reporting them allocates nothing.
constexpr const char* kNoSkeleton = "IKChain: the parent is not a Skeleton3D; make IKChain a child of a Skeleton3D.";
constexpr const char* kNoTarget =
    "IKChain: target is empty or does not point to a Node3D inside the scene tree; set target to the Node3D the "
    "tip should reach.";
constexpr const char* kBadTarget = "IKChain: the target's position is not finite; the pose was left unchanged.";
constexpr const char* kNonFinite =
    "IKChain: the solver produced a non-finite rotation; the pose was left unchanged.";

const char* reason_name(TerminationReason r) {
  switch (r) {
    case TerminationReason::kConverged: return "converged";
    case TerminationReason::kMaxIterations: return "max_iterations";
    case TerminationReason::kStalled: return "stalled";
    case TerminationReason::kUnreachable: return "unreachable";
    case TerminationReason::kInvalidInput: return "invalid_input";
  }
  return "invalid_input";
}

glm::dquat rotation_of(const gdx::Basis& basis) {
  // Bone rests may carry scale: orthonormalize the columns before taking the rotation.
  glm::dmat3 m = gdx::to_glm(basis);
  for (int c = 0; c < 3; ++c) {
    const double len = glm::length(m[c]);
    if (len > 0.0) m[c] /= len;
  }
  return glm::normalize(glm::quat_cast(m));
}

// The modifier's skeleton; before the node enters the tree get_skeleton() has not cached it yet,
// so fall back to the parent (the editor asks for warnings at any time).
ObjectPtr find_skeleton(ObjectPtr owner) {
  ObjectPtr skeleton = gdx::cast_to<gdx::ClassTag::Skeleton3D>(call<ObjectPtr>(M::SkeletonModifier3D_get_skeleton, owner));
  if (skeleton == nullptr) skeleton = gdx::cast_to<gdx::ClassTag::Skeleton3D>(call<ObjectPtr>(M::Node_get_parent, owner));
  return skeleton;
}

uint64_t gde_instance_id(ObjectPtr object) { return gdx::gde.object_get_instance_id(object); }

gdx::String text(const std::string& s) { return gdx::String(std::string_view(s)); }

// --- bound-method thunks (plain functions; the class builder wraps them for both call paths) ---
void b_set_root_bone(IKChain& s, gdx::String v) { s.set_root_bone(v); }
gdx::String b_get_root_bone(IKChain& s) { return s.get_root_bone(); }
void b_set_tip_bone(IKChain& s, gdx::String v) { s.set_tip_bone(v); }
gdx::String b_get_tip_bone(IKChain& s) { return s.get_tip_bone(); }
void b_set_target(IKChain& s, gdx::NodePath v) { s.set_target(v); }
gdx::NodePath b_get_target(IKChain& s) { return s.get_target(); }
void b_set_solver(IKChain& s, int64_t v) { s.set_solver(v); }
int64_t b_get_solver(IKChain& s) { return s.get_solver(); }
void b_set_max_iterations(IKChain& s, int64_t v) { s.set_max_iterations(v); }
int64_t b_get_max_iterations(IKChain& s) { return s.get_max_iterations(); }
void b_set_tolerance(IKChain& s, double v) { s.set_tolerance(v); }
double b_get_tolerance(IKChain& s) { return s.get_tolerance(); }
void b_set_deterministic(IKChain& s, bool v) { s.set_deterministic(v); }
bool b_is_deterministic(IKChain& s) { return s.is_deterministic(); }
gdx::Dictionary b_get_last_result(IKChain& s) { return s.get_last_result(); }
gdx::PackedStringArray b_get_configuration_warnings(IKChain& s) { return s.get_configuration_warnings(); }
void b_on_skeleton_bones_changed(IKChain& s) { s.skeleton_changed(); }

// --- virtual thunks: ptrcall encoding (float -> double*, PackedStringArray* return slot) ---
void v_process_modification_with_delta(void* self, const GDExtensionConstTypePtr* args, GDExtensionTypePtr) {
  static_cast<IKChain*>(self)->process_modification(*static_cast<const double*>(args[0]));
}
void v_get_configuration_warnings(void* self, const GDExtensionConstTypePtr*, GDExtensionTypePtr r_ret) {
  *static_cast<gdx::PackedStringArray*>(r_ret) = static_cast<IKChain*>(self)->get_configuration_warnings();
}
void v_skeleton_changed(void* self, const GDExtensionConstTypePtr*, GDExtensionTypePtr) {
  static_cast<IKChain*>(self)->skeleton_changed();
}

}  // namespace

void IKChain::register_class(gdx::ClassRecord& record) {
  g_names = new Names();
  gdx::ClassBuilder<IKChain> b(record);
  b.register_class(/*has_validate_property=*/true, /*has_notification=*/true);

  b.method("set_root_bone", &b_set_root_bone, {"bone_name"});
  b.method("get_root_bone", &b_get_root_bone, {}, true);
  b.method("set_tip_bone", &b_set_tip_bone, {"bone_name"});
  b.method("get_tip_bone", &b_get_tip_bone, {}, true);
  b.method("set_target", &b_set_target, {"path"});
  b.method("get_target", &b_get_target, {}, true);
  b.method("set_solver", &b_set_solver, {"solver"});
  b.method("get_solver", &b_get_solver, {}, true);
  b.method("set_max_iterations", &b_set_max_iterations, {"iterations"});
  b.method("get_max_iterations", &b_get_max_iterations, {}, true);
  b.method("set_tolerance", &b_set_tolerance, {"meters"});
  b.method("get_tolerance", &b_get_tolerance, {}, true);
  b.method("set_deterministic", &b_set_deterministic, {"enabled"});
  b.method("is_deterministic", &b_is_deterministic, {}, true);
  b.method("get_last_result", &b_get_last_result, {}, true);
  // Also callable from scripts (as godot-cpp does for bound virtuals); the editor uses the virtual.
  b.method("_get_configuration_warnings", &b_get_configuration_warnings, {}, true);
  // Target of the skeleton's bone_list_changed / rest_updated signals (marks the chain dirty).
  b.method("_on_skeleton_bones_changed", &b_on_skeleton_bones_changed, {});

  const char* solver_constants[] = {"SOLVER_TWO_BONE", "SOLVER_CCD", "SOLVER_JACOBIAN",
                                    "SOLVER_DLS",      "SOLVER_BFGS", "SOLVER_FABRIK"};
  for (int i = 0; i < 6; ++i) b.constant("Solver", solver_constants[i], i);

  // root_bone / tip_bone get their bone-name drop-down in validate_property().
  b.property({"root_bone", GDEXTENSION_VARIANT_TYPE_STRING, hint::PROPERTY_HINT_ENUM, ""}, "set_root_bone",
             "get_root_bone");
  b.property({"tip_bone", GDEXTENSION_VARIANT_TYPE_STRING, hint::PROPERTY_HINT_ENUM, ""}, "set_tip_bone",
             "get_tip_bone");
  b.property({"target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_target", "get_target");
  b.property({"solver", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, kSolverHint}, "set_solver",
             "get_solver");
  b.property({"max_iterations", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "1,1000,1"},
             "set_max_iterations", "get_max_iterations");
  b.property({"tolerance", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0.000001,1,0.000001,exp,suffix:m"},
             "set_tolerance", "get_tolerance");
  b.property({"deterministic", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_deterministic", "is_deterministic");

  b.virtual_override("_process_modification_with_delta",
                     gdx::gen::kVirtualHash_SkeletonModifier3D__process_modification_with_delta,
                     &v_process_modification_with_delta);
  b.virtual_override("_get_configuration_warnings", gdx::gen::kVirtualHash_Node__get_configuration_warnings,
                     &v_get_configuration_warnings);
  b.virtual_override("_skeleton_changed", gdx::gen::kVirtualHash_SkeletonModifier3D__skeleton_changed,
                     &v_skeleton_changed);
}

void IKChain::unregister_class() {
  delete g_names;
  g_names = nullptr;
}

IKChain::IKChain(ObjectPtr owner) : owner_(owner) {
  options_.max_iterations = int(max_iterations_);
  options_.position_tolerance = tolerance_;
  options_.warm_start = !deterministic_;
}

// ---------------------------------------------------------------- properties

void IKChain::mark_dirty() {
  dirty_ = true;
  call(M::Node_update_configuration_warnings, owner_);
}

void IKChain::set_root_bone(const gdx::String& name) {
  root_bone_ = name.utf8();
  mark_dirty();
}
gdx::String IKChain::get_root_bone() const { return text(root_bone_); }

void IKChain::set_tip_bone(const gdx::String& name) {
  tip_bone_ = name.utf8();
  mark_dirty();
}
gdx::String IKChain::get_tip_bone() const { return text(tip_bone_); }

void IKChain::set_target(const gdx::NodePath& path) {
  target_ = path;
  call(M::Node_update_configuration_warnings, owner_);
}
gdx::NodePath IKChain::get_target() const { return target_; }

// Out-of-range values from scripts (the editor's range hints already prevent them there) are
// clamped to the nearest valid value with an error naming the property, the range and the value used.
namespace {
void report_clamped(const char* property, const char* range, double given, double used) {
  char message[256];
  std::snprintf(message, sizeof(message), "IKChain: %s must be in %s, got %g; using %g.", property, range, given,
                used);
  IKCHAIN_PRINT_ERROR(message);
}
}  // namespace

void IKChain::set_solver(int64_t solver) {
  solver_ = std::clamp<int64_t>(solver, SOLVER_TWO_BONE, SOLVER_FABRIK);
  if (solver_ != solver) report_clamped("solver", "0..5 (IKChain.SOLVER_*)", double(solver), double(solver_));
  mark_dirty();
}

void IKChain::set_max_iterations(int64_t n) {
  max_iterations_ = std::clamp<int64_t>(n, 1, 1000);
  if (max_iterations_ != n) report_clamped("max_iterations", "1..1000", double(n), double(max_iterations_));
  options_.max_iterations = int(max_iterations_);
}

void IKChain::set_tolerance(double meters) {
  if (std::isnan(meters)) {
    report_clamped("tolerance", "[1e-06, 1] m", meters, tolerance_);  // keeps the last valid value
    return;
  }
  tolerance_ = std::clamp(meters, 1e-6, 1.0);
  if (tolerance_ != meters) report_clamped("tolerance", "[1e-06, 1] m", meters, tolerance_);
  options_.position_tolerance = tolerance_;
}

void IKChain::set_deterministic(bool on) {
  deterministic_ = on;
  options_.warm_start = !on;
}

gdx::Dictionary IKChain::get_last_result() const {
  gdx::Dictionary d;
  d.set(gdx::Variant("reason"), gdx::Variant(has_result_ ? reason_name(last_.reason) : "not_run"));
  d.set(gdx::Variant("iterations"), gdx::Variant(int64_t(has_result_ ? last_.iterations : 0)));
  d.set(gdx::Variant("initial_error"), gdx::Variant(has_result_ ? last_.initial_error : 0.0));
  d.set(gdx::Variant("final_error"), gdx::Variant(has_result_ ? last_.final_error : 0.0));
  d.set(gdx::Variant("microseconds"), gdx::Variant(has_result_ ? last_.elapsed_us : 0.0));
  d.set(gdx::Variant("usable"), gdx::Variant(has_result_ && last_.usable()));
  return d;
}

// ---------------------------------------------------------------- editor

bool IKChain::validate_property(GDExtensionPropertyInfo& property) {
  if (g_names == nullptr) return false;
  const bool is_bone = g_names->root_bone.equals(property.name) || g_names->tip_bone.equals(property.name);
  if (!is_bone) return false;
  const ObjectPtr skeleton = find_skeleton(owner_);
  if (skeleton == nullptr) {
    property.hint = uint32_t(hint::PROPERTY_HINT_NONE);  // free text until there is a skeleton
    return true;
  }
  // The same drop-down Godot's own modifiers use: "bone0,bone1,...".
  const gdx::String names(call<gdx::StringName>(M::Skeleton3D_get_concatenated_bone_names, skeleton));
  property.hint = uint32_t(hint::PROPERTY_HINT_ENUM);
  gdx::String::assign_to(property.hint_string, names);
  return true;
}

void IKChain::watch_skeleton(ObjectPtr skeleton) {
  if (skeleton == nullptr || g_names == nullptr) return;
  const gdx::Callable callback(owner_, g_names->on_skeleton_bones_changed);
  for (const gdx::StringName* signal : {&g_names->bone_list_changed, &g_names->rest_updated}) {
    if (!call<bool>(M::Object_is_connected, skeleton, *signal, callback))
      call<int64_t>(M::Object_connect, skeleton, *signal, callback, int64_t(0));
  }
}

void IKChain::skeleton_changed() {
  dirty_ = true;
  call(M::Object_notify_property_list_changed, owner_);
}

void IKChain::collect_chain_problems(ObjectPtr skeleton, std::vector<Problem>& problems,
                                     std::vector<int>* joint_bones, int* tip_index) const {
  if (skeleton == nullptr) {
    problems.push_back({"parent", kNoSkeleton});
    return;
  }
  auto bone_index = [&](const char* prop, const std::string& name) -> int {
    if (name.empty()) {
      problems.push_back({prop, std::string("IKChain: ") + prop + " is empty; pick a bone of the parent Skeleton3D "
                                "in the " + prop + " property."});
      return -1;
    }
    const int idx = int(call<int64_t>(M::Skeleton3D_find_bone, skeleton, text(name)));
    if (idx < 0)
      problems.push_back({prop, std::string("IKChain: ") + prop + " '" + name +
                                    "' is not a bone of the parent Skeleton3D; pick one from the " + prop +
                                    " drop-down."});
    return idx;
  };
  const int root = bone_index("root_bone", root_bone_);
  const int tip = bone_index("tip_bone", tip_bone_);
  if (root < 0 || tip < 0) return;

  // Joints: tip's parent up to root (then reversed, root first).
  std::vector<int> joints;
  int b = int(call<int64_t>(M::Skeleton3D_get_bone_parent, skeleton, int64_t(tip)));
  const int64_t bone_count = call<int64_t>(M::Skeleton3D_get_bone_count, skeleton);
  while (b >= 0 && b != root && int64_t(joints.size()) <= bone_count) {
    joints.push_back(b);
    b = int(call<int64_t>(M::Skeleton3D_get_bone_parent, skeleton, int64_t(b)));
  }
  if (b != root) {
    problems.push_back({"tip_bone", "IKChain: tip_bone '" + tip_bone_ + "' is not a descendant of root_bone '" +
                                        root_bone_ + "'; pick a tip_bone below root_bone (the effector is tip_bone's "
                                        "origin, the joints are root_bone down to tip_bone's parent)."});
    return;
  }
  joints.push_back(root);
  std::reverse(joints.begin(), joints.end());
  if (solver_ == SOLVER_TWO_BONE && joints.size() != 2) {
    problems.push_back({"solver", "IKChain: solver Two Bone needs exactly 2 joints (root_bone, its child, then "
                                  "tip_bone), this chain has " + std::to_string(joints.size()) +
                                  "; change root_bone/tip_bone or pick another solver."});
  }
  if (joint_bones != nullptr) *joint_bones = std::move(joints);
  if (tip_index != nullptr) *tip_index = tip;
}

void IKChain::collect_target_problems(std::vector<Problem>& problems) const {
  if (target_.is_empty()) {
    problems.push_back({"target", "IKChain: target is empty; set it to the Node3D the tip should reach."});
    return;
  }
  const ObjectPtr node = call<ObjectPtr>(M::Node_get_node_or_null, owner_, target_);
  if (gdx::cast_to<gdx::ClassTag::Node3D>(node) == nullptr) {
    problems.push_back({"target", "IKChain: target '" + target_.to_string().utf8() +
                                      "' does not point to a Node3D; set it to the Node3D the tip should reach."});
  }
}

gdx::PackedStringArray IKChain::get_configuration_warnings() const {
  std::vector<Problem> problems;
  const ObjectPtr skeleton =
      find_skeleton(owner_);
  collect_chain_problems(skeleton, problems, nullptr, nullptr);
  collect_target_problems(problems);
  gdx::PackedStringArray out;
  for (const Problem& p : problems) out.push_back(text(p.message));
  return out;
}

// ---------------------------------------------------------------- solving

void IKChain::report_once(const char* message) {
  for (const std::string& r : reported_)
    if (r == message) return;
  gdx::print_error(message, "IKChain::_process_modification_with_delta", __FILE__, __LINE__);
  reported_.emplace_back(message);
}

void IKChain::forget_reports_except(const std::vector<Problem>& still_active) {
  // A problem that went away may be reported again if it comes back.
  reported_.erase(std::remove_if(reported_.begin(), reported_.end(),
                                 [&](const std::string& r) {
                                   if (r == kNoTarget || r == kBadTarget || r == kNonFinite) return false;
                                   for (const Problem& p : still_active)
                                     if (p.message == r) return false;
                                   return true;
                                 }),
                 reported_.end());
}

void IKChain::rebuild(ObjectPtr skeleton) {
  dirty_ = false;
  chain_ok_ = false;
  chain_problems_.clear();
  joint_bones_.clear();
  int tip = -1;
  collect_chain_problems(skeleton, chain_problems_, &joint_bones_, &tip);
  forget_reports_except(chain_problems_);
  if (skeleton != nullptr && gde_instance_id(skeleton) != built_skeleton_id_) watch_skeleton(skeleton);
  built_skeleton_id_ = skeleton ? gde_instance_id(skeleton) : 0;
  built_bone_count_ = skeleton ? call<int64_t>(M::Skeleton3D_get_bone_count, skeleton) : -1;
  if (!chain_problems_.empty() || joint_bones_.empty()) return;

  // Offsets from the bones' current poses (positions and scales at rebuild); rest rotations from
  // the bones' rests. Godot's bone transform is T(position) R(rotation) S(scale) and a bone's scale
  // applies to its whole subtree, so a joint's offset is its position times the product of the
  // chain ancestors' scales (exact for uniform scale; the chain model is rigid, so a non-uniform
  // scale inside the chain is approximated). Scale above root_bone is in the base space itself.
  ChainBuilder builder;
  const int n = int(joint_bones_.size());
  glm::dvec3 inherited_scale(1.0);
  for (int i = 0; i < n; ++i) {
    const int bone = joint_bones_[i];
    const gdx::Transform3D rest = call<gdx::Transform3D>(M::Skeleton3D_get_bone_rest, skeleton, int64_t(bone));
    const glm::dvec3 position = gdx::to_glm(call<gdx::Vector3>(M::Skeleton3D_get_bone_pose_position, skeleton,
                                                               int64_t(bone)));
    JointDesc joint;
    joint.type = JointType::kBall;
    joint.offset_translation = inherited_scale * position;
    joint.rest_rotation = rotation_of(rest.basis);
    builder.add_joint(joint);
    inherited_scale *= gdx::to_glm(call<gdx::Vector3>(M::Skeleton3D_get_bone_pose_scale, skeleton, int64_t(bone)));
  }
  const glm::dvec3 tip_position =
      gdx::to_glm(call<gdx::Vector3>(M::Skeleton3D_get_bone_pose_position, skeleton, int64_t(tip)));
  builder.set_tip_offset(inherited_scale * tip_position);
  const Message built = builder.build(chain_);
  if (!built.empty()) {
    chain_problems_.push_back({"root_bone", std::string("IKChain: cannot build the chain: ") + built.c_str()});
    return;
  }
  base_bone_ = int(call<int64_t>(M::Skeleton3D_get_bone_parent, skeleton, int64_t(joint_bones_[0])));
  workspace_.reset(chain_, 1);
  params_ = Eigen::VectorXd::Zero(chain_.dof_count());
  new_rotations_.assign(size_t(n), gdx::Quaternion{});
  chain_ok_ = true;
}

void IKChain::set_invalid_result() {
  // The modification did nothing this frame: a defined result, the pose is left as it was.
  has_result_ = true;
  last_ = SolveResult();
  last_.reason = TerminationReason::kInvalidInput;
}

void IKChain::notification(int32_t what) {
  if (what != gdx::gen::kNode_NOTIFICATION_ENTER_TREE) return;
  if (find_skeleton(owner_) == nullptr) report_once(kNoSkeleton);
}

void IKChain::process_modification(double /*delta*/) {
  const ObjectPtr skeleton =
      find_skeleton(owner_);
  if (skeleton == nullptr) {
    report_once(kNoSkeleton);
    set_invalid_result();
    return;
  }
  if (dirty_ || gde_instance_id(skeleton) != built_skeleton_id_ ||
      call<int64_t>(M::Skeleton3D_get_bone_count, skeleton) != built_bone_count_) {
    rebuild(skeleton);  // allocates, but only when something changed
  }
  if (!chain_ok_) {
    for (const Problem& p : chain_problems_) report_once(p.message.c_str());
    set_invalid_result();
    return;
  }
  const ObjectPtr target = gdx::cast_to<gdx::ClassTag::Node3D>(
      target_.is_empty() ? nullptr : call<ObjectPtr>(M::Node_get_node_or_null, owner_, target_));
  if (target == nullptr || !call<bool>(M::Node_is_inside_tree, target)) {
    report_once(kNoTarget);
    set_invalid_result();
    return;
  }

  // Target in the chain's base space: (skeleton global * base bone pose)^-1 * target global.
  glm::dmat4 base_global = gdx::to_glm(call<gdx::Transform3D>(M::Node3D_get_global_transform, skeleton));
  if (base_bone_ >= 0)
    base_global = base_global *
                  gdx::to_glm(call<gdx::Transform3D>(M::Skeleton3D_get_bone_global_pose, skeleton, int64_t(base_bone_)));
  const glm::dvec3 target_global =
      gdx::to_glm(call<gdx::Transform3D>(M::Node3D_get_global_transform, target).origin);
  const glm::dvec3 target_in_base = glm::dvec3(glm::inverse(base_global) * glm::dvec4(target_global, 1.0));
  if (!gdx::is_finite(target_in_base)) {
    report_once(kBadTarget);
    set_invalid_result();
    return;
  }

  // Warm start: params from the current pose rotations (local = rest * exp(params)).
  const int n = int(joint_bones_.size());
  if (!deterministic_) {
    for (int i = 0; i < n; ++i) {
      glm::dquat pose = gdx::to_glm(
          call<gdx::Quaternion>(M::Skeleton3D_get_bone_pose_rotation, skeleton, int64_t(joint_bones_[i])));
      const double len = glm::length(pose);
      pose = (len > 0.0 && std::isfinite(len)) ? pose / len : glm::dquat(1.0, 0.0, 0.0, 0.0);
      const glm::dvec3 r = so3::log(glm::conjugate(chain_.rest_rotation(i)) * pose);
      params_.segment<3>(chain_.dof_offset(i)) = Eigen::Vector3d(r.x, r.y, r.z);
    }
  } else {
    params_.setZero();
  }

  goal_ = Goal::position(target_in_base);
  last_ = solve(static_cast<SolverKind>(solver_), chain_, Span<const Goal>(&goal_, 1), options_, workspace_,
                params_);
  has_result_ = true;
  if (!last_.usable()) {
    if (!last_.message.empty()) report_once(last_.message.c_str());
    return;
  }

  for (int i = 0; i < n; ++i) {
    const auto p = params_.segment<3>(chain_.dof_offset(i));
    const glm::dquat q = glm::normalize(chain_.rest_rotation(i) * so3::exp(glm::dvec3(p[0], p[1], p[2])));
    if (!gdx::is_finite(q)) {
      report_once(kNonFinite);
      last_.reason = TerminationReason::kInvalidInput;
      return;  // nothing written yet: the old pose stays
    }
    new_rotations_[size_t(i)] = gdx::from_glm(q);
  }
  for (int i = 0; i < n; ++i)
    call(M::Skeleton3D_set_bone_pose_rotation, skeleton, int64_t(joint_bones_[i]), new_rotations_[size_t(i)]);
}

}  // namespace ikchain::godot
