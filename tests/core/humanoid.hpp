// Godot 4.6's SkeletonProfileHumanoid rests, copied as data (the body bones; no fingers, eyes or
// jaw): a T-pose facing +Z, the character's left on +X, about 1.45 m tall, the feet at y = 0.
// Printed by Godot 4.6.3 from `SkeletonProfileHumanoid.new().get_reference_pose(i)` (position,
// rotation as w, x, y, z). Knees and elbows on both sides bend about their own +X (a positive
// angle bends them the anatomical way), and the upper and lower bones of each limb are turned
// 180 deg about the bone against each other in the rest: the case that exposed issue 16's item 17.
#pragma once
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ikchain/chain.hpp"
#include "ikchain/so3.hpp"

namespace ikchain {
namespace test {
namespace humanoid {

struct Bone {
  const char* name;
  const char* parent;  // "" for the root
  glm::dvec3 position;
  glm::dquat rotation;  // (w, x, y, z)
};

constexpr double kH = 0.707106769;  // as Godot prints sqrt(1/2)

inline const std::vector<Bone>& bones() {
  static const std::vector<Bone> b = {
      {"Root", "", {0, 0, 0}, {1, 0, 0, 0}},
      {"Hips", "Root", {0, 0.75, 0}, {1, 0, 0, 0}},
      {"Spine", "Hips", {0, 0.1, 0}, {1, 0, 0, 0}},
      {"Chest", "Spine", {0, 0.1, 0}, {1, 0, 0, 0}},
      {"UpperChest", "Chest", {0, 0.1, 0}, {1, 0, 0, 0}},
      {"Neck", "UpperChest", {0, 0.1, 0}, {1, 0, 0, 0}},
      {"Head", "Neck", {0, 0.1, 0}, {1, 0, 0, 0}},
      {"LeftShoulder", "UpperChest", {0.05, 0.1, 0}, {-0.5, 0.5, 0.5, 0.5}},
      {"LeftUpperArm", "LeftShoulder", {0, 0.05, 0}, {0, 0, 1, 0}},
      {"LeftLowerArm", "LeftUpperArm", {0, 0.25, 0}, {kH, 0, -kH, 0}},
      {"LeftHand", "LeftLowerArm", {0, 0.25, 0}, {kH, 0, kH, 0}},
      {"LeftMiddleProximal", "LeftHand", {0, 0.075, 0}, {1, 0, 0, 0}},
      {"RightShoulder", "UpperChest", {-0.05, 0.1, 0}, {-0.5, 0.5, -0.5, -0.5}},
      {"RightUpperArm", "RightShoulder", {0, 0.05, 0}, {0, 0, 1, 0}},
      {"RightLowerArm", "RightUpperArm", {0, 0.25, 0}, {kH, 0, kH, 0}},
      {"RightHand", "RightLowerArm", {0, 0.25, 0}, {kH, 0, -kH, 0}},
      {"RightMiddleProximal", "RightHand", {0, 0.075, 0}, {1, 0, 0, 0}},
      {"LeftUpperLeg", "Hips", {0.1, 0, 0}, {0, 0, 0, 1}},
      {"LeftLowerLeg", "LeftUpperLeg", {0, 0.375, 0}, {0, 0, 1, 0}},
      {"LeftFoot", "LeftLowerLeg", {0, 0.375, 0}, {0, 0, kH, -kH}},
      {"LeftToes", "LeftFoot", {0, 0.15, 0}, {0, 0, 1, 0}},
      {"RightUpperLeg", "Hips", {-0.1, 0, 0}, {0, 0, 0, 1}},
      {"RightLowerLeg", "RightUpperLeg", {0, 0.375, 0}, {0, 0, 1, 0}},
      {"RightFoot", "RightLowerLeg", {0, 0.375, 0}, {0, 0, kH, -kH}},
      {"RightToes", "RightFoot", {0, 0.15, 0}, {0, 0, 1, 0}},
  };
  return b;
}

inline const Bone& bone(const std::string& name) {
  for (const Bone& b : bones())
    if (name == b.name) return b;
  ADD_FAILURE() << "no humanoid bone " << name;
  return bones()[0];
}

// The bone's rest frame in the skeleton (T-pose): rotation and origin.
inline glm::dquat rest_rotation_in_skeleton(const std::string& name) {
  const Bone& b = bone(name);
  const glm::dquat q = glm::normalize(b.rotation);
  return b.parent[0] ? rest_rotation_in_skeleton(b.parent) * q : q;
}
inline glm::dvec3 rest_origin_in_skeleton(const std::string& name) {
  const Bone& b = bone(name);
  return b.parent[0] ? rest_origin_in_skeleton(b.parent) + rest_rotation_in_skeleton(b.parent) * b.position
                     : b.position;
}

// A chain as the IKChain node maps one (skeleton_chain.cpp): one joint per bone from `root` to
// the parent of `tip`, each with its bone's rest position and rotation, the tip at `tip`'s rest
// position; the base is `root`'s parent bone. `hinge_knee`: every joint but the first is a hinge
// about its own +X (the humanoid's knees and elbows), limited to [hinge_min, hinge_max] when
// hinge_min < hinge_max.
inline Chain chain(const std::vector<std::string>& joint_bones, const std::string& tip, bool hinge_knee = false,
                   double hinge_min = 0.0, double hinge_max = 0.0) {
  ChainBuilder builder;
  for (size_t i = 0; i < joint_bones.size(); ++i) {
    const Bone& b = bone(joint_bones[i]);
    JointDesc j;
    j.offset_translation = b.position;
    j.rest_rotation = glm::normalize(b.rotation);
    if (hinge_knee && i > 0) {
      j.type = JointType::kHinge;
      j.axis = glm::dvec3(1, 0, 0);
      if (hinge_min < hinge_max) {
        j.limits.has_hinge_limit = true;
        j.limits.hinge_min = hinge_min;
        j.limits.hinge_max = hinge_max;
      }
    }
    builder.add_joint(j);
  }
  builder.set_tip_offset(bone(tip).position);
  Chain c;
  EXPECT_TRUE(builder.build(c).ok());
  return c;
}

// A point given in the skeleton (T-pose) in the base frame of a chain whose first joint is `root`.
inline glm::dvec3 skeleton_to_base(const std::string& root, const glm::dvec3& point_in_skeleton) {
  const std::string parent = bone(root).parent;
  return glm::conjugate(rest_rotation_in_skeleton(parent)) * (point_in_skeleton - rest_origin_in_skeleton(parent));
}

}  // namespace humanoid
}  // namespace test
}  // namespace ikchain
