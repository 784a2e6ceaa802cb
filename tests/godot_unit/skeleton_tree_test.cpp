// The skeleton <-> tree mapping (src/godot/skeleton_tree.*), engine-free. The oracle composes the
// bones the way Godot does (global = parent_global * T(position) R(rotation) S(scale)), written
// here plainly. The rig is a small branched body: hips, a spine with a head, two arms with a
// finger each, two legs with toes; bones along their own +Y with rotated rests.
#include "skeleton_tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "../core/alloc_counter.hpp"
#include "ikchain/so3.hpp"
#include "ikchain/tree_solve.hpp"

namespace ikchain::godot {
namespace {

constexpr double kPi = so3::kPi;

glm::dquat axis_angle(double angle, glm::dvec3 axis) { return glm::angleAxis(angle, glm::normalize(axis)); }

double angle_between(const glm::dquat& a, const glm::dquat& b) {
  return glm::length(so3::log(glm::normalize(glm::conjugate(a) * b)));
}

glm::dmat4 trs(const glm::dvec3& position, const glm::dquat& rotation, const glm::dvec3& scale) {
  return glm::translate(glm::dmat4(1.0), position) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), scale);
}

// A skeleton as Godot holds it: names, parents, rests, poses (skeleton indices).
struct Skel {
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<glm::dquat> rests;
  std::vector<BonePose> poses;
  int add(const std::string& name, int parent, glm::dvec3 position, glm::dquat rest) {
    names.push_back(name);
    parents.push_back(parent);
    rests.push_back(rest);
    BonePose p;
    p.position = position;
    p.rotation = rest;
    poses.push_back(p);
    return int(names.size()) - 1;
  }
  std::vector<glm::dmat4> globals() const {
    std::vector<glm::dmat4> g(names.size());
    for (size_t i = 0; i < names.size(); ++i) {
      const glm::dmat4 local = trs(poses[i].position, poses[i].rotation, poses[i].scale);
      g[i] = parents[i] < 0 ? local : g[size_t(parents[i])] * local;
    }
    return g;
  }
};

// The bones are added out of depth-first order on purpose (Godot does not require parents first).
Skel body() {
  Skel s;
  const glm::dquat down = axis_angle(kPi, {0, 0, 1});
  const int hips = s.add("Hips", -1, {0, 1.0, 0}, glm::dquat(1, 0, 0, 0));
  const int spine = s.add("Spine", hips, {0, 0.1, 0}, axis_angle(0.1, {1, 0, 0}));
  const int lleg = s.add("LeftUpperLeg", hips, {0.1, -0.05, 0}, down);
  const int head = s.add("Head", spine, {0, 0.5, 0}, axis_angle(-0.1, {1, 0, 0}));
  const int larm = s.add("LeftUpperArm", spine, {0.2, 0.4, 0}, axis_angle(-kPi / 2, {0, 0, 1}));
  const int lfore = s.add("LeftLowerArm", larm, {0, 0.28, 0}, axis_angle(0.05, {0, 0, 1}));
  const int lhand = s.add("LeftHand", lfore, {0, 0.25, 0}, glm::dquat(1, 0, 0, 0));
  s.add("LeftFinger", lhand, {0, 0.08, 0}, glm::dquat(1, 0, 0, 0));
  const int rarm = s.add("RightUpperArm", spine, {-0.2, 0.4, 0}, axis_angle(kPi / 2, {0, 0, 1}));
  const int rfore = s.add("RightLowerArm", rarm, {0, 0.28, 0}, axis_angle(-0.05, {0, 0, 1}));
  s.add("RightHand", rfore, {0, 0.25, 0}, glm::dquat(1, 0, 0, 0));
  const int lknee = s.add("LeftLowerLeg", lleg, {0, 0.42, 0}, axis_angle(0.05, {1, 0, 0}));
  const int lfoot = s.add("LeftFoot", lknee, {0, 0.4, 0}, axis_angle(-1.2, {1, 0, 0}));
  s.add("LeftToes", lfoot, {0, 0.12, 0}, glm::dquat(1, 0, 0, 0));
  const int rleg = s.add("RightUpperLeg", hips, {-0.1, -0.05, 0}, down);
  const int rknee = s.add("RightLowerLeg", rleg, {0, 0.42, 0}, axis_angle(0.05, {1, 0, 0}));
  s.add("RightFoot", rknee, {0, 0.4, 0}, axis_angle(-1.2, {1, 0, 0}));
  (void)head;
  return s;
}

