#include "ik_body_effector.hpp"

#include <algorithm>
#include <cmath>

#include "binding/log.hpp"
#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;

namespace {
constexpr const char* kClass = "IKBodyEffector";

// A weight: finite and within [0, 1e6]; NaN keeps the previous value.
double clamp_weight(const char* property, double given, double previous) {
  const double used = std::isnan(given) ? previous : std::clamp(given, 0.0, 1e6);
  if (used != given) report_clamped(kClass, property, "[0, 1e+06]", given, used);
  return used;
}
}  // namespace

void IKBodyEffector::register_class(gdx::ClassRecord& record) {
  gdx::ClassBuilder<IKBodyEffector> b(record);
  b.register_class();
  b.method("set_bone_name", &IKBodyEffector::set_bone_name, {"bone_name"});
  b.method("get_bone_name", &IKBodyEffector::get_bone_name);
  b.method("set_enabled", &IKBodyEffector::set_enabled, {"enabled"});
  b.method("is_enabled", &IKBodyEffector::is_enabled);
  b.method("set_target", &IKBodyEffector::set_target, {"path"});
  b.method("get_target", &IKBodyEffector::get_target);
  b.method("set_use_target_transform", &IKBodyEffector::set_use_target_transform, {"enabled"});
  b.method("is_using_target_transform", &IKBodyEffector::is_using_target_transform);
  b.method("set_target_transform", &IKBodyEffector::set_target_transform, {"transform"});
  b.method("get_target_transform", &IKBodyEffector::get_target_transform);
  b.method("set_position_weight", &IKBodyEffector::set_position_weight, {"weight"});
  b.method("get_position_weight", &IKBodyEffector::get_position_weight);
  b.method("set_rotation_weight", &IKBodyEffector::set_rotation_weight, {"weight"});
  b.method("get_rotation_weight", &IKBodyEffector::get_rotation_weight);
  b.method("set_priority", &IKBodyEffector::set_priority, {"priority"});
  b.method("get_priority", &IKBodyEffector::get_priority);
  b.method("set_influence", &IKBodyEffector::set_influence, {"influence"});
  b.method("get_influence", &IKBodyEffector::get_influence);
  b.method("set_pole_target", &IKBodyEffector::set_pole_target, {"path"});
  b.method("get_pole_target", &IKBodyEffector::get_pole_target);
  b.method("set_look_at", &IKBodyEffector::set_look_at, {"enabled"});
  b.method("is_look_at", &IKBodyEffector::is_look_at);
  b.method("set_look_axis", &IKBodyEffector::set_look_axis, {"axis"});
  b.method("get_look_axis", &IKBodyEffector::get_look_axis);
  b.method("set_look_shares", &IKBodyEffector::set_look_shares, {"shares"});
  b.method("get_look_shares", &IKBodyEffector::get_look_shares);

  b.property({"bone_name", GDEXTENSION_VARIANT_TYPE_STRING}, "set_bone_name", "get_bone_name");
  b.property({"enabled", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_enabled", "is_enabled");
  b.group("Target", "");
  b.property({"target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_target", "get_target");
  b.property({"use_target_transform", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_use_target_transform",
             "is_using_target_transform");
  b.property({"target_transform", GDEXTENSION_VARIANT_TYPE_TRANSFORM3D}, "set_target_transform",
             "get_target_transform");
  b.property({"pole_target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_pole_target", "get_pole_target");
  b.group("Weights", "");
  b.property({"position_weight", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,10,0.01,or_greater"},
             "set_position_weight", "get_position_weight");
  b.property({"rotation_weight", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,10,0.01,or_greater"},
             "set_rotation_weight", "get_rotation_weight");
  b.property({"priority", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "1,4,1"}, "set_priority",
             "get_priority");
  b.property({"influence", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,1,0.01"}, "set_influence",
             "get_influence");
  b.group("Look", "look_");
  b.property({"look_at", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_look_at", "is_look_at");
  b.property({"look_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_look_axis", "get_look_axis");
  b.property({"look_shares", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING, "3/1:0,1,0.01"},
             "set_look_shares", "get_look_shares");
}

IKBodyEffector* IKBodyEffector::from_object(gdx::ObjectPtr object) {
  return gdx::instance_of<IKBodyEffector>(object, gdx::String(kClass));
}

void IKBodyEffector::changed(bool structural) {
  // Only what reshapes the body (the bone, enabled, the pole) makes the IKBody rebuild; targets,
  // weights, priority and influence are read every frame (keyable).
  if (structural) ++revision_;
  gdx::Resource::unchecked(owner_).emit_changed();
}

void IKBodyEffector::set_bone_name(const gdx::String& name) {
  bone_name_ = name.utf8();
  changed(true);
}
void IKBodyEffector::set_enabled(bool on) {
  if (on == enabled_) return;
  enabled_ = on;
  changed(true);
}
void IKBodyEffector::set_target(const gdx::NodePath& path) {
  target_ = path;
  changed(false);
}
void IKBodyEffector::set_use_target_transform(bool on) {
  use_target_transform_ = on;
  changed(false);
}
void IKBodyEffector::set_target_transform(const gdx::Transform3D& transform) { target_transform_ = transform; }
void IKBodyEffector::set_position_weight(double weight) {
  position_weight_ = clamp_weight("position_weight", weight, position_weight_);
  changed(false);
}
void IKBodyEffector::set_rotation_weight(double weight) {
  rotation_weight_ = clamp_weight("rotation_weight", weight, rotation_weight_);
  changed(false);
}
void IKBodyEffector::set_priority(int64_t priority) {
  priority_ = priority;
  changed(false);
}
void IKBodyEffector::set_influence(double influence) {
  // Keyable: no signal per frame, only a clamp.
  const double used = std::isnan(influence) ? influence_ : std::clamp(influence, 0.0, 1.0);
  if (used != influence) report_clamped(kClass, "influence", "[0, 1]", influence, used);
  influence_ = used;
}
void IKBodyEffector::set_pole_target(const gdx::NodePath& path) {
  pole_target_ = path;
  changed(true);  // which limbs take a pole is resolved at the rebuild
}
void IKBodyEffector::set_look_at(bool on) {
  if (on == look_at_) return;
  look_at_ = on;
  changed(true);  // the look's bones are resolved at the rebuild
}
void IKBodyEffector::set_look_axis(const gdx::Vector3& axis) {
  // Read every frame; a zero or non-finite axis is refused (the previous one stays).
  const double length = std::sqrt(double(axis.x) * axis.x + double(axis.y) * axis.y + double(axis.z) * axis.z);
  if (!(length > 1e-6) || !std::isfinite(length)) {
    gdx::print_error("IKBodyEffector.look_axis must be a finite non-zero vector; the previous axis is kept.",
                     "IKBodyEffector::set_look_axis", __FILE__, __LINE__);
    return;
  }
  look_axis_ = axis;
}
void IKBodyEffector::set_look_shares(const gdx::Array& shares) {
  look_shares_ = shares;
  changed(true);  // the look's bones are resolved at the rebuild
}

}  // namespace ikchain::godot
