// The skeleton <-> chain mapping (src/godot/skeleton_chain.*), engine-free. The oracle is written
// here plainly, the way Godot composes bones: global = parent_global * T(position) R(rotation)
// S(scale). Rigs are character-like: bones along their own +Y with rotated rests, an arm going
// sideways from a spine, a leg from a straight T-pose.
#include "skeleton_chain.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "../core/alloc_counter.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/solve.hpp"
#include "ikchain/so3.hpp"

namespace ikchain::godot {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = so3::kPi;

glm::dquat axis_angle(double angle, glm::dvec3 axis) { return glm::angleAxis(angle, glm::normalize(axis)); }

// Angle of the rotation taking a to b (sign of the quaternions ignored).
double angle_between(const glm::dquat& a, const glm::dquat& b) {
  return glm::length(so3::log(glm::normalize(glm::conjugate(a) * b)));
}

// ---------------------------------------------------------------- the oracle

glm::dmat4 trs(const glm::dvec3& position, const glm::dquat& rotation, const glm::dvec3& scale) {
  return glm::translate(glm::dmat4(1.0), position) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), scale);
}

// Global transforms of the bones of a simple chain (bone i's parent is bone i-1), from `base`.
std::vector<glm::dmat4> oracle_globals(const glm::dmat4& base, const std::vector<BonePose>& poses) {
  std::vector<glm::dmat4> out;
  glm::dmat4 global = base;
  for (const BonePose& p : poses) {
    global = global * trs(p.position, p.rotation, p.scale);
    out.push_back(global);
  }
  return out;
}

glm::dvec3 origin(const glm::dmat4& m) { return glm::dvec3(m[3]); }

// The rotation part of a transform with positive uniform scale.
glm::dquat rotation_part(const glm::dmat4& m) {
  glm::dmat3 r(m);
  for (int c = 0; c < 3; ++c) r[c] = glm::normalize(r[c]);
  return glm::normalize(glm::quat_cast(r));
}

// ---------------------------------------------------------------- rigs

struct Rig {
  SkeletonChainDesc desc;
  std::vector<glm::dquat> rests;  // rest rotations, to pose bones relative to their rest
};

void add_bone(Rig& rig, const std::string& name, const glm::dvec3& position, const glm::dquat& rest,
              const glm::dvec3& scale = glm::dvec3(1.0)) {
  ChainBoneDesc b;
  b.name = name;
  b.skeleton_bone = 10 + int(rig.desc.bones.size());
  // Rests imported from a file often carry the bone's scale: the mapping takes only the rotation.
  b.rest_basis_in_parent = glm::mat3_cast(rest) * glm::dmat3(glm::scale(glm::dmat4(1.0), scale));
  b.pose.position = position;
  b.pose.rotation = rest;
  b.pose.scale = scale;
  rig.desc.bones.push_back(b);
  rig.rests.push_back(rest);
}

// A left arm from the spine: the upper arm's rest turns its +Y to point sideways (+X) with a roll,
// the forearm and hand have rests of their own.
Rig sideways_arm() {
  Rig r;
  add_bone(r, "upper_arm", glm::dvec3(0.2, 0.1, 0.05), axis_angle(-kPi / 2, {0, 0, 1}) * axis_angle(0.5, {0, 1, 0}));
  add_bone(r, "forearm", glm::dvec3(0, 0.3, 0), axis_angle(0.1, {1, 0, 0}) * axis_angle(-0.3, {0, 1, 0}));
  add_bone(r, "hand", glm::dvec3(0, 0.25, 0), axis_angle(0.4, {0, 1, 0}) * axis_angle(0.2, {0, 0, 1}));
  return r;
}

// A straight leg from a T-pose import: the thigh's rest points its +Y down (180 degrees about Z)
// with a roll, the shin straight below it, the foot turned forward.
Rig tpose_leg() {
  Rig r;
  add_bone(r, "thigh", glm::dvec3(0.1, -0.05, 0.0), axis_angle(kPi, {0, 0, 1}) * axis_angle(0.15, {0, 1, 0}));
  add_bone(r, "shin", glm::dvec3(0, 0.45, 0), glm::dquat(1, 0, 0, 0));
  add_bone(r, "foot", glm::dvec3(0, 0.42, 0), axis_angle(-1.2, {1, 0, 0}));
  return r;
}

std::vector<BonePose> poses_of(const Rig& rig) {
  std::vector<BonePose> out;
  for (const ChainBoneDesc& b : rig.desc.bones) out.push_back(b.pose);
  return out;
}

glm::dquat random_rotation(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  glm::dvec3 axis(u(rng), u(rng), u(rng));
  if (glm::length(axis) < 1e-3) axis = glm::dvec3(1, 0, 0);
  return axis_angle(0.5 * (u(rng) + 1.0) * max_angle, axis);
}

// Random joint pose rotations (rest * a random turn) written into `poses`.
std::vector<glm::dquat> random_joint_rotations(const Rig& rig, int joints, std::mt19937& rng, double max_angle = 2.5) {
  std::vector<glm::dquat> q;
  for (int i = 0; i < joints; ++i) q.push_back(rig.rests[size_t(i)] * random_rotation(rng, max_angle));
  return q;
}

std::vector<BonePose> with_rotations(std::vector<BonePose> poses, const std::vector<glm::dquat>& rotations) {
  for (size_t i = 0; i < rotations.size(); ++i) poses[i].rotation = rotations[i];
  return poses;
}

SkeletonChain build_ok(const SkeletonChainDesc& desc) {
  SkeletonChain c;
  const Message m = c.build(desc);
  EXPECT_TRUE(m.empty()) << m.c_str();
  EXPECT_TRUE(c.valid());
  return c;
}

void expect_near(const glm::dvec3& a, const glm::dvec3& b, double tol, const std::string& what) {
  EXPECT_LE(glm::length(a - b), tol) << what << ": (" << a.x << ", " << a.y << ", " << a.z << ") vs (" << b.x
                                     << ", " << b.y << ", " << b.z << ")";
}

struct CoreFk {
  Workspace ws;
  std::vector<double> params;
};
CoreFk core_fk(const SkeletonChain& c, const std::vector<glm::dquat>& joint_rotations) {
  CoreFk f{Workspace(c.chain(), 4), std::vector<double>(size_t(c.chain().dof_count()), 0.0)};
  c.params_from_rotations(joint_rotations, f.params.data());
  forward_kinematics(c.chain(), f.params.data(), f.ws);
  return f;
}

// ---------------------------------------------------------------- rotation_of_basis

