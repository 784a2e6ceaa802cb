// The body benchmark's BVH reader (bench/bvh.cpp): a tiny inline file with exact values, then the
// three CMU clips of Debian's assimp-testmodels when installed (scripts/setup installs them).
#include <cmath>
#include <fstream>
#include <string>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "bvh.hpp"

namespace {

// Two joints with different rotation orders, an End Site, two frames.
const char* const kTiny = R"(HIERARCHY
ROOT Hips
{
	OFFSET 0.5 0 0
	CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
	JOINT Leg
	{
		OFFSET 1 -2 0.25
		CHANNELS 3 Yrotation Xrotation Zrotation
		End Site
		{
			OFFSET 0 -3 0
		}
	}
}
MOTION
Frames: 2
Frame Time: 0.0083333
1 2 3 0 0 0 0 0 0
10 20 30 90 90 0 0 0 90
)";

void expect_vec(const glm::dvec3& a, const glm::dvec3& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

TEST(Bvh, TinyHierarchyOffsetsChannelsAndFrames) {
  bvh::Clip c;
  std::string error;
  ASSERT_TRUE(bvh::parse(kTiny, c, error)) << error;
  ASSERT_EQ(c.joints.size(), 2u);
  EXPECT_EQ(c.joints[0].name, "Hips");
  EXPECT_EQ(c.joints[0].parent, -1);
  EXPECT_EQ(c.joints[1].name, "Leg");
  EXPECT_EQ(c.joints[1].parent, 0);
  expect_vec(c.joints[0].offset, {0.5, 0, 0});
  expect_vec(c.joints[1].offset, {1, -2, 0.25});
  using bvh::Channel;
  const std::vector<Channel> root = {Channel::kXposition, Channel::kYposition, Channel::kZposition,
                                     Channel::kZrotation, Channel::kXrotation, Channel::kYrotation};
  const std::vector<Channel> leg = {Channel::kYrotation, Channel::kXrotation, Channel::kZrotation};
  EXPECT_EQ(c.joints[0].channels, root);
  EXPECT_EQ(c.joints[1].channels, leg);
  EXPECT_EQ(c.joints[1].first_channel, 6);
  EXPECT_FALSE(c.joints[0].has_end_site);
  EXPECT_TRUE(c.joints[1].has_end_site);
  expect_vec(c.joints[1].end_site, {0, -3, 0});
  EXPECT_EQ(c.channel_count, 9);
  EXPECT_EQ(c.frame_count, 2);
  EXPECT_DOUBLE_EQ(c.frame_time, 0.0083333);
  EXPECT_EQ(c.frame(1)[0], 10.0);
  EXPECT_EQ(c.frame(1)[8], 90.0);
  EXPECT_EQ(c.find("Leg"), 1);
  EXPECT_EQ(c.find("Arm"), -1);
  EXPECT_EQ(c.ignored_values, 0);
}

TEST(Bvh, RotationChannelsComposeInFileOrder) {
  bvh::Clip c;
  std::string error;
  ASSERT_TRUE(bvh::parse(kTiny, c, error)) << error;
  // Root, frame 1: Zrotation 90 then Xrotation 90 in the file: R = Rz(90) Rx(90). (0,0,1) -> Rx ->
  // (0,-1,0) -> Rz -> (1,0,0); the other order would give (0,-1,0).
  const glm::dquat r = bvh::local_rotation(c, 0, c.frame(1));
  expect_vec(r * glm::dvec3(0, 0, 1), {1, 0, 0});
  // Leg: Yrotation 0, Xrotation 0, Zrotation 90.
  expect_vec(bvh::local_rotation(c, 1, c.frame(1)) * glm::dvec3(1, 0, 0), {0, 1, 0});
  // Frame 0: identity everywhere.
  const glm::dquat id = bvh::local_rotation(c, 0, c.frame(0));
  EXPECT_NEAR(std::abs(id.w), 1.0, 1e-15);
  // Position channels add to the OFFSET.
  expect_vec(bvh::local_translation(c, 0, c.frame(1)), {10.5, 20, 30});
  expect_vec(bvh::local_translation(c, 1, c.frame(1)), {1, -2, 0.25});
}

TEST(Bvh, ForwardKinematicsOfAKnownPose) {
  bvh::Clip c;
  std::string error;
  ASSERT_TRUE(bvh::parse(kTiny, c, error)) << error;
  std::vector<glm::dvec3> o;
  std::vector<glm::dquat> q;
  bvh::forward_kinematics(c, c.frame(0), o, q);
  expect_vec(o[0], {1.5, 2, 3});
  expect_vec(o[1], {2.5, 0, 3.25});
  bvh::forward_kinematics(c, c.frame(1), o, q);
  expect_vec(o[0], {10.5, 20, 30});
  // R_root = Rz(90) Rx(90) maps x -> y, y -> z, z -> x: the Leg's offset (1, -2, 0.25) becomes
  // (0.25, 1, -2).
  expect_vec(o[1], glm::dvec3(10.5, 20, 30) + glm::dvec3(0.25, 1, -2));
  // The End Site: Q_leg = R_root Rz(90); (0,-3,0) -> Rz(90) -> (3,0,0) -> R_root -> (0,3,0).
  expect_vec(o[1] + q[1] * c.joints[1].end_site, glm::dvec3(10.75, 24, 28));
}

TEST(Bvh, ExtraFrameLineIsCountedAndIgnored) {
  bvh::Clip c;
  std::string error;
  ASSERT_TRUE(bvh::parse(std::string(kTiny) + "7 7 7 7 7 7 7 7 7\n", c, error)) << error;
  EXPECT_EQ(c.frame_count, 2);
  EXPECT_EQ(c.ignored_values, 9);
}

TEST(Bvh, MalformedInputsAreRejectedWithTheLine) {
  struct Case {
    std::string text;
    const char* says;
  };
  std::string tiny = kTiny;
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = tiny;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  const Case cases[] = {
      {"", "expected HIERARCHY"},
      {replaced("Yrotation Xrotation Zrotation", "Yrotation Xrotation Wrotation"), "unknown channel 'Wrotation'"},
      {replaced("OFFSET 1 -2 0.25", "OFFSET 1 -2"), "OFFSET needs 3 numbers"},
      {replaced("10 20 30 90 90 0 0 0 90", "10 20 30 90 90 0 0 0"), "frame 1: expected 9 numbers"},
      {replaced("Frames: 2", "Frames: x"), "bad frame count"},
      {replaced("CHANNELS 3 Yrotation", "CHANNELS 3 Xposition"), "position channels only on the root"},
  };
  for (const Case& k : cases) {
    bvh::Clip c;
    std::string error;
    EXPECT_FALSE(bvh::parse(k.text, c, error)) << k.says;
    EXPECT_NE(error.find(k.says), std::string::npos) << error;
    if (!k.text.empty()) EXPECT_EQ(error.rfind("line ", 0), 0u) << error;
  }
}

const char* const kClipsDir = "/usr/share/assimp/models/BVH/";

bool load_clip(const char* file, bvh::Clip& c) {
  const std::string path = std::string(kClipsDir) + file;
  if (!std::ifstream(path)) return false;
  std::string error;
  EXPECT_TRUE(bvh::load(path, c, error)) << error;
  return true;
}

TEST(Bvh, CmuClips) {
  struct Expect {
    const char* file;
    size_t joints;
    int channels, frames;
    double frame_time;
    int ignored;
  };
  const Expect clips[] = {{"01_01.bvh", 31, 96, 2752, 0.0083333, 0},
                          {"01_03.bvh", 31, 96, 4511, 0.0083333, 0},
                          {"Boxing_Toes.bvh", 21, 66, 3069, 0.01, 66}};
  for (const Expect& e : clips) {
    bvh::Clip c;
    if (!load_clip(e.file, c)) GTEST_SKIP() << kClipsDir << e.file << " missing: scripts/setup installs assimp-testmodels";
    EXPECT_EQ(c.joints.size(), e.joints) << e.file;
    EXPECT_EQ(c.channel_count, e.channels) << e.file;
    EXPECT_EQ(c.frame_count, e.frames) << e.file;
    EXPECT_DOUBLE_EQ(c.frame_time, e.frame_time) << e.file;
    EXPECT_EQ(c.ignored_values, e.ignored) << e.file;
    EXPECT_EQ(c.joints[0].name, "Hips");
    EXPECT_EQ(c.joints[0].channels.size(), 6u);
  }
  // CMU's conversion: Z Y X rotations; Boxing_Toes: Z X Y. The reader takes them from the file.
  bvh::Clip cmu, boxing;
  ASSERT_TRUE(load_clip("01_01.bvh", cmu));
  ASSERT_TRUE(load_clip("Boxing_Toes.bvh", boxing));
  using bvh::Channel;
  EXPECT_EQ(cmu.joints[1].channels, (std::vector<Channel>{Channel::kZrotation, Channel::kYrotation, Channel::kXrotation}));
  EXPECT_EQ(boxing.joints[1].channels, (std::vector<Channel>{Channel::kZrotation, Channel::kXrotation, Channel::kYrotation}));
  // A value read back: 01_01's first motion line starts 9.3722 17.8693 -17.3198 -3.2316.
  EXPECT_DOUBLE_EQ(cmu.frame(1)[0], 9.3722);
  EXPECT_DOUBLE_EQ(cmu.frame(1)[3], -3.2316);
  EXPECT_EQ(cmu.joints[cmu.find("LeftLeg")].parent, cmu.find("LeftUpLeg"));
  EXPECT_DOUBLE_EQ(cmu.joints[cmu.find("LeftLeg")].offset.y, -6.72613);
}

}  // namespace