int find(const Skel& s, const std::string& name) {
  for (size_t i = 0; i < s.names.size(); ++i)
    if (s.names[i] == name) return int(i);
  return -1;
}

// The mapping of `skel` for effectors on the named bones, joints as `joint_of` says (free balls by default).
SkeletonTreeDesc describe(const Skel& skel, const std::string& root, const std::vector<std::string>& effectors,
                          bool floating_root, std::vector<int>* order_out = nullptr,
                          JointSettings (*joint_of)(const std::string&) = nullptr) {
  std::vector<int> eff;
  for (const std::string& e : effectors) eff.push_back(find(skel, e));
  std::vector<int> order;
  int outside = -1;
  supporting_bones(Span<const int>(skel.parents), find(skel, root), Span<const int>(eff), order, outside);
  EXPECT_EQ(outside, -1);
  SkeletonTreeDesc d;
  d.floating_root = floating_root;
  for (size_t i = 0; i < order.size(); ++i) {
    const int b = order[i];
    TreeBoneDesc bone;
    bone.name = skel.names[size_t(b)];
    bone.skeleton_bone = b;
    bone.parent = -1;
    for (size_t k = 0; k < i; ++k)
      if (order[k] == skel.parents[size_t(b)]) bone.parent = int(k);
    bone.rest_basis_in_parent = glm::mat3_cast(skel.rests[size_t(b)]);
    bone.pose = skel.poses[size_t(b)];
    if (joint_of != nullptr) bone.joint = joint_of(bone.name);
    d.bones.push_back(bone);
  }
  for (int e : eff)
    for (size_t k = 0; k < order.size(); ++k)
      if (order[k] == e) d.effector_bones.push_back(int(k));
  if (order_out) *order_out = order;
  return d;
}

PoseUpdate update(SkeletonTree& map, const std::vector<BonePose>& poses) {
  return map.update_pose(Span<const BonePose>(poses));
}

std::vector<BonePose> poses_of(const Skel& skel, const std::vector<int>& order) {
  std::vector<BonePose> out;
  for (int b : order) out.push_back(skel.poses[size_t(b)]);
  return out;
}

// ---------------------------------------------------------------- supporting_bones

TEST(SkeletonTree, SupportingBonesKeepOnlyThePathsToTheEffectorsDepthFirst) {
  const Skel s = body();
  std::vector<int> order;
  int outside = -1;
  const std::vector<int> eff = {find(s, "LeftHand"), find(s, "RightFoot"), find(s, "Head")};
  supporting_bones(Span<const int>(s.parents), find(s, "Hips"), Span<const int>(eff), order, outside);
  EXPECT_EQ(outside, -1);
  std::vector<std::string> names;
  for (int b : order) names.push_back(s.names[size_t(b)]);
  // Fingers, toes, the right arm and the left leg support no effector: left out.
  const std::vector<std::string> want = {"Hips",         "Spine",        "Head",          "LeftUpperArm",
                                         "LeftLowerArm", "LeftHand",     "RightUpperLeg", "RightLowerLeg",
                                         "RightFoot"};
  EXPECT_EQ(names, want);
  for (size_t i = 1; i < order.size(); ++i) {  // a parent always precedes its children
    const auto it = std::find(order.begin(), order.end(), s.parents[size_t(order[i])]);
    ASSERT_NE(it, order.end());
    EXPECT_LT(size_t(it - order.begin()), i);
  }
}

TEST(SkeletonTree, SupportingBonesNameTheFirstEffectorOutsideTheRoot) {
  const Skel s = body();
  std::vector<int> order;
  int outside = -1;
  const std::vector<int> eff = {find(s, "LeftHand"), find(s, "RightFoot")};
  supporting_bones(Span<const int>(s.parents), find(s, "Spine"), Span<const int>(eff), order, outside);
  EXPECT_EQ(outside, find(s, "RightFoot"));
  EXPECT_TRUE(order.empty());
}