TEST(RotationOfBasis, TakesTheRotationOfScaledAndMirroredBasesLikeGodot) {
  std::mt19937 rng(1);
  for (int t = 0; t < 50; ++t) {
    const glm::dquat q = random_rotation(rng, 3.0);
    const glm::dmat3 r = glm::mat3_cast(q);
    const glm::dmat3 scaled = r * glm::dmat3(glm::scale(glm::dmat4(1.0), glm::dvec3(0.5, 2.0, 1.3)));
    EXPECT_LT(angle_between(rotation_of_basis(scaled), q), 1e-12);
    // A uniform negative scale is a reflection: Godot negates the basis and keeps the rotation.
    EXPECT_LT(angle_between(rotation_of_basis(-2.0 * r), q), 1e-12);
  }
  const glm::dquat identity(1, 0, 0, 0);
  EXPECT_EQ(rotation_of_basis(glm::dmat3(0.0)), identity);
  glm::dmat3 bad(1.0);
  bad[1][2] = kNaN;
  EXPECT_EQ(rotation_of_basis(bad), identity);
}

// ---------------------------------------------------------------- build

TEST(SkeletonChainBuild, SidewaysArmJointsRestsAndOffsets) {
  const Rig rig = sideways_arm();
  const SkeletonChain c = build_ok(rig.desc);
  ASSERT_EQ(c.joint_count(), 2);  // upper_arm, forearm; the hand's origin is the effector
  ASSERT_EQ(c.bone_count(), 3);
  EXPECT_EQ(c.bone_name(1), "forearm");
  EXPECT_EQ(c.skeleton_bone(2), 12);
  EXPECT_EQ(c.chain_bone_of(12), 2);
  EXPECT_EQ(c.chain_bone_of(99), -1);
  for (int i = 0; i < 2; ++i) EXPECT_LT(angle_between(c.chain().rest_rotation(i), rig.rests[size_t(i)]), 1e-12);
  expect_near(c.chain().offset_translation(0), glm::dvec3(0.2, 0.1, 0.05), 0.0, "root offset");
  expect_near(c.chain().offset_translation(1), glm::dvec3(0, 0.3, 0), 0.0, "forearm offset");
  expect_near(c.chain().tip_offset(), glm::dvec3(0, 0.25, 0), 0.0, "tip offset");
  EXPECT_DOUBLE_EQ(c.chain().total_length(), 0.55);
  EXPECT_LT(angle_between(c.tip_rotation_in_effector(), rig.rests[2]), 1e-15);
  EXPECT_FALSE(c.has_non_uniform_scale());
  EXPECT_TRUE(c.scale_warning().empty());
}

// Every invalid field in turn: the build fails with a message naming the bone and the field. The
// core builder validates the limits and names a joint by its index; the message names its bone
// instead, and where to fix it.
TEST(SkeletonChainBuild, EachInvalidFieldNamesTheBoneAndTheField) {
  struct Case {
    std::function<void(SkeletonChainDesc&)> change;
    std::vector<std::string> expected;  // each is in the message; none: the build succeeds
  };
  auto shin = [](SkeletonChainDesc& d) -> JointSettings& { return d.bones[1].joint; };
  auto thigh = [](SkeletonChainDesc& d) -> JointSettings& { return d.bones[0].joint; };
  auto hinge = [](JointSettings& j) { j.type = JointType::kHinge; j.hinge_limit_enabled = true; };
  const std::string fix = "; fix it in the bone's IKChainJoint";
  const std::vector<Case> cases = {
      {[&](SkeletonChainDesc& d) { hinge(shin(d)); shin(d).hinge_min = 1.5; shin(d).hinge_max = 0.5; },
       {"joint 'shin': hinge_min (1.5) > hinge_max (0.5)", fix}},
      {[&](SkeletonChainDesc& d) { hinge(shin(d)); shin(d).hinge_min = kNaN; shin(d).hinge_max = 0.5; },
       {"joint 'shin': hinge_min", "finite", fix}},
      {[&](SkeletonChainDesc& d) { hinge(shin(d)); shin(d).hinge_axis_in_bone = glm::dvec3(0.0); },
       {"joint 'shin': hinge_axis", "non-zero", fix}},
      {[&](SkeletonChainDesc& d) { thigh(d).cone_limit_enabled = true; thigh(d).cone_angle = 4.0; },
       {"joint 'thigh': cone_angle", "[0, pi]", fix}},
      {[&](SkeletonChainDesc& d) { thigh(d).twist_limit_enabled = true; thigh(d).twist_min = 0.5; thigh(d).twist_max = -0.5; },
       {"joint 'thigh': twist_min (0.5) > twist_max (-0.5)", fix}},
      {[&](SkeletonChainDesc& d) { thigh(d).twist_limit_enabled = true; thigh(d).twist_min = -4.0; thigh(d).twist_max = 0.5; },
       {"joint 'thigh': twist_min", "[-pi, pi]", fix}},
      {[&](SkeletonChainDesc& d) { thigh(d).cone_limit_enabled = true; thigh(d).cone_angle = 1.0; thigh(d).twist_axis_in_bone = glm::dvec3(0.0); },
       {"joint 'thigh': ", "twist_axis", "non-zero", fix}},
      {[&](SkeletonChainDesc& d) { thigh(d).type = JointType(5); },
       {"joint 'thigh': type (5) must be JOINT_BALL (0) or JOINT_HINGE (1)"}},
      {[&](SkeletonChainDesc& d) { thigh(d).type = JointType::kPrismatic; },  // the core has it, the mapping does not
       {"joint 'thigh': type (2) must be JOINT_BALL (0) or JOINT_HINGE (1)"}},
      {[&](SkeletonChainDesc& d) { d.bones[1].pose.position.x = kNaN; },
       {"bone 'shin': pose position (nan, 0.45, 0) is not finite"}},
      {[&](SkeletonChainDesc& d) { d.bones[1].pose.position.y = 1e60; },  // finite, beyond what the core takes
       {"joint 'shin': offset_translation (0, 1e+60, 0)"}},
      {[&](SkeletonChainDesc& d) { d.bones[0].pose.scale.x = kInf; },
       {"bone 'thigh': pose scale (inf, 1, 1) is not finite"}},
      {[&](SkeletonChainDesc& d) { d.bones[1].rest_basis_in_parent = glm::dmat3(0.0); },
       {"bone 'shin': rest basis is not finite or has zero scale"}},
      {[&](SkeletonChainDesc& d) { for (auto& b : d.bones) b.pose.position = glm::dvec3(0.0); },
       {"zero-length chain: the bones from 'thigh' to 'foot' are all at one point"}},
      {[&](SkeletonChainDesc& d) { d.bones[1].pose.scale = glm::dvec3(0.0); },  // collapses shin -> foot
       {}},  // the thigh -> shin bone still has length: a valid (if odd) chain
      {[&](SkeletonChainDesc& d) { d.bones.resize(1); },
       {"root_bone and tip_bone are the same bone 'thigh': pick a tip_bone below root_bone, or turn on extend_tip_bone"}},
      {[&](SkeletonChainDesc& d) { d.bones.clear(); }, {"no bones: set root_bone and tip_bone"}},
      {[&](SkeletonChainDesc& d) { d.extend_tip_bone = true; d.tip_extension_length = -1.0; },
       {"tip_extension_length (-1) must be finite and >= 0"}},
      {[&](SkeletonChainDesc& d) { d.extend_tip_bone = true; d.tip_extension_axis = TipAxis(7); },
       {"tip_extension_axis (7) must be one of AXIS_PLUS_X (0) .. AXIS_MINUS_Z (5)"}},
      // A disabled limit is not checked, nor the twist axis of a ball joint without limits.
      {[&](SkeletonChainDesc& d) { shin(d).type = JointType::kHinge; shin(d).hinge_min = 2.0; shin(d).hinge_max = -2.0; },
       {}},
      {[&](SkeletonChainDesc& d) { thigh(d).twist_min = 0.5; thigh(d).twist_max = -0.5; thigh(d).cone_angle = 4.0; thigh(d).twist_axis_in_bone = glm::dvec3(0.0); },
       {}},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    SCOPED_TRACE("case " + std::to_string(k) + ": " + (cases[k].expected.empty() ? "" : cases[k].expected[0]));
    Rig rig = tpose_leg();
    cases[k].change(rig.desc);
    SkeletonChain c;
    const Message m = c.build(rig.desc);
    if (cases[k].expected.empty()) {
      EXPECT_TRUE(m.empty()) << m.c_str();
      EXPECT_TRUE(c.valid());
      continue;
    }
    for (const std::string& part : cases[k].expected)
      EXPECT_NE(std::string(m.c_str()).find(part), std::string::npos) << "'" << part << "' not in: " << m.c_str();
    // Only a joint setting is fixed in the IKChainJoint (an offset comes from the bone's pose).
    const bool hint_expected = std::find(cases[k].expected.begin(), cases[k].expected.end(), fix) != cases[k].expected.end();
    EXPECT_EQ(std::string(m.c_str()).find(fix) != std::string::npos, hint_expected) << m.c_str();
    EXPECT_FALSE(c.valid());
    EXPECT_EQ(c.joint_count(), 0);
    EXPECT_EQ(c.bone_count(), 0);
    // A failed chain's per-frame functions do nothing and claim nothing.
    const std::vector<Goal> goals{Goal::position(glm::dvec3(0.0))};
    EXPECT_EQ(c.measure_pose({}, goals).combined, HUGE_VAL);
  }
}

