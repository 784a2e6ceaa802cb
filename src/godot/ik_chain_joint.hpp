// IKChainJoint: per-joint settings of an IKChain (a Resource, saved in .tscn as a sub-resource).
// A bone of the chain that no IKChainJoint names is a free ball joint.
#pragma once

#include <cstdint>
#include <string>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "core/chain.hpp"

namespace ikchain::godot {

class IKChainJoint {
 public:
  enum Type : int64_t { JOINT_BALL = 0, JOINT_HINGE = 1 };  // registered as enum JointType

  static void register_class(gdx::ClassRecord& record);
  // The C++ instance behind a Variant of an Array (null when it is not an IKChainJoint).
  static const IKChainJoint* from_object(gdx::ObjectPtr object);
  // Bumped by every setter of every IKChainJoint / IKChainGoal: an IKChain compares it each frame
  // (one integer) to know that settings inside its resources changed.
  static uint64_t generation();
  static void bump_generation();

  explicit IKChainJoint(gdx::ObjectPtr owner) : owner_(owner) {}

  void set_bone_name(const gdx::String& name);
  gdx::String get_bone_name() const { return gdx::String(bone_name_); }
  const std::string& bone_name() const { return bone_name_; }
  void set_type(int64_t type);
  int64_t get_type() const { return type_; }
  void set_hinge_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_hinge_axis() const { return hinge_axis_; }
  void set_hinge_limit_enabled(bool on);
  bool is_hinge_limit_enabled() const { return hinge_limit_enabled_; }
  void set_hinge_min(double radians);
  double get_hinge_min() const { return hinge_min_; }
  void set_hinge_max(double radians);
  double get_hinge_max() const { return hinge_max_; }
  void set_cone_limit_enabled(bool on);
  bool is_cone_limit_enabled() const { return cone_limit_enabled_; }
  void set_cone_angle(double radians);
  double get_cone_angle() const { return cone_angle_; }
  void set_twist_limit_enabled(bool on);
  bool is_twist_limit_enabled() const { return twist_limit_enabled_; }
  void set_twist_min(double radians);
  double get_twist_min() const { return twist_min_; }
  void set_twist_max(double radians);
  double get_twist_max() const { return twist_max_; }
  void set_twist_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_twist_axis() const { return twist_axis_; }

  // The core's joint type and limits (joint space = the bone's own frame after its rest).
  JointType joint_type() const { return type_ == JOINT_HINGE ? JointType::kHinge : JointType::kBall; }
  glm::dvec3 hinge_axis_in_bone() const;
  JointLimits limits() const;

 private:
  void changed();

  gdx::ObjectPtr owner_;
  std::string bone_name_;
  int64_t type_ = JOINT_BALL;
  gdx::Vector3 hinge_axis_{1, 0, 0};
  bool hinge_limit_enabled_ = false;
  double hinge_min_ = -3.14159265358979323846;
  double hinge_max_ = 3.14159265358979323846;
  bool cone_limit_enabled_ = false;
  double cone_angle_ = 3.14159265358979323846;
  bool twist_limit_enabled_ = false;
  double twist_min_ = -3.14159265358979323846;
  double twist_max_ = 3.14159265358979323846;
  gdx::Vector3 twist_axis_{0, 1, 0};
};

}  // namespace ikchain::godot
