// The body benchmark's skeleton mapping (bench/body_model.cpp): recorded BVH frames -> params,
// whose forward kinematics must reproduce the recording; joint classes; the limit check against
// the core's own within_limits; the recorded motion inside the joint ranges.
#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "body_model.hpp"
#include "bvh.hpp"
#include "ikchain/kinematics.hpp"

namespace {

const char* const kClipsDir = "/usr/share/assimp/models/BVH/";
constexpr double kCmuMetresPerUnit = (1.0 / 0.45) * 2.54 / 100.0;

bool load(const char* file, double scale, bvh::Clip& clip, body::Model& m) {
  const std::string path = std::string(kClipsDir) + file;
  if (!std::ifstream(path)) return false;
  std::string error;
  EXPECT_TRUE(bvh::load(path, clip, error)) << error;
  EXPECT_TRUE(body::make_model(clip, file, scale, m, error)) << error;
  return true;
}

TEST(BodyModel, RecordedParamsReproduceTheRecordingsForwardKinematics) {
  const struct {
    const char* file;
    double scale;
  } clips[] = {{"01_01.bvh", kCmuMetresPerUnit}, {"01_03.bvh", kCmuMetresPerUnit}, {"Boxing_Toes.bvh", 0.01}};
  for (const auto& spec : clips) {
    bvh::Clip clip;
    body::Model m;
    if (!load(spec.file, spec.scale, clip, m)) GTEST_SKIP() << "assimp-testmodels not installed (scripts/setup)";
    std::vector<double> params(m.dof_count());
    std::vector<glm::dvec3> origins;
    std::vector<glm::dquat> orientations;
    body::Pose pose;
    for (int f = 0; f < clip.frame_count; f += 97) {
      body::recorded_params(clip, m, f, params.data());
      body::forward_kinematics(m, params.data(), pose);
      bvh::forward_kinematics(clip, clip.frame(f), origins, orientations);
      for (int j = 0; j < m.joint_count; ++j) {
        EXPECT_LT(glm::length(pose.origins[j] - origins[j] * spec.scale), 1e-9) << spec.file << " frame " << f << " joint " << j;
        EXPECT_GT(std::abs(glm::dot(pose.orientations[j], orientations[j])), 1.0 - 1e-12);
      }
    }
  }
}

TEST(BodyModel, JointClassesByPlaceNotName) {
  bvh::Clip cmu, boxing;
  body::Model a, b;
  if (!load("01_01.bvh", kCmuMetresPerUnit, cmu, a) || !load("Boxing_Toes.bvh", 0.01, boxing, b))
    GTEST_SKIP() << "assimp-testmodels not installed (scripts/setup)";
  using body::JointClass;
  auto cls = [](const bvh::Clip& c, const body::Model& m, const char* name) { return m.joint_class[c.find(name)]; };
  // CMU's LeftShoulder is the collar, Boxing_Toes' the glenohumeral joint.
  EXPECT_EQ(cls(cmu, a, "LeftShoulder"), JointClass::kCollar);
  EXPECT_EQ(cls(cmu, a, "LeftArm"), JointClass::kShoulder);
  EXPECT_EQ(cls(cmu, a, "LeftForeArm"), JointClass::kElbow);
  EXPECT_EQ(cls(cmu, a, "LeftHand"), JointClass::kWrist);
  EXPECT_EQ(cls(cmu, a, "LThumb"), JointClass::kFinger);
  EXPECT_EQ(cls(cmu, a, "LHipJoint"), JointClass::kPelvis);
  EXPECT_EQ(cls(cmu, a, "LeftUpLeg"), JointClass::kHip);
  EXPECT_EQ(cls(cmu, a, "LeftLeg"), JointClass::kKnee);
  EXPECT_EQ(cls(cmu, a, "LeftFoot"), JointClass::kAnkle);
  EXPECT_EQ(cls(cmu, a, "LeftToeBase"), JointClass::kToe);
  EXPECT_EQ(cls(cmu, a, "Spine1"), JointClass::kSpine);
  EXPECT_EQ(cls(cmu, a, "Neck1"), JointClass::kNeck);
  EXPECT_EQ(cls(boxing, b, "LeftCollar"), JointClass::kCollar);
  EXPECT_EQ(cls(boxing, b, "LeftShoulder"), JointClass::kShoulder);
  EXPECT_EQ(cls(boxing, b, "LeftKnee"), JointClass::kKnee);
  EXPECT_EQ(cls(boxing, b, "Chest"), JointClass::kSpine);
  // The stack's chains: spine -> head, arms from the collar, legs from below the hips.
  ASSERT_EQ(a.chains.size(), 5u);
  EXPECT_EQ(a.chains[1].joints.front(), cmu.find("LeftShoulder"));
  EXPECT_EQ(a.chains[1].joints.back(), cmu.find("LeftHand"));
  EXPECT_EQ(a.chains[1].base_joint, cmu.find("Spine1"));
  EXPECT_EQ(a.chains[3].joints.front(), cmu.find("LHipJoint"));
  EXPECT_EQ(b.chains[0].joints.back(), boxing.find("Head"));
}

TEST(BodyModel, LimitCheckAgreesWithTheCoresWithinLimits) {
  ikchain::JointLimits l;
  l.has_cone_limit = true;
  l.cone_angle = 1.2;
  l.has_twist_limit = true;
  l.twist_min = -0.7;
  l.twist_max = 0.4;
  l.twist_axis = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
  body::Model m;
  m.joint_count = 2;
  m.parent = {-1, 0};
  m.offset_m = {glm::dvec3(0.0), glm::dvec3(0, 1, 0)};
  m.joint_class = {body::JointClass::kRoot, body::JointClass::kOther};
  m.limits = {ikchain::JointLimits{}, l};
  ikchain::ChainBuilder b;
  ikchain::JointDesc d;
  d.limits = l;
  d.offset_translation = glm::dvec3(0, 1, 0);
  b.add_joint(d);
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  ikchain::Chain chain;
  const ikchain::Message built = b.build(chain).message;
  ASSERT_TRUE(built.empty()) << built.c_str();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  int inside = 0;
  for (int k = 0; k < 2000; ++k) {
    std::vector<double> params(m.dof_count(), 0.0);
    for (int d3 = 0; d3 < 3; ++d3) params[m.dof_offset(1) + d3] = u(rng);
    const bool within = ikchain::within_limits(chain, params.data() + m.dof_offset(1), 1e-6);
    EXPECT_EQ(body::count_limit_violations(m, params.data(), 1e-6) == 0, within) << k;
    inside += within;
  }
  EXPECT_GT(inside, 100);  // both sides sampled
  EXPECT_LT(inside, 1900);
}

TEST(BodyModel, RecordedMotionLiesInsideTheJointRanges) {
  const struct {
    const char* file;
    double scale;
  } clips[] = {{"01_01.bvh", kCmuMetresPerUnit}, {"01_03.bvh", kCmuMetresPerUnit}, {"Boxing_Toes.bvh", 0.01}};
  for (const auto& spec : clips) {
    bvh::Clip clip;
    body::Model m;
    if (!load(spec.file, spec.scale, clip, m)) GTEST_SKIP() << "assimp-testmodels not installed (scripts/setup)";
    std::vector<double> params(m.dof_count());
    int outside = 0;
    for (int f = 1; f < clip.frame_count; ++f) {  // frame 0: the converter's reference pose
      body::recorded_params(clip, m, f, params.data());
      outside += body::count_limit_violations(m, params.data(), 1e-6) > 0;
    }
    EXPECT_EQ(outside, 0) << spec.file;
    // Zero params (the rest pose, every solve's cold start) are inside too.
    std::fill(params.begin(), params.end(), 0.0);
    EXPECT_EQ(body::count_limit_violations(m, params.data(), 0.0), 0);
  }
}

TEST(BodyModel, StatureInMetres) {
  bvh::Clip cmu, boxing;
  body::Model a, b;
  if (!load("01_01.bvh", kCmuMetresPerUnit, cmu, a) || !load("Boxing_Toes.bvh", 0.01, boxing, b))
    GTEST_SKIP() << "assimp-testmodels not installed (scripts/setup)";
  // Hips to the top of the head plus hips to the ankle, upright rest pose: a human size.
  auto height = [](const body::Model& m) {
    std::vector<double> zero(m.dof_count(), 0.0);
    body::Pose p;
    body::forward_kinematics(m, zero.data(), p);
    return body::effector_position(m, p, body::kHead).y - body::effector_position(m, p, body::kLeftFoot).y;
  };
  EXPECT_NEAR(height(a), 1.35, 0.1);
  EXPECT_NEAR(height(b), 1.6, 0.1);
}

// The rig's neutral pose (body_model.hpp): every joint at rest but the upper arms, which hang
// kNeutralArmDeg out from straight down on their own side; inside every joint range.
TEST(BodyModel, TheNeutralPoseHangsTheArmsInsideTheRanges) {
  const struct {
    const char* file;
    double scale;
  } clips[] = {{"01_01.bvh", kCmuMetresPerUnit}, {"Boxing_Toes.bvh", 0.01}};
  for (const auto& spec : clips) {
    bvh::Clip clip;
    body::Model m;
    if (!load(spec.file, spec.scale, clip, m)) GTEST_SKIP() << "assimp-testmodels not installed (scripts/setup)";
    std::vector<double> params(m.dof_count(), 1.0);
    body::neutral_params(m, params.data());
    EXPECT_EQ(body::count_limit_violations(m, params.data(), 0.0), 0) << spec.file;
    body::Pose rest, neutral;
    std::vector<double> zero(m.dof_count(), 0.0);
    body::forward_kinematics(m, zero.data(), rest);
    body::forward_kinematics(m, params.data(), neutral);
    int arms = 0;
    for (int j = 0; j < m.joint_count; ++j) {
      if (m.joint_class[j] != body::JointClass::kShoulder) {
        for (int d = 0; d < 3; ++d) EXPECT_EQ(params[m.dof_offset(j) + d], 0.0) << spec.file << " " << m.joint_names[j];
        continue;
      }
      for (int c = 0; c < m.joint_count; ++c) {
        if (m.parent[c] != j || m.joint_class[c] != body::JointClass::kElbow) continue;
        ++arms;
        const glm::dvec3 upper_arm = glm::normalize(neutral.origins[c] - neutral.origins[j]);
        const glm::dvec3 rest_arm = rest.origins[c] - rest.origins[j];
        EXPECT_NEAR(glm::degrees(std::acos(-upper_arm.y)), body::kNeutralArmDeg, 1e-9) << spec.file << " " << m.joint_names[j];
        EXPECT_GT(upper_arm.x * rest_arm.x, 0.0) << spec.file << " " << m.joint_names[j] << ": out on its own side";
        EXPECT_NEAR(upper_arm.z, 0.0, 1e-9) << spec.file << " " << m.joint_names[j];
      }
    }
    EXPECT_EQ(arms, 2) << spec.file;
  }
}

}  // namespace