// ---------------------------------------------------------------- FK round trips

TEST(SkeletonChainFk, SidewaysArmRandomPosesMatchTheOracle) {
  const Rig rig = sideways_arm();
  SkeletonChain c = build_ok(rig.desc);
  std::mt19937 rng(7);
  for (int t = 0; t < 200; ++t) {
    const std::vector<glm::dquat> q = random_joint_rotations(rig, 2, rng);
    const CoreFk f = core_fk(c, q);
    const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
    for (int i = 0; i < 2; ++i) {
      expect_near(f.ws.joint_origins[size_t(i)], origin(g[size_t(i)]), 1e-12, "joint origin");
      EXPECT_LT(angle_between(f.ws.joint_orientations[size_t(i)], rotation_part(g[size_t(i)])), 1e-12);
    }
    expect_near(f.ws.tip, origin(g[2]), 1e-12, "tip");
    // The tip bone's own rotation = effector orientation * tip_rotation_in_effector.
    EXPECT_LT(angle_between(f.ws.joint_orientations[1] * c.tip_rotation_in_effector(), rotation_part(g[2])), 1e-12);
    // And back: params -> pose rotations gives the same rotations.
    std::vector<glm::dquat> back(2);
    ASSERT_TRUE(c.rotations_from_params(f.params.data(), back));
    for (int i = 0; i < 2; ++i) EXPECT_LT(angle_between(back[size_t(i)], q[size_t(i)]), 1e-12);
  }
}

TEST(SkeletonChainFk, TPoseLegWithUniformScalesMatchesTheOracle) {
  Rig rig = tpose_leg();
  rig.desc.bones[0].pose.scale = glm::dvec3(1.3);
  rig.desc.bones[1].pose.scale = glm::dvec3(0.7);
  rig.desc.bones[2].pose.scale = glm::dvec3(2.0);  // the tip bone's scale moves nothing
  SkeletonChain c = build_ok(rig.desc);
  EXPECT_FALSE(c.has_non_uniform_scale());
  expect_near(c.chain().offset_translation(1), glm::dvec3(0, 0.45 * 1.3, 0), 1e-15, "shin offset");
  expect_near(c.chain().tip_offset(), glm::dvec3(0, 0.42 * 1.3 * 0.7, 0), 1e-15, "foot offset");
  // At rest the leg hangs straight down from the hip.
  const std::vector<glm::dmat4> rest = oracle_globals(glm::dmat4(1.0), poses_of(rig));
  expect_near(c.chain().rest_tip(), origin(rest[2]), 1e-12, "rest tip");
  EXPECT_NEAR(origin(rest[2]).y, -0.05 - (0.45 + 0.42 * 0.7) * 1.3, 1e-12);
  std::mt19937 rng(11);
  for (int t = 0; t < 200; ++t) {
    const std::vector<glm::dquat> q = random_joint_rotations(rig, 2, rng);
    const CoreFk f = core_fk(c, q);
    const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
    expect_near(f.ws.joint_origins[1], origin(g[1]), 1e-12, "knee");
    expect_near(f.ws.tip, origin(g[2]), 1e-12, "ankle");
    EXPECT_LT(angle_between(f.ws.joint_orientations[1] * c.tip_rotation_in_effector(), rotation_part(g[2])), 1e-12);
    // The exact (affine) FK agrees with both when scales are uniform.
    c.forward_kinematics_affine(q);
    expect_near(c.effector_in_base(), origin(g[2]), 1e-12, "affine ankle");
  }
}

