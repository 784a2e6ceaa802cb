#include "ik_chain_goal.hpp"

#include <algorithm>
#include <cmath>

#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;

namespace {
constexpr const char* kClass = "IKChainGoal";
}

void IKChainGoal::register_class(gdx::ClassRecord& record) {
  gdx::ClassBuilder<IKChainGoal> b(record);
  b.register_class();
  b.method("set_bone_name", &IKChainGoal::set_bone_name, {"bone_name"});
  b.method("get_bone_name", &IKChainGoal::get_bone_name);
  b.method("set_kind", &IKChainGoal::set_kind, {"kind"});
  b.method("get_kind", &IKChainGoal::get_kind, {}, {"IKChainGoal.Kind"});
  b.method("set_target", &IKChainGoal::set_target, {"path"});
  b.method("get_target", &IKChainGoal::get_target);
  b.method("set_weight", &IKChainGoal::set_weight, {"weight"});
  b.method("get_weight", &IKChainGoal::get_weight);
  b.method("set_aim_axis", &IKChainGoal::set_aim_axis, {"axis"});
  b.method("get_aim_axis", &IKChainGoal::get_aim_axis);

  b.constant("Kind", "KIND_POSITION", KIND_POSITION);
  b.constant("Kind", "KIND_ORIENTATION", KIND_ORIENTATION);
  b.constant("Kind", "KIND_AIM", KIND_AIM);

  b.property({"bone_name", GDEXTENSION_VARIANT_TYPE_STRING}, "set_bone_name", "get_bone_name");
  b.property({"kind", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, "Position,Orientation,Aim"}, "set_kind",
             "get_kind");
  // Relative to the IKChain that owns the goal (a Resource has no place in the tree of its own).
  b.property({"target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_target", "get_target");
  b.property({"weight", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0.001,100,0.001,or_greater"},
             "set_weight", "get_weight");
  b.property({"aim_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_aim_axis", "get_aim_axis");
}

const IKChainGoal* IKChainGoal::from_object(gdx::ObjectPtr object) {
  return gdx::instance_of<IKChainGoal>(object, gdx::String(kClass));
}

void IKChainGoal::changed() {
  // The IKChains that hold this goal listen to `changed` and rebuild (goals are resolved there).
  gdx::Resource::unchecked(owner_).emit_changed();
}

void IKChainGoal::set_bone_name(const gdx::String& name) {
  bone_name_ = name.utf8();
  changed();
}
void IKChainGoal::set_kind(int64_t kind) {
  kind_ = std::clamp<int64_t>(kind, KIND_POSITION, KIND_AIM);
  if (kind_ != kind) report_clamped(kClass, "kind", "0..2 (IKChainGoal.KIND_*)", double(kind), double(kind_));
  changed();
}
void IKChainGoal::set_target(const gdx::NodePath& path) {
  target_ = path;
  changed();
}
void IKChainGoal::set_weight(double weight) {
  const double used = std::isnan(weight) ? weight_ : std::clamp(weight, 1e-6, 1e6);
  if (used != weight) report_clamped(kClass, "weight", "[1e-06, 1e+06]", weight, used);
  weight_ = used;
  changed();
}
void IKChainGoal::set_aim_axis(const gdx::Vector3& axis) {
  double x = 0, y = 0, z = 0;
  if (!direction_or_report(kClass, "aim_axis", "Set the bone's axis that should point at the target, e.g. (0, 1, 0).",
                           axis.x, axis.y, axis.z, x, y, z))
    return;
  aim_axis_ = gdx::Vector3{gdx::real_t(x), gdx::real_t(y), gdx::real_t(z)};
  changed();
}

GoalKind IKChainGoal::goal_kind() const {
  switch (kind_) {
    case KIND_ORIENTATION: return GoalKind::kOrientation;
    case KIND_AIM: return GoalKind::kAim;
    default: return GoalKind::kPosition;
  }
}

}  // namespace ikchain::godot
