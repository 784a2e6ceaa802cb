// The kinematic chain: built once by ChainBuilder, then immutable and read by every solve.
//
// Frames. The chain lives in its own "base" space (for Godot: the root bone's parent, in skeleton
// space). Joint i has a frame whose origin o_i and orientation Q_i are
//   o_i = o_{i-1} + Q_{i-1} * offset_translation[i]          (o_{-1} = 0, Q_{-1} = identity)
//   Q_i = Q_{i-1} * rest_rotation[i] * R_i(params)
// with R_i = exp(r) for a ball joint (r: rotation vector, 3 params, radians) and
// R_i = angle_axis(theta, axis) for a hinge (1 param, radians). The tip (end effector) is
//   tip = o_{n-1} + Q_{n-1} * tip_offset,   tip frame orientation = Q_{n-1} * tip_rotation
// (the tool frame: a hand, a gripper, a barrel; identity by default).
// params = 0 is the rest pose. Bone i spans o_i -> o_{i+1} (or -> tip for the last joint).
//
// Effectors (where goals attach) are numbered 1..n: effector k < n is the origin o_k of joint k
// (e.g. the elbow of a shoulder-elbow-wrist chain), effector n is the tip; effector k's orientation
// is Q_{k-1}, the frame of the bone that ends there. Only joints 0..k-1 move effector k.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/joint_traits.hpp"
#include "ikchain/message.hpp"

namespace ikchain {

// The largest magnitude the core accepts for a coordinate (offsets, targets, pole; m) or a joint
// parameter (rad), and for a goal weight. Far beyond any scene (a float32 position tops out at
// 3.4e38), yet squared errors and gradient products of 200 joints and several goals stay far from
// overflow, so every error, cost and Jacobian entry of a valid input is finite; anything larger is
// rejected by name rather than turned into inf or a silently zero direction.
constexpr double kMaxMagnitude = 1e50;
constexpr double kMaxWeight = 1e30;
// Every component finite and within +-kMaxMagnitude (false for NaN): the one bound check of
// coordinates, for chains, trees and goals.
inline bool within_magnitude(const glm::dvec3& v) {
  return std::abs(v.x) <= kMaxMagnitude && std::abs(v.y) <= kMaxMagnitude && std::abs(v.z) <= kMaxMagnitude;
}

struct JointDesc {
  JointType type = JointType::kBall;
  glm::dvec3 offset_translation{0.0};        // from the parent joint's frame (or base), chain units (m)
  glm::dquat rest_rotation{1.0, 0.0, 0.0, 0.0};  // from the parent frame, applied before the joint's motion
  glm::dvec3 axis{0.0, 0.0, 1.0};            // hinge: rotation axis, prismatic: slide axis, in joint space (after rest_rotation)
  JointLimits limits;
};

// A build error as data: the joint, the field and a message saying why, so a caller that knows
// the joint by another name (a bone) maps `joint` and `reason` instead of parsing `message`.
struct BuildError {
  int joint = -1;          // the offending joint, or -1 (a chain-wide problem: no joints, tip_offset, ...)
  const char* field = "";  // "offset_translation", "limits.cone_angle", "tip_offset", ...
  Message message;         // "joint 2: hinge_min (1.5) > hinge_max (0.5)"
  Message reason;          // the same without the joint: "hinge_min (1.5) > hinge_max (0.5)"
  bool ok() const { return message.empty(); }
};

// Checks joint `index`'s fields and writes it normalised into `out` (unit rest rotation and axes;
// the axis its type does not use set to the default), or names the bad field. Chains and trees
// validate joints with it, each naming the offset and axis fields as its own struct does.
BuildError normalize_joint(int index, const JointDesc& joint, JointDesc& out,
                           const char* offset_name = "offset_translation", const char* axis_name = "axis");

class Chain;

class ChainBuilder {
 public:
  ChainBuilder& add_joint(const JointDesc& joint);
  // Offset of the end effector from the last joint, in the last joint's frame (m).
  ChainBuilder& set_tip_offset(const glm::dvec3& tip_offset);
  // Rotation of the tip (tool) frame relative to the last joint's frame: orientation and aim goals
  // on the tip mean this frame's orientation (unit quaternion after build; identity by default).
  ChainBuilder& set_tip_rotation(const glm::dquat& tip_rotation);
  // Both at once: the tool frame's origin (tip_offset) and orientation in the last joint's frame.
  ChainBuilder& set_tip_frame(const glm::dvec3& tip_offset, const glm::dquat& tip_rotation);
  void clear();

  // Validates every field and fills `out`. On failure `out` is left invalid and the returned error
  // names the joint and field (joint 2, "limits.hinge_min", "joint 2: hinge_min (1.5) > hinge_max (0.5)").
  // `axis_name` is what the error calls JointDesc::axis (field and message), for a caller whose
  // users set it under another name (Godot's IKChainJoint.hinge_axis).
  BuildError build(Chain& out, const char* axis_name = "axis") const;