TEST(SkeletonChainFk, ExtendedTipBoneAlongEachAxis) {
  const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::mt19937 rng(3);
  for (int a = 0; a < 6; ++a) {
    SCOPED_TRACE("axis " + std::to_string(a));
    Rig rig = sideways_arm();
    rig.desc.extend_tip_bone = true;
    rig.desc.tip_extension_axis = TipAxis(a);
    rig.desc.tip_extension_length = 0.08;
    rig.desc.bones[2].pose.scale = glm::dvec3(1.5);  // the hand's scale stretches its extension
    SkeletonChain c = build_ok(rig.desc);
    ASSERT_EQ(c.joint_count(), 3);  // the hand turns too
    EXPECT_EQ(c.tip_rotation_in_effector(), glm::dquat(1, 0, 0, 0));
    EXPECT_NEAR(c.chain().total_length(), 0.3 + 0.25 + 0.08 * 1.5, 1e-15);
    for (int t = 0; t < 20; ++t) {
      const std::vector<glm::dquat> q = random_joint_rotations(rig, 3, rng);
      const CoreFk f = core_fk(c, q);
      const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
      const glm::dvec3 fingertip = glm::dvec3(g[2] * glm::dvec4(0.08 * axes[a], 1.0));
      expect_near(f.ws.tip, fingertip, 1e-12, "extended tip");
      c.forward_kinematics_affine(q);
      expect_near(c.effector_in_base(), fingertip, 1e-12, "affine extended tip");
    }
  }
}

// ---------------------------------------------------------------- hinges

Rig leg_with_knee(double lo, double hi) {
  Rig rig = tpose_leg();
  JointSettings& knee = rig.desc.bones[1].joint;
  knee.type = JointType::kHinge;
  knee.hinge_axis_in_bone = glm::dvec3(1, 0, 0);
  knee.hinge_limit_enabled = true;
  knee.hinge_min = lo;
  knee.hinge_max = hi;
  return rig;
}

TEST(SkeletonChainHinge, PoseParamsRoundTripAndOracle) {
  const Rig rig = leg_with_knee(0.0, 2.5);
  const SkeletonChain c = build_ok(rig.desc);
  ASSERT_EQ(c.chain().dof_count(), 4);  // ball hip + hinge knee
  std::mt19937 rng(5);
  for (int t = 0; t < 100; ++t) {
    const double knee = 2.5 * t / 99.0;
    std::vector<double> params{0, 0, 0, knee};
    const glm::dvec3 hip = glm::dvec3(random_rotation(rng, 2.0) * glm::dvec3(0, 0, 0)) + so3::log(random_rotation(rng, 2.0));
    params[0] = hip.x, params[1] = hip.y, params[2] = hip.z;
    std::vector<glm::dquat> q(2);
    ASSERT_TRUE(c.rotations_from_params(params.data(), q));
    // The knee's pose rotation is its rest turned about its own X axis.
    EXPECT_LT(angle_between(q[1], rig.rests[1] * axis_angle(knee, {1, 0, 0})), 1e-12);
    std::vector<double> back(4, 0.0);
    c.params_from_rotations(q, back.data());
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(back[size_t(k)], params[size_t(k)], 1e-12) << "param " << k;
    // Core FK of those params is where the oracle puts the ankle.
    Workspace ws(c.chain(), 1);
    forward_kinematics(c.chain(), params.data(), ws);
    const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
    expect_near(ws.tip, origin(g[2]), 1e-12, "ankle");
  }
}

TEST(SkeletonChainHinge, GeneralAxisInTheBoneFrameWithARotatedRest) {
  Rig rig = sideways_arm();
  JointSettings& elbow = rig.desc.bones[1].joint;
  elbow.type = JointType::kHinge;
  elbow.hinge_axis_in_bone = glm::dvec3(0.3, -0.2, 1.0);  // not normalized on purpose
  const SkeletonChain c = build_ok(rig.desc);
  for (double angle : {-2.0, -0.5, 0.0, 0.7, 1.9, 3.0}) {
    std::vector<double> params{0.2, -0.1, 0.3, angle};
    std::vector<glm::dquat> q(2);
    ASSERT_TRUE(c.rotations_from_params(params.data(), q));
    EXPECT_LT(angle_between(q[1], rig.rests[1] * axis_angle(angle, elbow.hinge_axis_in_bone)), 1e-12);
    Workspace ws(c.chain(), 1);
    forward_kinematics(c.chain(), params.data(), ws);
    const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
    expect_near(ws.tip, origin(g[2]), 1e-12, "wrist");
    std::vector<double> back(4, 0.0);
    c.params_from_rotations(q, back.data());
    EXPECT_NEAR(back[3], angle, 1e-12);
  }
}

TEST(SkeletonChainHinge, WarmStartKeepsTheTwistAndClampsToTheNearerLimit) {
  const Rig rig = leg_with_knee(0.0, 2.5);
  const SkeletonChain c = build_ok(rig.desc);
  auto knee_param = [&](const glm::dquat& motion) {
    const std::vector<glm::dquat> q{rig.rests[0], rig.rests[1] * motion};
    std::vector<double> p(4, 0.0);
    c.params_from_rotations(q, p.data());
    return p[3];
  };
  // An animated knee with some swing (about Z, perpendicular to the hinge): only the turn about X counts.
  EXPECT_NEAR(knee_param(axis_angle(0.4, {0, 0, 1}) * axis_angle(0.9, {1, 0, 0})), 0.9, 1e-12);
  EXPECT_NEAR(knee_param(axis_angle(-0.2, {1, 0, 0})), 0.0, 0.0);   // just below the minimum
  EXPECT_NEAR(knee_param(axis_angle(2.8, {1, 0, 0})), 2.5, 0.0);    // just above the maximum
  // -3.0 rad is 0.78 rad past 2.5 going round, 3.0 rad from 0: the nearer limit is 2.5.
  EXPECT_NEAR(knee_param(axis_angle(-3.0, {1, 0, 0})), 2.5, 0.0);

  // Limits beyond (-pi, pi]: an angle inside them one turn away is kept (3.0 = -3.28 + 2 pi).
  const Rig wide = leg_with_knee(-4.0, -3.0);
  const SkeletonChain cw = build_ok(wide.desc);
  const std::vector<glm::dquat> q{wide.rests[0], wide.rests[1] * axis_angle(3.0, {1, 0, 0})};
  std::vector<double> p(4, 0.0);
  cw.params_from_rotations(q, p.data());
  EXPECT_NEAR(p[3], 3.0 - 2.0 * kPi, 1e-12);
}