TEST(SkeletonTree, SupportingBonesSurviveAParentCycle) {
  std::vector<int> parents = {1, 2, 0};  // a cycle: no root to reach
  std::vector<int> order;
  int outside = -1;
  const std::vector<int> eff = {2};
  supporting_bones(Span<const int>(parents), 5, Span<const int>(eff), order, outside);
  EXPECT_EQ(outside, 2);
  const std::vector<int> zero = {0};
  supporting_bones(Span<const int>(parents), 1, Span<const int>(zero), order, outside);
  EXPECT_EQ(outside, -1);  // 0 -> 1 reaches the root before the cycle closes
}

// ---------------------------------------------------------------- pose <-> params, FK

TEST(SkeletonTree, RandomPosesRoundTripAndMatchGodotsComposition) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (bool floating : {false, true}) {
    for (int trial = 0; trial < 20; ++trial) {
      Skel s = body();
      const double scale = 0.5 + 0.5 * (u(rng) + 1.0);
      s.poses[0].scale = glm::dvec3(scale);  // a uniform scale on the hips scales the whole body
      std::vector<int> order;
      SkeletonTree map;
      const SkeletonTreeDesc d = describe(s, "Hips", {"LeftHand", "RightFoot", "Head", "RightHand"}, floating, &order);
      ASSERT_TRUE(map.build(d).empty());
      // A random animated pose (rotations; the hips move too).
      for (int b : order)
        s.poses[size_t(b)].rotation = s.rests[size_t(b)] * so3::exp(glm::dvec3(u(rng), u(rng), u(rng)) * 0.8);
      s.poses[0].position += glm::dvec3(u(rng), u(rng), u(rng)) * 0.2;
      ASSERT_TRUE(update(map, poses_of(s, order)).error.empty());
      std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
      map.params_from_pose(params.data());
      std::vector<glm::dquat> rotations(order.size());
      glm::dvec3 root_position(0.0);
      ASSERT_TRUE(map.pose_from_params(params.data(), rotations, root_position));
      for (size_t i = 0; i < order.size(); ++i)
        EXPECT_LT(angle_between(rotations[i], s.poses[size_t(order[i])].rotation), 1e-12) << s.names[size_t(order[i])];
      EXPECT_LT(glm::length(root_position - s.poses[0].position), 1e-12);
      // The core's frames are Godot's globals (in base space = the skeleton here).
      TreeWorkspace ws(map.tree(), 4);
      tree_forward_kinematics(map.tree(), params.data(), ws);
      const std::vector<glm::dmat4> g = s.globals();
      for (size_t i = 0; i < order.size(); ++i) {
        const glm::dvec3 o = map.point_in_base(ws.joint_origins[i]);
        EXPECT_LT(glm::length(o - glm::dvec3(g[size_t(order[i])][3])), 1e-12) << s.names[size_t(order[i])];
        glm::dmat3 r(g[size_t(order[i])]);
        for (int c = 0; c < 3; ++c) r[c] = glm::normalize(r[c]);
        EXPECT_LT(angle_between(ws.joint_orientations[i], glm::normalize(glm::quat_cast(r))), 1e-12);
      }
    }
  }
}

TEST(SkeletonTree, FloatingRootSolvesTheHipsTranslationFromWhereTheyAre) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand"}, true, &order)).empty());
  EXPECT_TRUE(map.tree().floating_root());
  EXPECT_EQ(map.tree().dof_count(), 6 + 3 + 3 + 3 + 3);  // hips 6, spine, arm, forearm, hand
  s.poses[0].position = {0.3, 0.8, -0.2};
  ASSERT_TRUE(update(map, poses_of(s, order)).error.empty());
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  EXPECT_NEAR(params[0], 0.3, 1e-15);
  EXPECT_NEAR(params[1], -0.2, 1e-15);
  EXPECT_NEAR(params[2], -0.2, 1e-15);
  params[1] = -0.5;  // the solver crouches
  std::vector<glm::dquat> rotations(order.size());
  glm::dvec3 root(0.0);
  ASSERT_TRUE(map.pose_from_params(params.data(), rotations, root));
  EXPECT_NEAR(root.y, 0.5, 1e-15);
  EXPECT_EQ(map.point_in_tree(glm::dvec3(1, 2, 3)), glm::dvec3(1, 2, 3));
}

