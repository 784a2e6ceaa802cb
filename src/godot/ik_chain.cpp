#include "ik_chain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "ik_chain_goal.hpp"
#include "ik_chain_joint.hpp"
#include "node_util.hpp"
#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;
namespace usage = gdx::gen::PropertyUsageFlags;

namespace {

constexpr const char* kClass = "IKChain";
constexpr IKModifier::Traits kTraits{kClass, IKChain::kDefaultMaxIterations, "[1e-06, 1] (skeleton units)",
                                     /*solver_change_rebuilds=*/false, /*deterministic_is_cold_start=*/true,
                                     "IKChain: the parent is not a Skeleton3D.",
                                     "IKChain: the parent is not a Skeleton3D; make IKChain a child of a Skeleton3D."};

// TipAxis (the engine-free mapping) takes IKChain.Axis values as they are.
static_assert(int(TipAxis::kPlusX) == IKChain::AXIS_PLUS_X, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusX) == IKChain::AXIS_MINUS_X, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kPlusY) == IKChain::AXIS_PLUS_Y, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusY) == IKChain::AXIS_MINUS_Y, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kPlusZ) == IKChain::AXIS_PLUS_Z, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusZ) == IKChain::AXIS_MINUS_Z, "TipAxis follows IKChain.Axis");

// StringNames the instances compare against; allocated at SCENE init, freed at deinit.
struct Names {
  gdx::StringName tip_extension_axis{"tip_extension_axis"};
  gdx::StringName tip_extension_length{"tip_extension_length"};
  gdx::StringName aim_axis{"aim_axis"};
  gdx::StringName use_target_rotation{"use_target_rotation"};
};
Names* g_names = nullptr;

}  // namespace

// ---------------------------------------------------------------- registration

