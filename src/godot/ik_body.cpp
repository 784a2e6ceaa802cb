#include "ik_body.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "ikchain/so3.hpp"
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
  IKModifier::bind_time_budget(b);
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
  put("budget_exhausted", gdx::Variant(last_.summary.budget_exhausted));
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

}  // namespace ikchain::godot