TEST(SkeletonTree, FixedRootMovedByTheAnimationShiftsTheGoalsInstead) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand"}, false, &order)).empty());
  s.poses[0].position += glm::dvec3(0.0, -0.25, 0.1);
  const PoseUpdate u = update(map, poses_of(s, order));
  EXPECT_TRUE(u.error.empty());
  EXPECT_FALSE(u.shape_changed);  // the root's position is no shape: the tree stays as built
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  TreeWorkspace ws(map.tree(), 4);
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 hand = glm::dvec3(s.globals()[size_t(find(s, "LeftHand"))][3]);
  EXPECT_LT(glm::length(map.point_in_base(tree_effector_position(map.tree(), ws, 0)) - hand), 1e-12);
  EXPECT_LT(glm::length(map.point_in_tree(hand) - tree_effector_position(map.tree(), ws, 0)), 1e-12);
}

TEST(SkeletonTree, AnimatedBoneLengthRebuildsTheTree) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand"}, false, &order)).empty());
  s.poses[size_t(find(s, "LeftLowerArm"))].position.y = 0.4;  // a stretchy arm
  const PoseUpdate u = update(map, poses_of(s, order));
  EXPECT_TRUE(u.error.empty());
  EXPECT_TRUE(u.shape_changed);
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  TreeWorkspace ws(map.tree(), 4);
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 hand = glm::dvec3(s.globals()[size_t(find(s, "LeftHand"))][3]);
  EXPECT_LT(glm::length(tree_effector_position(map.tree(), ws, 0) - hand), 1e-12);
}

JointSettings knee_hinge(const std::string& name) {
  JointSettings j;
  if (name == "LeftLowerLeg") {
    j.type = JointType::kHinge;
    j.hinge_axis_in_bone = {1, 0, 0};
    j.hinge_limit_enabled = true;
    j.hinge_min = 0.0;
    j.hinge_max = 150.0 * kPi / 180.0;
  }
  if (name == "Spine") {
    j.cone_limit_enabled = true;
    j.cone_angle = 0.3;
    j.motion_cost = 3.0;
  }
  return j;
}

TEST(SkeletonTree, JointSettingsBecomeHingesAndConesAndTheWarmStartRespectsThem) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftFoot", "Head"}, false, &order, &knee_hinge)).empty());
  const int knee = map.bone_of(find(s, "LeftLowerLeg"));
  const int spine = map.bone_of(find(s, "Spine"));
  ASSERT_GE(knee, 0);
  EXPECT_EQ(map.tree().joint_type(knee), JointType::kHinge);
  EXPECT_TRUE(map.tree().limits(spine).has_cone_limit);
  EXPECT_EQ(map.tree().motion_cost(spine), 3.0);
  EXPECT_EQ(map.tree().motion_cost(knee), 1.0);
  // An animated knee bent backwards and a spine bent beyond its cone start on their limits.
  const int shin = find(s, "LeftLowerLeg");
  s.poses[size_t(shin)].rotation = s.rests[size_t(shin)] * axis_angle(-0.4, {1, 0, 0});
  s.poses[size_t(find(s, "Spine"))].rotation = s.rests[size_t(find(s, "Spine"))] * axis_angle(0.9, {1, 0, 0});
  ASSERT_TRUE(update(map, poses_of(s, order)).error.empty());
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  EXPECT_NEAR(params[size_t(map.tree().dof_offset(knee))], 0.0, 1e-12);
  EXPECT_TRUE(within_tree_limits(map.tree(), params.data(), 1e-9));
}

