// IKChainJoint: per-joint settings of an IKChain (a Resource, saved in .tscn as a sub-resource).
// A bone of the chain that no IKChainJoint names is a free ball joint.
#pragma once

#include <cstdint>
#include <string>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "binding/math.hpp"
#include "skeleton_chain.hpp"

namespace ikchain::godot {

class IKChainJoint {
 public:
  enum Type : int64_t { JOINT_BALL = 0, JOINT_HINGE = 1 };  // registered as enum JointType

  static void register_class(gdx::ClassRecord& record);
  // The C++ instance behind a Variant of an Array (null when it is not an IKChainJoint).
  static const IKChainJoint* from_object(gdx::ObjectPtr object);

  explicit IKChainJoint(gdx::ObjectPtr owner) : owner_(owner) {}

  void set_bone_name(const gdx::String& name);
  gdx::String get_bone_name() const { return gdx::String(bone_name_); }
  const std::string& bone_name() const { return bone_name_; }
  void set_type(int64_t type);
  int64_t get_type() const { return int64_t(settings_.type); }
  void set_hinge_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_hinge_axis() const { return gdx::from_glm(settings_.hinge_axis_in_bone); }
  void set_hinge_limit_enabled(bool on);
  bool is_hinge_limit_enabled() const { return settings_.hinge_limit_enabled; }
  void set_hinge_min(double radians);
  double get_hinge_min() const { return settings_.hinge_min; }
  void set_hinge_max(double radians);
  double get_hinge_max() const { return settings_.hinge_max; }
  void set_cone_limit_enabled(bool on);
  bool is_cone_limit_enabled() const { return settings_.cone_limit_enabled; }
  void set_cone_angle(double radians);
  double get_cone_angle() const { return settings_.cone_angle; }
  void set_twist_limit_enabled(bool on);
  bool is_twist_limit_enabled() const { return settings_.twist_limit_enabled; }
  void set_twist_min(double radians);
  double get_twist_min() const { return settings_.twist_min; }
  void set_twist_max(double radians);
  double get_twist_max() const { return settings_.twist_max; }
  void set_twist_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_twist_axis() const { return gdx::from_glm(settings_.twist_axis_in_bone); }
  void set_motion_cost(double cost);
  double get_motion_cost() const { return settings_.motion_cost; }
  void set_posture_stiffness(double share);
  double get_posture_stiffness() const { return settings_.posture_stiffness; }

  // The settings as the skeleton mapping takes them (the properties are stored there, so the
  // defaults and the mapping exist once).
  const JointSettings& settings() const { return settings_; }
  // Bumped by every setter (each also emits `changed`, which the owning nodes listen to): an IKBody
  // compares it to tell a change that reshapes it from one that does not.
  uint64_t revision() const { return revision_; }

 private:
  void changed();

  gdx::ObjectPtr owner_;
  std::string bone_name_;
  JointSettings settings_;
  uint64_t revision_ = 0;
};

}  // namespace ikchain::godot
