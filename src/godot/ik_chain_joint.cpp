#include "ik_chain_joint.hpp"

#include <algorithm>
#include <cmath>

#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr const char* kClass = "IKChainJoint";

// The registered JointType values are the core's JointType values (settings() hands them over).
static_assert(int64_t(JointType::kBall) == IKChainJoint::JOINT_BALL &&
                  int64_t(JointType::kHinge) == IKChainJoint::JOINT_HINGE,
              "IKChainJoint.JointType values are the core's JointType values");

// Keeps an angle finite and within [lo, hi], reporting a clamp.
double clamp_angle(const char* property, const char* range, double radians, double lo, double hi, double fallback) {
  if (std::isnan(radians)) {
    report_clamped(kClass, property, range, radians, fallback);
    return fallback;
  }
  const double used = std::clamp(radians, lo, hi);
  if (used != radians) report_clamped(kClass, property, range, radians, used);
  return used;
}
}  // namespace

void IKChainJoint::register_class(gdx::ClassRecord& record) {
  gdx::ClassBuilder<IKChainJoint> b(record);
  b.register_class();
  b.method("set_bone_name", &IKChainJoint::set_bone_name, {"bone_name"});
  b.method("get_bone_name", &IKChainJoint::get_bone_name);
  b.method("set_type", &IKChainJoint::set_type, {"type"});
  b.method("get_type", &IKChainJoint::get_type, {}, {"IKChainJoint.JointType"});
  b.method("set_hinge_axis", &IKChainJoint::set_hinge_axis, {"axis"});
  b.method("get_hinge_axis", &IKChainJoint::get_hinge_axis);
  b.method("set_hinge_limit_enabled", &IKChainJoint::set_hinge_limit_enabled, {"enabled"});
  b.method("is_hinge_limit_enabled", &IKChainJoint::is_hinge_limit_enabled);
  b.method("set_hinge_min", &IKChainJoint::set_hinge_min, {"radians"});
  b.method("get_hinge_min", &IKChainJoint::get_hinge_min);
  b.method("set_hinge_max", &IKChainJoint::set_hinge_max, {"radians"});
  b.method("get_hinge_max", &IKChainJoint::get_hinge_max);
  b.method("set_cone_limit_enabled", &IKChainJoint::set_cone_limit_enabled, {"enabled"});
  b.method("is_cone_limit_enabled", &IKChainJoint::is_cone_limit_enabled);
  b.method("set_cone_angle", &IKChainJoint::set_cone_angle, {"radians"});
  b.method("get_cone_angle", &IKChainJoint::get_cone_angle);
  b.method("set_twist_limit_enabled", &IKChainJoint::set_twist_limit_enabled, {"enabled"});
  b.method("is_twist_limit_enabled", &IKChainJoint::is_twist_limit_enabled);
  b.method("set_twist_min", &IKChainJoint::set_twist_min, {"radians"});
  b.method("get_twist_min", &IKChainJoint::get_twist_min);
  b.method("set_twist_max", &IKChainJoint::set_twist_max, {"radians"});
  b.method("get_twist_max", &IKChainJoint::get_twist_max);
  b.method("set_twist_axis", &IKChainJoint::set_twist_axis, {"axis"});
  b.method("get_twist_axis", &IKChainJoint::get_twist_axis);
  b.method("set_motion_cost", &IKChainJoint::set_motion_cost, {"cost"});
  b.method("get_motion_cost", &IKChainJoint::get_motion_cost);
  b.method("set_posture_stiffness", &IKChainJoint::set_posture_stiffness, {"share"});
  b.method("get_posture_stiffness", &IKChainJoint::get_posture_stiffness);

  b.constant("JointType", "JOINT_BALL", JOINT_BALL);
  b.constant("JointType", "JOINT_HINGE", JOINT_HINGE);

  b.property({"bone_name", GDEXTENSION_VARIANT_TYPE_STRING}, "set_bone_name", "get_bone_name");
  b.property({"type", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, "Ball,Hinge"}, "set_type", "get_type");
  b.group("Hinge", "hinge_");
  b.property({"hinge_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_hinge_axis", "get_hinge_axis");
  b.property({"hinge_limit_enabled", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_hinge_limit_enabled",
             "is_hinge_limit_enabled");
  b.property({"hinge_min", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "-180,180,0.1,radians_as_degrees"},
             "set_hinge_min", "get_hinge_min");
  b.property({"hinge_max", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "-180,180,0.1,radians_as_degrees"},
             "set_hinge_max", "get_hinge_max");
  b.group("Cone", "cone_");
  b.property({"cone_limit_enabled", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_cone_limit_enabled", "is_cone_limit_enabled");
  b.property({"cone_angle", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,180,0.1,radians_as_degrees"},
             "set_cone_angle", "get_cone_angle");
  b.group("Twist", "twist_");
  b.property({"twist_limit_enabled", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_twist_limit_enabled",
             "is_twist_limit_enabled");
  b.property({"twist_min", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "-180,180,0.1,radians_as_degrees"},
             "set_twist_min", "get_twist_min");
  b.property({"twist_max", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "-180,180,0.1,radians_as_degrees"},
             "set_twist_max", "get_twist_max");
  b.property({"twist_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_twist_axis", "get_twist_axis");
  b.group("Body", "");
  b.property({"motion_cost", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0.01,100,0.01,exp"},
             "set_motion_cost", "get_motion_cost");
  b.property({"posture_stiffness", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,1,0.01"},
             "set_posture_stiffness", "get_posture_stiffness");
}

const IKChainJoint* IKChainJoint::from_object(gdx::ObjectPtr object) {
  return gdx::instance_of<IKChainJoint>(object, gdx::String(kClass));
}

void IKChainJoint::changed() {
  // Only the nodes that hold this joint listen (IKModifier::listen_to): editing it rebuilds them,
  // not every IKChain of the scene.
  ++revision_;
  gdx::Resource::unchecked(owner_).emit_changed();
}

void IKChainJoint::set_bone_name(const gdx::String& name) {
  bone_name_ = name.utf8();
  changed();
}
void IKChainJoint::set_type(int64_t type) {
  const int64_t used = std::clamp<int64_t>(type, JOINT_BALL, JOINT_HINGE);
  if (used != type) report_clamped(kClass, "type", "0..1 (IKChainJoint.JOINT_*)", double(type), double(used));
  settings_.type = JointType(used);
  changed();
}
void IKChainJoint::set_hinge_axis(const gdx::Vector3& axis) {
  // A zero or non-finite axis is reported by the IKChain's configuration warnings.
  settings_.hinge_axis_in_bone = gdx::to_glm(axis);
  changed();
}
void IKChainJoint::set_hinge_limit_enabled(bool on) {
  settings_.hinge_limit_enabled = on;
  changed();
}
void IKChainJoint::set_hinge_min(double radians) {
  settings_.hinge_min = clamp_angle("hinge_min", "[-pi, pi] rad", radians, -kPi, kPi, settings_.hinge_min);
  changed();
}
void IKChainJoint::set_hinge_max(double radians) {
  settings_.hinge_max = clamp_angle("hinge_max", "[-pi, pi] rad", radians, -kPi, kPi, settings_.hinge_max);
  changed();
}
void IKChainJoint::set_cone_limit_enabled(bool on) {
  settings_.cone_limit_enabled = on;
  changed();
}
void IKChainJoint::set_cone_angle(double radians) {
  settings_.cone_angle = clamp_angle("cone_angle", "[0, pi] rad", radians, 0.0, kPi, settings_.cone_angle);
  changed();
}
void IKChainJoint::set_twist_limit_enabled(bool on) {
  settings_.twist_limit_enabled = on;
  changed();
}
void IKChainJoint::set_twist_min(double radians) {
  settings_.twist_min = clamp_angle("twist_min", "[-pi, pi] rad", radians, -kPi, kPi, settings_.twist_min);
  changed();
}
void IKChainJoint::set_twist_max(double radians) {
  settings_.twist_max = clamp_angle("twist_max", "[-pi, pi] rad", radians, -kPi, kPi, settings_.twist_max);
  changed();
}
void IKChainJoint::set_motion_cost(double cost) {
  const double used = std::isnan(cost) ? settings_.motion_cost : std::clamp(cost, 0.01, 100.0);
  if (used != cost) report_clamped(kClass, "motion_cost", "[0.01, 100]", cost, used);
  settings_.motion_cost = used;
  changed();
}
void IKChainJoint::set_posture_stiffness(double share) {
  const double used = std::isnan(share) ? settings_.posture_stiffness : std::clamp(share, 0.0, 1.0);
  if (used != share) report_clamped(kClass, "posture_stiffness", "[0, 1]", share, used);
  settings_.posture_stiffness = used;
  changed();
}
void IKChainJoint::set_twist_axis(const gdx::Vector3& axis) {
  settings_.twist_axis_in_bone = gdx::to_glm(axis);
  changed();
}

}  // namespace ikchain::godot