// IKBody's posture task reads each joint's posture_stiffness per DOF: a floating root's 6 params
// take the root bone's, a bone without settings the default (JointSettings); out of [0, 1] is refused by name.
TEST(SkeletonTree, PostureStiffnessPerDofFromEachBonesJoint) {
  Skel s = body();
  SkeletonTreeDesc d = describe(s, "Hips", {"LeftFoot", "Head"}, true, nullptr, &knee_hinge);
  for (TreeBoneDesc& b : d.bones) {
    if (b.name == "Spine") b.joint.posture_stiffness = 1.0;
    if (b.name == "Hips") b.joint.posture_stiffness = 0.0;
  }
  SkeletonTree map;
  ASSERT_TRUE(map.build(d).empty());
  std::vector<double> stiffness(size_t(map.tree().dof_count()), -1.0);
  map.posture_stiffness(stiffness.data());
  const int spine = map.bone_of(find(s, "Spine")), knee = map.bone_of(find(s, "LeftLowerLeg"));
  for (int p = 0; p < 6; ++p) EXPECT_EQ(stiffness[size_t(p)], 0.0) << "root param " << p;
  for (int p = 0; p < 3; ++p) EXPECT_EQ(stiffness[size_t(map.tree().dof_offset(spine) + p)], 1.0);
  EXPECT_EQ(stiffness[size_t(map.tree().dof_offset(knee))], JointSettings().posture_stiffness);
  for (double v : stiffness) EXPECT_GE(v, 0.0);  // every DOF written
  for (TreeBoneDesc& b : d.bones)
    if (b.name == "Spine") b.joint.posture_stiffness = 1.5;
  SkeletonTree bad;
  const Message m = bad.build(d);
  EXPECT_FALSE(bad.valid());
  EXPECT_NE(std::string(m.c_str()).find("joint 'Spine': posture_stiffness (1.5) must be within [0, 1]"),
            std::string::npos)
      << m.c_str();
}

TEST(SkeletonTree, BuildErrorsNameTheBoneAndNothingHalfBuiltSurvives) {
  Skel s = body();
  SkeletonTreeDesc d = describe(s, "Hips", {"LeftFoot"}, false, nullptr, &knee_hinge);
  for (TreeBoneDesc& b : d.bones)
    if (b.name == "LeftLowerLeg") b.joint.hinge_min = 2.0, b.joint.hinge_max = 1.0;
  SkeletonTree map;
  const Message m = map.build(d);
  EXPECT_FALSE(map.valid());
  EXPECT_NE(std::string(m.c_str()).find("LeftLowerLeg"), std::string::npos) << m.c_str();
  EXPECT_NE(std::string(m.c_str()).find("hinge_min"), std::string::npos) << m.c_str();
  // The bone names the joint; its index inside the tree is not shown as well.
  EXPECT_EQ(std::string(m.c_str()).find(": joint "), std::string::npos) << m.c_str();
  EXPECT_EQ(map.bone_count(), 0);

  // A zero hinge axis: named as the IKChainJoint property users set, not the core's field.
  SkeletonTreeDesc zero_axis = describe(s, "Hips", {"LeftFoot"}, false, nullptr, &knee_hinge);
  for (TreeBoneDesc& b : zero_axis.bones)
    if (b.name == "LeftLowerLeg") b.joint.hinge_axis_in_bone = glm::dvec3(0.0);
  const std::string axis_message = map.build(zero_axis).c_str();
  EXPECT_NE(axis_message.find("joint 'LeftLowerLeg' (hinge_axis): hinge_axis must be"), std::string::npos)
      << axis_message;

  SkeletonTreeDesc no_effectors = describe(s, "Hips", {"LeftFoot"}, false);
  no_effectors.effector_bones.clear();
  EXPECT_NE(std::string(map.build(no_effectors).c_str()).find("no effectors"), std::string::npos);

  SkeletonTreeDesc hinge_root = describe(s, "Hips", {"LeftFoot"}, true);
  hinge_root.bones[0].joint.type = JointType::kHinge;
  EXPECT_NE(std::string(map.build(hinge_root).c_str()).find("floating root must be a ball"), std::string::npos);
}

TEST(SkeletonTree, NonFinitePoseIsRefusedByNameAndTheTreeKept) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand"}, false, &order)).empty());
  std::vector<BonePose> poses = poses_of(s, order);
  poses[2].position.x = std::nan("");
  const PoseUpdate u = update(map, poses);
  EXPECT_NE(std::string(u.error.c_str()).find(s.names[size_t(order[2])]), std::string::npos) << u.error.c_str();
  EXPECT_TRUE(map.valid());
  // A zero or non-finite rotation starts from the rest rotation; nothing non-finite comes out.
  poses = poses_of(s, order);
  poses[1].rotation = glm::dquat(std::nan(""), 0, 0, 0);
  ASSERT_TRUE(update(map, poses).error.empty());
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  for (double p : params) EXPECT_TRUE(std::isfinite(p));
}