TEST(SkeletonChainParams, BallWarmStartIsProjectedOntoItsLimits) {
  Rig rig = tpose_leg();
  JointSettings& hip = rig.desc.bones[0].joint;
  hip.cone_limit_enabled = true;
  hip.cone_angle = 0.5;
  hip.twist_limit_enabled = true;
  hip.twist_min = -0.2;
  hip.twist_max = 0.2;
  const SkeletonChain c = build_ok(rig.desc);
  std::mt19937 rng(9);
  int outside = 0;
  for (int t = 0; t < 100; ++t) {
    const std::vector<glm::dquat> q = random_joint_rotations(rig, 2, rng, 2.5);
    std::vector<double> raw(6, 0.0);
    const glm::dvec3 r = so3::log(glm::conjugate(rig.rests[0]) * q[0]);
    raw[0] = r.x, raw[1] = r.y, raw[2] = r.z;
    outside += within_limits(c.chain(), raw.data(), 1e-9) ? 0 : 1;
    std::vector<double> p(6, 0.0);
    c.params_from_rotations(q, p.data());
    EXPECT_TRUE(within_limits(c.chain(), p.data(), 1e-9));
  }
  EXPECT_GT(outside, 50);  // the poses did violate the limits before projection
}

TEST(SkeletonChainParams, NonFiniteInputsGiveDefinedResults) {
  const Rig rig = leg_with_knee(-1.0, 1.0);
  const SkeletonChain c = build_ok(rig.desc);
  // A NaN or zero pose rotation counts as the rest rotation: params 0 (0 is inside the limits).
  std::vector<double> p(4, 7.0);
  const std::vector<glm::dquat> broken{glm::dquat(kNaN, 0, 0, 0), glm::dquat(0, 0, 0, 0)};
  c.params_from_rotations(broken, p.data());
  for (double v : p) EXPECT_EQ(v, 0.0);
  // Non-finite params: refused, the node writes nothing.
  std::vector<double> bad{0.1, kNaN, 0.0, 0.2};
  std::vector<glm::dquat> q(2);
  EXPECT_FALSE(c.rotations_from_params(bad.data(), q));
  std::vector<double> good{0.1, 0.2, 0.0, 0.2};
  EXPECT_TRUE(c.rotations_from_params(good.data(), q));
}

// ---------------------------------------------------------------- per-frame shape refresh

TEST(SkeletonChainRefresh, AnimatedPositionIsDetectedAndAppliedInPlace) {
  Rig rig = sideways_arm();
  SkeletonChain c = build_ok(rig.desc);
  std::vector<BonePose> poses = poses_of(rig);
  EXPECT_FALSE(c.shape_differs(poses));
  PoseUpdate u = c.update_pose(poses);
  EXPECT_FALSE(u.shape_changed);
  EXPECT_TRUE(u.error.empty());

  // Only rotations moved: no shape change, but the tip frame follows the hand's rotation.
  poses[2].rotation = axis_angle(1.0, {0, 0, 1});
  EXPECT_FALSE(c.shape_differs(poses));
  u = c.update_pose(poses);
  EXPECT_FALSE(u.shape_changed);
  EXPECT_LT(angle_between(c.tip_rotation_in_effector(), poses[2].rotation), 1e-15);

  // A stretchy forearm and an animated hand position (as set_bone_pose_position does).
  poses[1].position = glm::dvec3(0, 0.4, 0.01);
  poses[2].position = glm::dvec3(0.02, 0.3, 0);
  EXPECT_TRUE(c.shape_differs(poses));
  u = c.update_pose(poses);
  EXPECT_TRUE(u.shape_changed);
  EXPECT_TRUE(u.error.empty()) << u.error.c_str();
  EXPECT_FALSE(c.shape_differs(poses));
  // The updated chain equals a chain freshly built from the new poses, to the last bit.
  Rig fresh_rig = rig;
  for (size_t i = 0; i < poses.size(); ++i) fresh_rig.desc.bones[i].pose = poses[i];
  const SkeletonChain fresh = build_ok(fresh_rig.desc);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(c.chain().offset_translation(i), fresh.chain().offset_translation(i));
    EXPECT_EQ(c.chain().bone_length(i), fresh.chain().bone_length(i));
    EXPECT_EQ(c.chain().offset_direction(i), fresh.chain().offset_direction(i));
    EXPECT_EQ(c.chain().rest_joint_origins()[size_t(i)], fresh.chain().rest_joint_origins()[size_t(i)]);
  }
  EXPECT_EQ(c.chain().tip_offset(), fresh.chain().tip_offset());
  EXPECT_EQ(c.chain().tip_direction(), fresh.chain().tip_direction());
  EXPECT_EQ(c.chain().rest_tip(), fresh.chain().rest_tip());
  EXPECT_EQ(c.chain().total_length(), fresh.chain().total_length());
  // And the solver's FK puts the hand where the oracle does.
  std::mt19937 rng(13);
  const std::vector<glm::dquat> q = random_joint_rotations(rig, 2, rng);
  const CoreFk f = core_fk(c, q);
  expect_near(f.ws.tip, origin(oracle_globals(glm::dmat4(1.0), with_rotations(poses, q))[2]), 1e-12, "hand");
}

TEST(SkeletonChainRefresh, BadShapeIsReportedAndThePreviousChainKept) {
  const Rig rig = tpose_leg();
  SkeletonChain c = build_ok(rig.desc);
  const glm::dvec3 tip_before = c.chain().tip_offset();
  std::vector<BonePose> poses = poses_of(rig);

  poses[2].position.y = kNaN;
  PoseUpdate u = c.update_pose(poses);
  EXPECT_NE(std::string(u.error.c_str()).find("bone 'foot': pose position (0, nan, 0) is not finite"), std::string::npos)
      << u.error.c_str();
  EXPECT_FALSE(u.shape_changed);
  EXPECT_EQ(c.chain().tip_offset(), tip_before);
  EXPECT_TRUE(c.shape_differs(poses));  // still differs: re-checked next frame

  poses = poses_of(rig);
  for (BonePose& p : poses) p.position = glm::dvec3(0.0);
  u = c.update_pose(poses);
  EXPECT_NE(std::string(u.error.c_str()).find("zero-length chain"), std::string::npos) << u.error.c_str();
  EXPECT_EQ(c.chain().tip_offset(), tip_before);

  const std::vector<BonePose> too_few(2);
  u = c.update_pose(too_few);
  EXPECT_NE(std::string(u.error.c_str()).find("2 bone poses given for a chain of 3 bones"), std::string::npos);

  poses = poses_of(rig);
  poses[2].position.y = 0.5;
  u = c.update_pose(poses);
  EXPECT_TRUE(u.error.empty());
  EXPECT_TRUE(u.shape_changed);
  EXPECT_EQ(c.chain().tip_offset(), glm::dvec3(0, 0.5, 0));
}

