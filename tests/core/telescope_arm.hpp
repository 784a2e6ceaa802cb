// The telescoping arm of the prismatic tests: a ball shoulder, a slide along its bone (+Y,
// 0..0.8 m), a hinge elbow, a ball wrist; 0.5 m bones, the tip 0.3 m beyond the wrist. Without
// the wrist, the tip sits 0.5 m beyond the elbow.
#pragma once
#include <gtest/gtest.h>

#include "ikchain/chain.hpp"

namespace ikchain {
namespace test {

inline Chain telescope_arm(bool with_wrist = true) {
  ChainBuilder b;
  JointDesc shoulder;
  b.add_joint(shoulder);
  JointDesc slide;
  slide.type = JointType::kPrismatic;
  slide.hinge_axis = glm::dvec3(0, 1, 0);
  slide.offset_translation = glm::dvec3(0, 0.5, 0);
  slide.limits.has_slide_limit = true;
  slide.limits.slide_min = 0.0;
  slide.limits.slide_max = 0.8;
  b.add_joint(slide);
  JointDesc elbow;
  elbow.type = JointType::kHinge;
  elbow.hinge_axis = glm::dvec3(1, 0, 0);
  elbow.offset_translation = glm::dvec3(0, 0.5, 0);
  b.add_joint(elbow);
  if (with_wrist) {
    JointDesc wrist;
    wrist.offset_translation = glm::dvec3(0, 0.5, 0);
    b.add_joint(wrist);
  }
  b.set_tip_offset(glm::dvec3(0, with_wrist ? 0.3 : 0.5, 0));
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_TRUE(m.empty()) << m.c_str();
  return c;
}

}  // namespace test
}  // namespace ikchain