// The perpendicular part of p - a with respect to the line a -> b, normalised.
glm::dvec3 off_line(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 axis = glm::normalize(b - a);
  return glm::normalize((p - a) - axis * glm::dot(p - a, axis));
}

TEST(SkeletonTree, PoleSwivelsTheBendPlaneAndKeepsTheLimbsEnd) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Skel s = body();
    std::vector<int> order;
    SkeletonTree map;
    ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand", "RightFoot"}, trial % 2 == 1, &order)).empty());
    for (int b : order)
      s.poses[size_t(b)].rotation = s.rests[size_t(b)] * so3::exp(glm::dvec3(u(rng), u(rng), u(rng)) * 0.6);
    ASSERT_TRUE(update(map, poses_of(s, order)).error.empty());
    std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
    map.params_from_pose(params.data());
    TreeWorkspace ws(map.tree(), 4);
    const int hand = map.bone_of(find(s, "LeftHand")), elbow = map.bone_of(find(s, "LeftLowerArm"));
    const int shoulder = map.bone_of(find(s, "LeftUpperArm"));
    EXPECT_EQ(map.pole_upper_bone(hand), shoulder);
    tree_forward_kinematics(map.tree(), params.data(), ws);
    const glm::dvec3 hand_before = ws.joint_origins[size_t(hand)];
    const glm::dvec3 pole = glm::dvec3(u(rng), u(rng), u(rng)) * 2.0;
    ASSERT_TRUE(map.swivel_toward_pole(hand, pole, params.data(), ws));
    tree_forward_kinematics(map.tree(), params.data(), ws);
    const glm::dvec3 a = ws.joint_origins[size_t(shoulder)], b = ws.joint_origins[size_t(hand)];
    EXPECT_LT(glm::length(b - hand_before), 1e-12);
    EXPECT_LT(glm::length(off_line(ws.joint_origins[size_t(elbow)], a, b) - off_line(pole, a, b)), 1e-9);
  }
}

TEST(SkeletonTree, PoleLeavesStraightLimbsAndShortLimbsAlone) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  // The rest arm is nearly straight (a 0.05 rad bend): it has a plane; a fully straight one does not.
  for (int b : {find(s, "LeftLowerArm")}) s.rests[size_t(b)] = s.poses[size_t(b)].rotation = glm::dquat(1, 0, 0, 0);
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand", "Spine"}, false, &order)).empty());
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  const std::vector<double> before = params;
  TreeWorkspace ws(map.tree(), 4);
  EXPECT_FALSE(map.swivel_toward_pole(map.bone_of(find(s, "LeftHand")), {0, 0, 5}, params.data(), ws));
  EXPECT_EQ(params, before);
  EXPECT_EQ(map.pole_upper_bone(map.bone_of(find(s, "Spine"))), -1);  // one bone below the root: no limb
}

// ---------------------------------------------------------------- look-at spread

// Hips -> Spine -> Head, the head's +Z looking at a point to the side: the head aims exactly, the
// spine and the head take their shares of the turn (about the vertical here, so the shares add up).
TEST(SkeletonTree, SpreadLookSharesTheTurnAndAimsExactly) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"Head"}, false, &order)).empty());
  const int spine = map.bone_of(find(s, "Spine")), head = map.bone_of(find(s, "Head"));
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  const std::vector<double> start = params;
  TreeWorkspace ws(map.tree(), 4);
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 axis_local = glm::conjugate(ws.joint_orientations[size_t(head)]) * glm::dvec3(0, 0, 1);
  const glm::dvec3 head_at = ws.joint_origins[size_t(head)];
  const glm::dvec3 target = head_at + 3.0 * glm::dvec3(std::sin(1.0), 0.0, std::cos(1.0));  // 1 rad to the side
  const int bones[] = {spine, head};
  const double shares[] = {0.25, 0.75};
  ASSERT_TRUE(map.spread_look(Span<const int>(bones, 2), Span<const double>(shares, 2), axis_local, target,
                              params.data(), ws));
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 facing = ws.joint_orientations[size_t(head)] * axis_local;
  EXPECT_LT(std::acos(std::min(1.0, glm::dot(facing, glm::normalize(target - ws.joint_origins[size_t(head)])))),
            1e-6);
  auto turned = [&](int bone) {
    const double* p = params.data() + map.tree().dof_offset(bone);
    const double* q = start.data() + map.tree().dof_offset(bone);
    return angle_between(so3::exp(glm::dvec3(p[0], p[1], p[2])), so3::exp(glm::dvec3(q[0], q[1], q[2])));
  };
  // The head origin moves a little as the spine turns (it sits 0.5 m up a tilted spine): a degree.
  EXPECT_NEAR(turned(spine), 0.25, 0.02);
  EXPECT_NEAR(turned(head), 0.75, 0.02);
}