TEST(SkeletonChainRefresh, PerFrameCallsAllocateNothing) {
  Rig rig = leg_with_knee(0.0, 2.5);
  SkeletonChain c = build_ok(rig.desc);
  std::vector<BonePose> poses = poses_of(rig);
  std::vector<double> params(size_t(c.chain().dof_count()), 0.0);
  std::vector<glm::dquat> old_rotations{rig.rests[0], rig.rests[1]};
  std::vector<glm::dquat> new_rotations(2), blended(2);
  const std::vector<Goal> goals{Goal::position(glm::dvec3(0.2, -0.6, 0.3)),
                                Goal::orientation(axis_angle(0.3, {0, 1, 0}))};
  BaseFrame base;
  ASSERT_TRUE(BaseFrame::make(glm::dmat4(2.0), glm::dmat4(1.0), base));

  const std::size_t before = test::allocation_count();
  double sink = 0.0;
  for (int frame = 0; frame < 50; ++frame) {
    poses[1].position.y = 0.45 + 0.001 * frame;  // a stretching shin: the chain changes every frame
    const PoseUpdate u = c.update_pose(poses);
    sink += u.shape_changed ? 1.0 : 0.0;
    sink += c.shape_differs(poses) ? 1.0 : 0.0;
    c.params_from_rotations(old_rotations, params.data());
    params[3] += 0.01;
    c.rotations_from_params(params.data(), new_rotations);
    sink += c.measure_blended_pose(old_rotations, new_rotations, 0.5, goals, blended).combined;
    sink += c.measure_pose(new_rotations, goals).combined;
    sink += base.point_in_base(glm::dvec3(1.0)).x + base.rotation_in_base(glm::dmat4(1.0)).w;
    sink += c.effector_orientation_for_tip_bone(glm::dquat(1, 0, 0, 0)).w + c.aim_axis_in_effector({0, 1, 0}).y;
  }
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sink));
  EXPECT_NEAR(c.chain().tip_offset().y, 0.42, 1e-15);
  EXPECT_NEAR(c.chain().offset_translation(1).y, 0.45 + 0.049, 1e-15);
}

// ---------------------------------------------------------------- non-uniform scale

TEST(SkeletonChainScale, NonUniformScaleOnAJointIsDetectedAndNamed) {
  Rig rig = sideways_arm();
  rig.desc.bones[1].pose.scale = glm::dvec3(1, 2, 1);
  SkeletonChain c = build_ok(rig.desc);
  EXPECT_TRUE(c.has_non_uniform_scale());
  EXPECT_EQ(c.non_uniform_scale_bone(), 1);
  EXPECT_NE(std::string(c.scale_warning().c_str()).find("bone 'forearm' has a non-uniform scale (1, 2, 1)"),
            std::string::npos)
      << c.scale_warning().c_str();

  // Uniform (even negative) scales are exact, and the tip bone's own scale moves nothing.
  Rig uniform = sideways_arm();
  uniform.desc.bones[0].pose.scale = glm::dvec3(1.5);
  uniform.desc.bones[1].pose.scale = glm::dvec3(-0.5);
  uniform.desc.bones[2].pose.scale = glm::dvec3(1, 3, 1);
  SkeletonChain u = build_ok(uniform.desc);
  EXPECT_FALSE(u.has_non_uniform_scale());
  EXPECT_TRUE(u.scale_warning().empty());
  // ...unless the tip bone is a joint (its scale stretches the extension).
  uniform.desc.extend_tip_bone = true;
  uniform.desc.tip_extension_length = 0.1;
  SkeletonChain e = build_ok(uniform.desc);
  EXPECT_EQ(e.non_uniform_scale_bone(), 2);

  // A scale animated per frame turns the flag on and off.
  std::vector<BonePose> poses = poses_of(uniform);
  poses[0].scale = glm::dvec3(1.0, 1.2, 1.0);
  EXPECT_TRUE(u.update_pose(poses).shape_changed);
  EXPECT_EQ(u.non_uniform_scale_bone(), 0);
  poses[0].scale = glm::dvec3(1.0);
  EXPECT_TRUE(u.update_pose(poses).shape_changed);
  EXPECT_FALSE(u.has_non_uniform_scale());
}

TEST(SkeletonChainScale, AffineFkMatchesTheOracleWhereTheRigidChainCannot) {
  Rig rig = sideways_arm();
  rig.desc.bones[0].pose.scale = glm::dvec3(1.0, 1.6, 0.7);
  rig.desc.bones[1].pose.scale = glm::dvec3(0.9, 1.0, 1.4);
  SkeletonChain c = build_ok(rig.desc);
  ASSERT_TRUE(c.has_non_uniform_scale());
  std::mt19937 rng(17);
  double worst_rigid = 0.0;
  for (int t = 0; t < 100; ++t) {
    const std::vector<glm::dquat> q = random_joint_rotations(rig, 2, rng);
    const std::vector<glm::dmat4> g = oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q));
    c.forward_kinematics_affine(q);
    for (int i = 0; i < 3; ++i) {
      for (int col = 0; col < 4; ++col)
        expect_near(glm::dvec3(c.bone_in_base(i)[col]), glm::dvec3(g[size_t(i)][col]), 1e-12, "bone column");
    }
    expect_near(c.effector_in_base(), origin(g[2]), 1e-12, "effector");
    worst_rigid = std::max(worst_rigid, glm::length(core_fk(c, q).ws.tip - origin(g[2])));
  }
  // What the warning is about: the rigid model misses the real hand by centimetres.
  EXPECT_GT(worst_rigid, 0.03);
}

