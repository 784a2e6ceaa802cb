// IKChainGoal: an extra goal of an IKChain on one of its bones (a Resource): a position,
// orientation or aim target for that bone, weighted against the chain's main goal.
#pragma once

#include <cstdint>
#include <string>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "ikchain/goal.hpp"

namespace ikchain::godot {

class IKChainGoal {
 public:
  enum Kind : int64_t { KIND_POSITION = 0, KIND_ORIENTATION = 1, KIND_AIM = 2 };

  static void register_class(gdx::ClassRecord& record);
  static const IKChainGoal* from_object(gdx::ObjectPtr object);

  explicit IKChainGoal(gdx::ObjectPtr owner) : owner_(owner) {}

  void set_bone_name(const gdx::String& name);
  gdx::String get_bone_name() const { return gdx::String(bone_name_); }
  const std::string& bone_name() const { return bone_name_; }
  void set_kind(int64_t kind);
  int64_t get_kind() const { return kind_; }
  void set_target(const gdx::NodePath& path);
  gdx::NodePath get_target() const { return target_; }
  void set_weight(double weight);
  double get_weight() const { return weight_; }
  void set_aim_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_aim_axis() const { return aim_axis_; }

  GoalKind goal_kind() const;

 private:
  void changed();

  gdx::ObjectPtr owner_;
  std::string bone_name_;
  int64_t kind_ = KIND_POSITION;
  gdx::NodePath target_;
  double weight_ = 1.0;
  gdx::Vector3 aim_axis_{0, 1, 0};
};

}  // namespace ikchain::godot