 private:
  std::vector<JointDesc> joints_;
  glm::dvec3 tip_offset_{0.0};
  glm::dquat tip_rotation_{1.0, 0.0, 0.0, 0.0};
};

// Immutable after build: flat arrays, one entry per joint (or per DOF where named so).
class Chain {
 public:
  bool valid() const { return joint_count_ > 0; }
  int joint_count() const { return joint_count_; }
  int dof_count() const { return dof_count_; }
  int effector_count() const { return joint_count_; }  // effectors 1..n

  JointType joint_type(int i) const { return static_cast<JointType>(joints_[i].type); }
  int dof_offset(int i) const { return joints_[i].dof_offset; }  // first param index of joint i
  int dof_count_of(int i) const { return joint_dof_count(joint_type(i)); }
  const glm::dvec3& offset_translation(int i) const { return joints_[i].offset_translation; }
  const glm::dquat& rest_rotation(int i) const { return rest_rotations_[i]; }
  // True when rest_rotation(i) is exactly the identity (FK skips the product).
  bool rest_is_identity(int i) const { return joints_[i].rest_identity != 0; }
  const glm::dvec3& axis(int i) const { return joints_[i].axis; }
  // Direction codes (quat_ops::Direction: along x / y / z / general) of offset_translation(i),
  // axis(i) and tip_offset(), for FK's sparse fast paths.
  uint8_t offset_direction(int i) const { return joints_[i].offset_direction; }
  uint8_t axis_direction(int i) const { return joints_[i].axis_direction; }
  uint8_t tip_direction() const { return tip_direction_; }
  // True when every joint is a hinge (the Jacobian solvers' step needs no rotation-vector algebra).
  bool all_hinges() const { return all_hinges_; }
  // The first prismatic joint, or -1 (the geometric solvers reject chains that have one).
  int first_prismatic() const { return first_prismatic_; }
  const JointLimits& limits(int i) const { return limits_[i]; }
  bool has_limits(int i) const;
  bool any_limits() const { return any_limits_; }
  const glm::dvec3& tip_offset() const { return tip_offset_; }
  const glm::dquat& tip_rotation() const { return tip_rotation_; }

  // Length of bone i (o_i -> o_{i+1}, or o_{n-1} -> tip), independent of the pose (m); for a
  // prismatic joint i, the longest it can be (the offset plus the largest slide).
  double bone_length(int i) const { return bone_lengths_[i]; }
  const std::vector<double>& bone_lengths() const { return bone_lengths_; }
  // Sum of bone lengths: the farthest the tip can be from the root joint's origin o_0.
  double total_length() const { return total_length_; }
  // Forward kinematics of the rest pose (params = 0), computed once at build: joint origins, base-frame
  // DOF axes and tip, as forward_kinematics + compute_dof_axes give them. Every deterministic solve
  // starts there; the Jacobian solvers copy these instead of recomputing them.
  const std::vector<glm::dvec3>& rest_joint_origins() const { return rest_joint_origins_; }
  const std::vector<glm::dvec3>& rest_dof_axes() const { return rest_dof_axes_; }
  const glm::dvec3& rest_tip() const { return rest_tip_; }

  // o_0: fixed by the base, independent of the pose.
  const glm::dvec3& root_in_base() const { return joints_[0].offset_translation; }

  // Replaces every joint's offset_translation and the tip offset in place (same joint count) and
  // updates what depends on them (bone lengths, direction codes, the rest pose's origins and tip),
  // for bone positions that change per frame (an animated position, a stretchy limb). Allocates
  // nothing. Validated and measured as build() does (the +-kMaxMagnitude bound; bone lengths with
  // prismatic slides). On failure (count mismatch, out of bounds, zero-length) the chain is left
  // unchanged.
  Message set_offsets(const glm::dvec3* offset_translations, int count, const glm::dvec3& tip_offset);

 private:
  friend class ChainBuilder;
  int joint_count_ = 0;
  int dof_count_ = 0;
  bool any_limits_ = false;
  // What forward kinematics reads for every joint, side by side (one record, not seven arrays:
  // the FK loops keep one base pointer instead of spilling seven).
  struct JointRecord {
    glm::dvec3 offset_translation{0.0};
    glm::dvec3 axis{0.0, 0.0, 1.0};
    int dof_offset = 0;
    uint8_t type = 0;
    uint8_t rest_identity = 0;
    uint8_t offset_direction = 0;
    uint8_t axis_direction = 0;
  };
  std::vector<JointRecord> joints_;
  std::vector<glm::dquat> rest_rotations_;
  uint8_t tip_direction_ = 0;
  bool all_hinges_ = false;
  int first_prismatic_ = -1;
  std::vector<JointLimits> limits_;
  std::vector<glm::dvec3> rest_joint_origins_;
  std::vector<glm::dvec3> rest_dof_axes_;
  glm::dvec3 rest_tip_{0.0};
  std::vector<double> bone_lengths_;
  glm::dvec3 tip_offset_{0.0};
  glm::dquat tip_rotation_{1.0, 0.0, 0.0, 0.0};
  double total_length_ = 0.0;
};

}  // namespace ikchain