// The case: every solver said "converged" with the tip far off. measure_pose() reports the
// error on the real bones.
TEST(SkeletonChainScale, MeasurePoseReportsTheTrueErrorOfASolve) {
  Rig rig = sideways_arm();
  rig.desc.bones[0].pose.scale = glm::dvec3(1.0, 1.6, 0.7);
  SkeletonChain c = build_ok(rig.desc);
  const glm::dvec3 target(0.35, 0.4, 0.25);
  const std::vector<Goal> goals{Goal::position(target)};
  Workspace ws(c.chain(), 1);
  Eigen::VectorXd params = Eigen::VectorXd::Zero(c.chain().dof_count());
  SolverOptions options;
  options.max_iterations = 200;
  const SolveResult r = solve(SolverKind::kDLS, c.chain(), goals, options, ws, params);
  ASSERT_EQ(r.reason, TerminationReason::kConverged) << to_string(r.reason);
  EXPECT_LT(r.final_error, options.position_tolerance);

  std::vector<glm::dquat> q(2);
  ASSERT_TRUE(c.rotations_from_params(params.data(), q));
  const GoalErrors real = c.measure_pose(q, goals);
  const glm::dvec3 hand = origin(oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), q))[2]);
  EXPECT_NEAR(real.combined, glm::length(hand - target), 1e-12);
  EXPECT_NEAR(real.max_position, glm::length(hand - target), 1e-12);
  EXPECT_GT(real.combined, 100.0 * options.position_tolerance);  // not converged on the skeleton
}

// ---------------------------------------------------------------- influence blend

TEST(SkeletonChainBlend, SlerpLikeSkeleton3D) {
  std::mt19937 rng(19);
  std::vector<glm::dquat> from, to;
  for (int i = 0; i < 40; ++i) {
    from.push_back(random_rotation(rng, 3.0));
    glm::dquat t = random_rotation(rng, 3.0);
    to.push_back(i % 2 ? -t : t);  // either sign: Godot takes the shorter way
  }
  for (double influence : {0.0, 0.25, 0.5, 0.9}) {
    std::vector<glm::dquat> out(from.size());
    blend_rotations(from, to, influence, out);
    for (size_t i = 0; i < from.size(); ++i) {
      const double full = angle_between(from[i], to[i]);
      EXPECT_NEAR(glm::length(out[i]), 1.0, 1e-15);
      // On the shortest arc from `from` to `to`, at `influence` of the way.
      EXPECT_NEAR(angle_between(from[i], out[i]), influence * full, 1e-9);
      EXPECT_NEAR(angle_between(out[i], to[i]), (1.0 - influence) * full, 1e-9);
    }
  }
  // influence >= 1 is not blended at all; unchanged bones are skipped.
  std::vector<glm::dquat> out(from.size());
  blend_rotations(from, to, 1.0, out);
  for (size_t i = 0; i < from.size(); ++i) EXPECT_EQ(out[i], to[i]);
  blend_rotations(from, from, 0.3, out);
  for (size_t i = 0; i < from.size(); ++i) EXPECT_EQ(out[i], from[i]);
  // Nearly parallel: Godot's linear branch, still normalized.
  const glm::dquat a = axis_angle(0.3, {0, 1, 0}), b = axis_angle(0.3 + 1e-4, {0, 1, 0});
  EXPECT_NEAR(angle_between(godot_slerp(a, b, 0.5), axis_angle(0.3 + 0.5e-4, {0, 1, 0})), 0.0, 1e-9);
}

TEST(SkeletonChainBlend, ErrorOfTheBlendedPoseMatchesTheOracle) {
  const Rig rig = sideways_arm();
  SkeletonChain c = build_ok(rig.desc);
  const glm::dvec3 target(0.3, 0.5, 0.2);
  const std::vector<Goal> goals{Goal::position(target)};
  Workspace ws(c.chain(), 1);
  Eigen::VectorXd params = Eigen::VectorXd::Zero(c.chain().dof_count());
  SolverOptions options;
  options.max_iterations = 200;
  const SolveResult r = solve(SolverKind::kDLS, c.chain(), goals, options, ws, params);
  ASSERT_EQ(r.reason, TerminationReason::kConverged);
  std::vector<glm::dquat> solved(2), blended(2);
  ASSERT_TRUE(c.rotations_from_params(params.data(), solved));
  const std::vector<glm::dquat> animated{rig.rests[0], rig.rests[1]};  // what the animation left

  for (double influence : {0.0, 0.5, 0.75, 1.0}) {
    const GoalErrors e = c.measure_blended_pose(animated, solved, influence, goals, blended);
    // The oracle: Skeleton3D slerps each bone, then composes the bones.
    std::vector<glm::dquat> expected(2);
    for (int i = 0; i < 2; ++i)
      expected[size_t(i)] = influence < 1.0 ? glm::slerp(animated[size_t(i)], solved[size_t(i)], influence)
                                            : solved[size_t(i)];
    for (int i = 0; i < 2; ++i) EXPECT_LT(angle_between(blended[size_t(i)], expected[size_t(i)]), 1e-9);
    const glm::dvec3 hand = origin(oracle_globals(glm::dmat4(1.0), with_rotations(poses_of(rig), expected))[2]);
    EXPECT_NEAR(e.combined, glm::length(hand - target), 1e-9) << "influence " << influence;
    if (influence < 1.0)
      EXPECT_GT(e.combined, 0.01) << "a partial blend leaves the hand off the target";
    else
      EXPECT_LT(e.combined, options.position_tolerance);
  }
}

// ---------------------------------------------------------------- goals in base space

// A skeleton placed in the world (rotated, moved, uniformly scaled), the arm's base is the spine bone.
struct Scene {
  glm::dmat4 skeleton_global = glm::translate(glm::dmat4(1.0), glm::dvec3(3, 0.5, -2)) *
                               glm::mat4_cast(axis_angle(0.8, {0.2, 1, 0.1})) * glm::scale(glm::dmat4(1.0), glm::dvec3(1.7));
  glm::dmat4 spine_in_skeleton = trs(glm::dvec3(0, 1.2, 0), axis_angle(0.2, {1, 0, 0}), glm::dvec3(1.0));
};

TEST(BaseFrame, PointsAndRotationsInBaseSpace) {
  const Scene s;
  BaseFrame base;
  ASSERT_TRUE(BaseFrame::make(s.skeleton_global, s.spine_in_skeleton, base));
  const glm::dmat4 base_global = s.skeleton_global * s.spine_in_skeleton;
  const glm::dmat4 target = trs(glm::dvec3(2.5, 2.0, -1.0), axis_angle(1.1, {1, 2, 3}), glm::dvec3(0.5));
  expect_near(base.point_in_base(origin(target)), glm::dvec3(glm::inverse(base_global) * target[3]), 1e-12, "point");
  // base rotation * rotation in base = the target's world rotation.
  EXPECT_LT(angle_between(rotation_part(base_global) * base.rotation_in_base(target), axis_angle(1.1, {1, 2, 3})), 1e-12);
  // A collapsed or non-finite base is refused, the frame kept.
  const BaseFrame kept = base;
  EXPECT_FALSE(BaseFrame::make(glm::scale(glm::dmat4(1.0), glm::dvec3(1, 0, 1)), glm::dmat4(1.0), base));
  glm::dmat4 nan_pose(1.0);
  nan_pose[3][0] = kNaN;
  EXPECT_FALSE(BaseFrame::make(s.skeleton_global, nan_pose, base));
  EXPECT_EQ(base.global_to_base, kept.global_to_base);
}

