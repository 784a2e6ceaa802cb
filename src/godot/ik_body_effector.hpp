// IKBodyEffector: one goal of an IKBody on one bone (a Resource, saved in .tscn as a
// sub-resource): where the bone should be (target node or transform), how much its position and
// rotation count, its priority level and its influence over the incoming animation.
#pragma once

#include <cstdint>
#include <string>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "binding/math.hpp"

namespace ikchain::godot {

class IKBodyEffector {
 public:
  static constexpr int64_t kMinPriority = 1;
  static constexpr int64_t kMaxPriority = 4;  // the core's kMaxPriorityLevels

  static void register_class(gdx::ClassRecord& record);
  // The C++ instance behind an Object (null when it is not an IKBodyEffector).
  static IKBodyEffector* from_object(gdx::ObjectPtr object);

  explicit IKBodyEffector(gdx::ObjectPtr owner) : owner_(owner) {}

  void set_bone_name(const gdx::String& name);
  gdx::String get_bone_name() const { return gdx::String(bone_name_); }
  const std::string& bone_name() const { return bone_name_; }
  void set_enabled(bool on);
  bool is_enabled() const { return enabled_; }
  void set_target(const gdx::NodePath& path);
  gdx::NodePath get_target() const { return target_; }
  const gdx::NodePath& target() const { return target_; }  // per frame: no NodePath copy
  void set_use_target_transform(bool on);
  bool is_using_target_transform() const { return use_target_transform_; }
  void set_target_transform(const gdx::Transform3D& transform);
  gdx::Transform3D get_target_transform() const { return target_transform_; }
  void set_position_weight(double weight);
  double get_position_weight() const { return position_weight_; }
  void set_rotation_weight(double weight);
  double get_rotation_weight() const { return rotation_weight_; }
  // Stored as given (a script may set 0 or 9): the IKBody clamps it to 1..4 and warns, naming it.
  void set_priority(int64_t priority);
  int64_t get_priority() const { return priority_; }
  void set_influence(double influence);
  double get_influence() const { return influence_; }
  void set_pole_target(const gdx::NodePath& path);
  gdx::NodePath get_pole_target() const { return pole_target_; }
  const gdx::NodePath& pole_target() const { return pole_target_; }
  // Look mode: the bone's look_axis (its own frame) aims at the target's origin (the core's kAimAt
  // goal, weighted by rotation_weight) instead of reaching it; look_shares spread the turn over the
  // bone and its ancestors (index 0 = this bone, 1 = its parent, ...).
  void set_look_at(bool on);
  bool is_look_at() const { return look_at_; }
  void set_look_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_look_axis() const { return look_axis_; }
  void set_look_shares(const gdx::Array& shares);
  gdx::Array get_look_shares() const { return look_shares_; }

  gdx::ObjectPtr owner() const { return owner_; }
  // Bumped by the changes that reshape the body (bone, enabled, pole, look); every change emits
  // `changed`, and the IKBody rebuilds only when this moved.
  uint64_t revision() const { return revision_; }

 private:
  void changed(bool structural);

  gdx::ObjectPtr owner_;
  std::string bone_name_;
  bool enabled_ = true;
  gdx::NodePath target_;
  bool use_target_transform_ = false;
  gdx::Transform3D target_transform_;
  double position_weight_ = 1.0;
  double rotation_weight_ = 0.0;
  int64_t priority_ = 1;
  double influence_ = 1.0;
  gdx::NodePath pole_target_;
  bool look_at_ = false;
  gdx::Vector3 look_axis_{0.0f, 0.0f, 1.0f};  // +Z: a Godot humanoid's forward
  gdx::Array look_shares_;
  uint64_t revision_ = 0;
};

}  // namespace ikchain::godot
