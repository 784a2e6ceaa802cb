// The telescoping arm of the prismatic tests: a ball shoulder, a slide along its bone (+Y,
// 0..0.8 m), a hinge elbow, a ball wrist; 0.5 m bones, the tip 0.3 m beyond the wrist. Without
// the wrist, the tip sits 0.5 m beyond the elbow.
#pragma once
#include <gtest/gtest.h>

#include "ikchain/chain.hpp"
#include "joint_desc.hpp"  // bench/

namespace ikchain {
namespace test {

inline Chain telescope_arm(bool with_wrist = true) {
  ChainBuilder b;
  JointDesc shoulder;
  b.add_joint(shoulder);
  b.add_joint(bench::slide_joint(glm::dvec3(0, 1, 0), glm::dvec3(0, 0.5, 0), 0.0, 0.8));
  b.add_joint(bench::hinge_joint(glm::dvec3(1, 0, 0), glm::dvec3(0, 0.5, 0)));  // the elbow
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