// A share withheld by a joint's limit passes on: a spine whose twist is held to 0.05 rad turns no
// further, and the head still aims. Bad inputs leave params untouched.
TEST(SkeletonTree, SpreadLookKeepsLimitsAndRefusesBadInputs) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  auto joint_of = [](const std::string& name) {
    JointSettings j;
    if (name == "Spine") {
      j.twist_limit_enabled = true;
      j.twist_min = -0.05;
      j.twist_max = 0.05;
    }
    return j;
  };
  ASSERT_TRUE(map.build(describe(s, "Hips", {"Head"}, false, &order, +joint_of)).empty());
  const int spine = map.bone_of(find(s, "Spine")), head = map.bone_of(find(s, "Head"));
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  map.params_from_pose(params.data());
  TreeWorkspace ws(map.tree(), 4);
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 axis_local = glm::conjugate(ws.joint_orientations[size_t(head)]) * glm::dvec3(0, 0, 1);
  const glm::dvec3 target = ws.joint_origins[size_t(head)] + 3.0 * glm::dvec3(std::sin(1.0), 0.0, std::cos(1.0));
  const int bones[] = {spine, head};
  const double shares[] = {0.5, 0.5};
  const std::vector<double> before = params;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(map.spread_look(Span<const int>(bones, 2), Span<const double>(shares, 2), glm::dvec3(0.0), target,
                               params.data(), ws));
  EXPECT_FALSE(map.spread_look(Span<const int>(bones, 2), Span<const double>(shares, 2), axis_local,
                               glm::dvec3(nan, 0, 0), params.data(), ws));
  EXPECT_FALSE(map.spread_look(Span<const int>(bones, 2), Span<const double>(shares, 1), axis_local, target,
                               params.data(), ws));
  EXPECT_EQ(params, before);
  ASSERT_TRUE(map.spread_look(Span<const int>(bones, 2), Span<const double>(shares, 2), axis_local, target,
                              params.data(), ws));
  EXPECT_TRUE(within_tree_limits(map.tree(), params.data(), 1e-9));
  tree_forward_kinematics(map.tree(), params.data(), ws);
  const glm::dvec3 facing = ws.joint_orientations[size_t(head)] * axis_local;
  EXPECT_LT(std::acos(std::min(1.0, glm::dot(facing, glm::normalize(target - ws.joint_origins[size_t(head)])))),
            1e-6);
}

TEST(SkeletonTree, PerFrameCallsAllocateNothing) {
  Skel s = body();
  std::vector<int> order;
  SkeletonTree map;
  ASSERT_TRUE(map.build(describe(s, "Hips", {"LeftHand", "RightFoot", "Head"}, true, &order)).empty());
  std::vector<BonePose> poses = poses_of(s, order);
  std::vector<double> params(size_t(map.tree().dof_count()), 0.0);
  std::vector<glm::dquat> rotations(order.size());
  glm::dvec3 root(0.0);
  TreeWorkspace ws(map.tree(), 4);
  poses[0].position.y = 0.9;  // the floating hips moved: no rebuild
  const std::size_t before = test::allocation_count();
  const PoseUpdate u = update(map, poses);
  map.params_from_pose(params.data());
  const bool ok = map.pose_from_params(params.data(), rotations, root);
  const int look[] = {map.bone_of(find(s, "Spine")), map.bone_of(find(s, "Head"))};
  const double shares[] = {0.3, 0.7};
  map.spread_look(Span<const int>(look, 2), Span<const double>(shares, 2), {0, 0, 1}, {2, 1.5, 1}, params.data(), ws);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(u.error.empty());
  EXPECT_FALSE(u.shape_changed);
  EXPECT_TRUE(ok);
}

}  // namespace
}  // namespace ikchain::godot