// use_target_rotation: the hand BONE (not the forearm's frame) takes the target's world rotation.
TEST(SkeletonChainGoals, UseTargetRotationGivesTheTipBoneTheTargetsRotation) {
  const Scene s;
  const Rig rig = sideways_arm();
  SkeletonChain c = build_ok(rig.desc);
  BaseFrame base;
  ASSERT_TRUE(BaseFrame::make(s.skeleton_global, s.spine_in_skeleton, base));
  const glm::dmat4 base_global = s.skeleton_global * s.spine_in_skeleton;
  std::mt19937 rng(23);
  for (int t = 0; t < 10; ++t) {
    // A reachable target: where some pose puts the hand, in the world.
    const std::vector<glm::dquat> pose = random_joint_rotations(rig, 2, rng, 1.5);
    const glm::dmat4 hand_world = oracle_globals(base_global, with_rotations(poses_of(rig), pose))[2];
    const glm::dmat4 target_world =
        glm::translate(glm::dmat4(1.0), origin(hand_world)) * glm::mat4_cast(rotation_part(hand_world));

    const std::vector<Goal> goals{
        Goal::position(base.point_in_base(origin(target_world))),
        Goal::orientation(c.effector_orientation_for_tip_bone(base.rotation_in_base(target_world)))};
    Workspace ws(c.chain(), 2);
    Eigen::VectorXd params = Eigen::VectorXd::Zero(c.chain().dof_count());
    SolverOptions options;
    options.max_iterations = 300;
    options.warm_start = false;
    const SolveResult r = solve(SolverKind::kDLS, c.chain(), goals, options, ws, params);
    ASSERT_EQ(r.reason, TerminationReason::kConverged) << to_string(r.reason) << " target " << t;
    std::vector<glm::dquat> q(2);
    ASSERT_TRUE(c.rotations_from_params(params.data(), q));
    const glm::dmat4 hand = oracle_globals(base_global, with_rotations(poses_of(rig), q))[2];
    EXPECT_LT(glm::length(origin(hand) - origin(target_world)), 1e-4);
    EXPECT_LT(angle_between(rotation_part(hand), rotation_part(target_world)), 1e-3);
    EXPECT_LT(c.measure_pose(q, goals).max_orientation, 1e-3);
  }
}

// Aim: an axis of the tip BONE points along the wanted direction.
TEST(SkeletonChainGoals, AimPointsTheTipBonesAxis) {
  const Scene s;
  const Rig rig = sideways_arm();
  SkeletonChain c = build_ok(rig.desc);
  BaseFrame base;
  ASSERT_TRUE(BaseFrame::make(s.skeleton_global, s.spine_in_skeleton, base));
  const glm::dmat4 base_global = s.skeleton_global * s.spine_in_skeleton;
  const glm::dvec3 aim_axis_in_hand(0, 0, 1);  // the palm's normal, say
  const glm::dvec3 target_world(5.0, 3.0, -1.0);

  c.forward_kinematics_affine(rig.rests);  // the current pose: rest
  glm::dvec3 direction_in_base;
  ASSERT_TRUE(SkeletonChain::aim_direction_in_base(base.point_in_base(target_world), c.effector_in_base(),
                                                   direction_in_base));
  const std::vector<Goal> goals{Goal::aim(c.aim_axis_in_effector(aim_axis_in_hand), direction_in_base)};
  Workspace ws(c.chain(), 1);
  Eigen::VectorXd params = Eigen::VectorXd::Zero(c.chain().dof_count());
  SolverOptions options;
  options.max_iterations = 200;
  const SolveResult r = solve(SolverKind::kDLS, c.chain(), goals, options, ws, params);
  ASSERT_EQ(r.reason, TerminationReason::kConverged) << to_string(r.reason);
  std::vector<glm::dquat> q(2);
  ASSERT_TRUE(c.rotations_from_params(params.data(), q));
  const glm::dmat4 hand = oracle_globals(base_global, with_rotations(poses_of(rig), q))[2];
  const glm::dvec3 axis_world = glm::normalize(glm::dmat3(hand) * aim_axis_in_hand);
  const glm::dvec3 wanted_world = glm::normalize(glm::dmat3(base_global) * direction_in_base);
  EXPECT_LT(std::acos(std::min(1.0, glm::dot(axis_world, wanted_world))), 1e-3);

  glm::dvec3 unused;
  EXPECT_FALSE(SkeletonChain::aim_direction_in_base(glm::dvec3(1, 2, 3), glm::dvec3(1, 2, 3), unused));
  EXPECT_FALSE(SkeletonChain::aim_direction_in_base(glm::dvec3(kNaN, 0, 0), glm::dvec3(0.0), unused));
}

TEST(SkeletonChainGoals, EffectorsOfBonesAndThePole) {
  const Scene s;
  Rig rig = tpose_leg();
  const SkeletonChain c = build_ok(rig.desc);
  EXPECT_EQ(c.effector_of_bone(0), -1);  // the hip's origin never moves
  EXPECT_EQ(c.effector_of_bone(1), 1);   // the knee
  EXPECT_EQ(c.effector_of_bone(2), 2);   // the ankle = the tip
  EXPECT_EQ(c.effector_of_bone(3), -1);
  rig.desc.extend_tip_bone = true;
  rig.desc.tip_extension_length = 0.2;
  const SkeletonChain e = build_ok(rig.desc);
  EXPECT_EQ(e.effector_of_bone(2), 2);  // the ankle, now a joint's origin; effector 3 is the toe
  EXPECT_EQ(e.joint_count(), 3);

  // The pole (a knee target in front of the leg) in base space, as the solvers take it.
  BaseFrame base;
  ASSERT_TRUE(BaseFrame::make(s.skeleton_global, glm::dmat4(1.0), base));
  const glm::dvec3 pole_world(3.2, 1.0, -0.5);
  expect_near(glm::dvec3(s.skeleton_global * glm::dvec4(base.point_in_base(pole_world), 1.0)), pole_world, 1e-12,
              "pole round trip");
}

}  // namespace
}  // namespace ikchain::godot