void IKChain::register_class(gdx::ClassRecord& record) {
  g_names = new Names();
  gdx::ClassBuilder<IKChain> b(record);
  b.register_class();

  b.method("set_tip_bone", &IKChain::set_tip_bone, {"bone_name"});
  b.method("get_tip_bone", &IKChain::get_tip_bone);
  b.method("set_extend_tip_bone", &IKChain::set_extend_tip_bone, {"enabled"});
  b.method("is_extend_tip_bone", &IKChain::is_extend_tip_bone);
  b.method("set_tip_extension_axis", &IKChain::set_tip_extension_axis, {"axis"});
  b.method("get_tip_extension_axis", &IKChain::get_tip_extension_axis, {}, {"IKChain.Axis"});
  b.method("set_tip_extension_length", &IKChain::set_tip_extension_length, {"length"});
  b.method("get_tip_extension_length", &IKChain::get_tip_extension_length);
  b.method("set_target", &IKChain::set_target, {"path"});
  b.method("get_target", &IKChain::get_target);
  b.method("set_use_target_transform", &IKChain::set_use_target_transform, {"enabled"});
  b.method("is_using_target_transform", &IKChain::is_using_target_transform);
  b.method("set_target_transform", &IKChain::set_target_transform, {"transform"});
  b.method("get_target_transform", &IKChain::get_target_transform);
  b.method("set_goal_mode", &IKChain::set_goal_mode, {"mode"});
  b.method("get_goal_mode", &IKChain::get_goal_mode, {}, {"IKChain.GoalMode"});
  b.method("set_aim_axis", &IKChain::set_aim_axis, {"axis"});
  b.method("get_aim_axis", &IKChain::get_aim_axis);
  b.method("set_use_target_rotation", &IKChain::set_use_target_rotation, {"enabled"});
  b.method("is_using_target_rotation", &IKChain::is_using_target_rotation);
  b.method("set_rotation_weight", &IKChain::set_rotation_weight, {"weight"});
  b.method("get_rotation_weight", &IKChain::get_rotation_weight);
  b.method("set_pole_target", &IKChain::set_pole_target, {"path"});
  b.method("get_pole_target", &IKChain::get_pole_target);
  b.method("set_joints", &IKChain::set_joints, {"joints"});
  b.method("get_joints", &IKChain::get_joints, {}, {nullptr, "IKChainJoint"});
  b.method("set_goals", &IKChain::set_goals, {"goals"});
  b.method("get_goals", &IKChain::get_goals, {}, {nullptr, "IKChainGoal"});
  b.method("set_soft_reach", &IKChain::set_soft_reach, {"distance"});
  b.method("get_soft_reach", &IKChain::get_soft_reach);
  b.method("set_max_restarts", &IKChain::set_max_restarts, {"restarts"});
  b.method("get_max_restarts", &IKChain::get_max_restarts);
  b.method("set_restart_seed", &IKChain::set_restart_seed, {"seed"});
  b.method("get_restart_seed", &IKChain::get_restart_seed);
  b.method("get_last_result", &IKChain::get_last_result);
  b.method("get_last_reason", &IKChain::get_last_reason);
  b.method("is_last_usable", &IKChain::is_last_usable);
  b.method("is_last_reached", &IKChain::is_last_reached);
  b.method("get_last_iterations", &IKChain::get_last_iterations);
  b.method("get_last_joints_at_limit", &IKChain::get_last_joints_at_limit);
  b.method("get_last_initial_error", &IKChain::get_last_initial_error);
  b.method("get_last_final_error", &IKChain::get_last_final_error);
  b.method("get_last_position_error", &IKChain::get_last_position_error);
  b.method("get_last_orientation_error", &IKChain::get_last_orientation_error);
  b.method("get_last_microseconds", &IKChain::get_last_microseconds);
  b.method("solve_now", &IKChain::solve_now);
  b.method("get_chain_bones", &IKChain::get_chain_bones);
  // Also callable from scripts (as godot-cpp does for bound virtuals): Node has no bound
  // get_configuration_warnings(), and tools and tests want to read them.
  b.method("_get_configuration_warnings", &IKChain::get_configuration_warnings);

  b.constant("GoalMode", "GOAL_MODE_REACH", GOAL_MODE_REACH);
  b.constant("GoalMode", "GOAL_MODE_AIM", GOAL_MODE_AIM);
  const char* axis_constants[] = {"AXIS_PLUS_X", "AXIS_MINUS_X", "AXIS_PLUS_Y",
                                  "AXIS_MINUS_Y", "AXIS_PLUS_Z", "AXIS_MINUS_Z"};
  for (int i = 0; i < 6; ++i) b.constant("Axis", axis_constants[i], i);
  constexpr const char* kAxisHint = "+X,-X,+Y,-Y,+Z,-Z";

  // root_bone / tip_bone get their bone-name drop-down in validate_property().
  IKModifier::bind_root_bone(b);
  b.property({"tip_bone", GDEXTENSION_VARIANT_TYPE_STRING, hint::PROPERTY_HINT_ENUM, ""}, "set_tip_bone",
             "get_tip_bone");
  b.property({"extend_tip_bone", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_extend_tip_bone", "is_extend_tip_bone");
  b.property({"tip_extension_axis", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, kAxisHint},
             "set_tip_extension_axis", "get_tip_extension_axis");
  b.property({"tip_extension_length", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0,10,0.001,or_greater,suffix:m"},
             "set_tip_extension_length", "get_tip_extension_length");
  b.group("Goal", "");
  b.property({"target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_target", "get_target");
  b.property({"use_target_transform", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_use_target_transform",
             "is_using_target_transform");
  b.property({"target_transform", GDEXTENSION_VARIANT_TYPE_TRANSFORM3D}, "set_target_transform",
             "get_target_transform");
  b.property({"goal_mode", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, "Reach,Aim"}, "set_goal_mode",
             "get_goal_mode");
  b.property({"aim_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_aim_axis", "get_aim_axis");
  b.property({"use_target_rotation", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_use_target_rotation",
             "is_using_target_rotation");
  b.property({"rotation_weight", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,10,0.01,or_greater"},
             "set_rotation_weight", "get_rotation_weight");
  b.property({"pole_target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_pole_target", "get_pole_target");
  b.group("Joints and Goals", "");
  b.property({"joints", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING,
              "24/17:IKChainJoint"},  // Array[IKChainJoint]: Variant::OBJECT / PROPERTY_HINT_RESOURCE_TYPE
             "set_joints", "get_joints");
  b.property({"goals", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING, "24/17:IKChainGoal"},
             "set_goals", "get_goals");
  b.group("Solver", "");
  IKModifier::bind_solver_settings(b, "IKChain.Solver", /*trees_only=*/false);
  b.property({"soft_reach", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,1,0.001,or_greater,suffix:m"},
             "set_soft_reach", "get_soft_reach");
  IKModifier::bind_time_budget(b);
  b.property({"max_restarts", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "0,100,1"},
             "set_max_restarts", "get_max_restarts");
  b.property({"restart_seed", GDEXTENSION_VARIANT_TYPE_INT}, "set_restart_seed", "get_restart_seed");
  IKModifier::bind_deterministic(b);

  b.virtual_method("_process_modification_with_delta",
                   gdx::gen::kVirtualHash_SkeletonModifier3D__process_modification_with_delta,
                   &IKChain::process_modification);
  b.virtual_method("_get_configuration_warnings", gdx::gen::kVirtualHash_Node__get_configuration_warnings,
                   &IKChain::get_configuration_warnings);
  b.virtual_method("_skeleton_changed", gdx::gen::kVirtualHash_SkeletonModifier3D__skeleton_changed,
                   &IKChain::skeleton_changed);
}

void IKChain::unregister_class() {
  delete g_names;
  g_names = nullptr;
}

IKChain::IKChain(gdx::ObjectPtr owner) : IKModifier(owner, kTraits) { options_.warm_start = !deterministic_; }

// ---------------------------------------------------------------- properties

void IKChain::set_tip_bone(const gdx::String& name) {
  std::string v = name.utf8();
  if (v == tip_bone_) return;
  tip_bone_ = std::move(v);
  mark_dirty();
}
gdx::String IKChain::get_tip_bone() const { return text(tip_bone_); }

void IKChain::set_extend_tip_bone(bool on) {
  if (on == extend_tip_bone_) return;
  extend_tip_bone_ = on;
  gdx::Object(owner_).notify_property_list_changed();
  mark_dirty();
}

void IKChain::set_tip_extension_axis(int64_t axis) {
  const int64_t used = std::clamp<int64_t>(axis, AXIS_PLUS_X, AXIS_MINUS_Z);
  if (used != axis) report_clamped(kClass, "tip_extension_axis", "0..5 (IKChain.AXIS_*)", double(axis), double(used));
  if (used == tip_extension_axis_) return;
  tip_extension_axis_ = used;
  mark_dirty();
}

void IKChain::set_tip_extension_length(double length) {
  const double used = std::isnan(length) ? tip_extension_length_ : std::clamp(length, 0.0, 1e6);
  if (used != length) report_clamped(kClass, "tip_extension_length", "[0, 1e+06] m", length, used);
  if (used == tip_extension_length_) return;
  tip_extension_length_ = used;
  mark_dirty();
}

void IKChain::set_target(const gdx::NodePath& path) {
  target_ = path;
  settings_changed();
}

void IKChain::set_use_target_transform(bool on) {
  if (on == use_target_transform_) return;
  use_target_transform_ = on;
  settings_changed();
}

void IKChain::set_target_transform(const gdx::Transform3D& transform) { target_transform_ = transform; }

void IKChain::set_goal_mode(int64_t mode) {
  const int64_t used = std::clamp<int64_t>(mode, GOAL_MODE_REACH, GOAL_MODE_AIM);
  if (used != mode) report_clamped(kClass, "goal_mode", "0..1 (IKChain.GOAL_MODE_*)", double(mode), double(used));
  if (used == goal_mode_) return;
  goal_mode_ = used;
  gdx::Object(owner_).notify_property_list_changed();
  settings_changed();
}

void IKChain::set_aim_axis(const gdx::Vector3& axis) {
  double x = 0, y = 0, z = 0;
  if (!direction_or_report(kClass, "aim_axis", "Set the tip bone's axis that should point at the target, e.g. (0, 1, 0).",
                           axis.x, axis.y, axis.z, x, y, z))
    return;
  aim_axis_ = gdx::Vector3{gdx::real_t(x), gdx::real_t(y), gdx::real_t(z)};
  settings_changed();
}

void IKChain::set_use_target_rotation(bool on) {
  if (on == use_target_rotation_) return;
  use_target_rotation_ = on;
  settings_changed();
}

void IKChain::set_rotation_weight(double weight) {
  const double used = std::isnan(weight) ? rotation_weight_ : std::clamp(weight, 0.0, 1e6);
  if (used != weight) report_clamped(kClass, "rotation_weight", "[0, 1e+06]", weight, used);
  rotation_weight_ = used;
}

void IKChain::set_pole_target(const gdx::NodePath& path) {
  pole_target_ = path;
  settings_changed();
}

void IKChain::set_joints(const gdx::Array& joints) {
  stop_listening_to(joints_);  // the rebuild listens to the new ones
  joints_ = joints;
  mark_dirty();
}

void IKChain::set_goals(const gdx::Array& goals) {
  stop_listening_to(goals_);
  goals_ = goals;
  mark_dirty();
}

void IKChain::set_soft_reach(double units) {
  const double used = std::isnan(units) ? soft_reach_ : std::clamp(units, 0.0, 1e6);
  if (used != units) report_clamped(kClass, "soft_reach", "[0, 1e+06] (skeleton units; 0 = off)", units, used);
  soft_reach_ = used;
  options_.soft_reach = soft_reach_;
}

void IKChain::set_max_restarts(int64_t n) {
  max_restarts_ = std::clamp<int64_t>(n, 0, 100);
  if (max_restarts_ != n) report_clamped(kClass, "max_restarts", "0..100", double(n), double(max_restarts_));
  options_.max_restarts = int(max_restarts_);
}

void IKChain::set_restart_seed(int64_t seed) {
  restart_seed_ = seed;
  // All 64 bits (a negative seed is its two's complement): different seeds give different restarts.
  options_.restart_seed = uint64_t(seed);
}

// ---------------------------------------------------------------- script API

// final_error, position_error, orientation_error and reached describe the pose the skeleton ends
// with (after its influence blend); solver_final_error is the solver's own. The typed getters and
// the Dictionary share these definitions, so they cannot disagree.
gdx::String IKChain::get_last_reason() const {
  return gdx::String(has_result_ ? reason_name(last_.reason) : "not_run");
}
bool IKChain::is_last_usable() const { return has_result_ && last_.usable(); }
double IKChain::get_last_final_error() const { return is_last_usable() ? written_.combined : last_.final_error; }
double IKChain::get_last_position_error() const {
  return is_last_usable() ? written_.max_position : last_.final_position_error;
}
double IKChain::get_last_orientation_error() const {
  return is_last_usable() ? written_.max_orientation : last_.final_orientation_error;
}
bool IKChain::is_last_reached() const {
  return is_last_usable() && written_.max_position <= tolerance_ && written_.max_orientation <= orientation_tolerance_;
}

gdx::Dictionary IKChain::get_last_result() const {
  gdx::Dictionary d;
  auto put = [&d](const char* key, const gdx::Variant& value) { d.set(gdx::Variant(key), value); };
  // The same keys every time (zeros before the first solve), so scripts can read them unguarded.
  const bool usable = is_last_usable();
  put("reason", gdx::Variant(get_last_reason()));
  put("usable", gdx::Variant(usable));
  put("iterations", gdx::Variant(get_last_iterations()));
  put("initial_error", gdx::Variant(get_last_initial_error()));
  put("final_error", gdx::Variant(get_last_final_error()));
  put("solver_final_error", gdx::Variant(last_.final_error));
  put("position_error", gdx::Variant(get_last_position_error()));
  put("orientation_error", gdx::Variant(get_last_orientation_error()));
  put("microseconds", gdx::Variant(get_last_microseconds()));
  put("reached", gdx::Variant(is_last_reached()));
  put("budget_exhausted", gdx::Variant(last_.budget_exhausted));
  put("restarts", gdx::Variant(int64_t(last_.restarts)));
  put("escapes", gdx::Variant(int64_t(last_.escapes)));
  put("joints_at_limit", gdx::Variant(get_last_joints_at_limit()));
  put("soft_pull", gdx::Variant(last_.soft_pull));
  put("solver", gdx::Variant(usable ? solver_info(last_solver_).display_name : ""));
  put("message", gdx::Variant(last_.message.c_str()));
  return d;
}

gdx::Dictionary IKChain::solve_now() {
  run_now();
  return get_last_result();
}

gdx::PackedInt32Array IKChain::get_chain_bones() {
  const gdx::Skeleton3D skel = skeleton();
  if (skel && needs_rebuild(skel)) rebuild(skel);
  gdx::PackedInt32Array out;
  if (!chain_ok_) return out;
  for (int i = 0; i < mapping_.joint_count(); ++i) out.push_back(mapping_.skeleton_bone(i));
  return out;
}

// ---------------------------------------------------------------- editor

bool IKChain::validate_property(GDExtensionPropertyInfo& property) {
  if (g_names == nullptr) return false;
  auto hide = [&property]() {
    property.usage = uint32_t(usage::PROPERTY_USAGE_NO_EDITOR);
    return true;
  };
  if (g_names->tip_extension_axis.equals(property.name) || g_names->tip_extension_length.equals(property.name))
    return extend_tip_bone_ ? false : hide();
  if (g_names->aim_axis.equals(property.name)) return goal_mode_ == GOAL_MODE_AIM ? false : hide();
  if (g_names->use_target_rotation.equals(property.name)) return goal_mode_ == GOAL_MODE_REACH ? false : hide();
  if (!is_bone_property(property.name)) return false;
  bone_drop_down(property);
  return true;
}


}  // namespace ikchain::godot
