// The body benchmark's baseline (bench/chain_stack.cpp): the stack of single-chain DLS solves
// replays the first frames of CMU 01_01 warm, every effector within 1 mm and 1 degree, every joint
// within its range; started on the recorded pose it keeps it.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "body_model.hpp"
#include "body_solvers.hpp"
#include "bvh.hpp"

namespace {

const char* const kClip = "/usr/share/assimp/models/BVH/01_01.bvh";

TEST(ChainStack, ReplaysCmuHopsWarm) {
  if (!std::ifstream(kClip)) GTEST_SKIP() << kClip << " missing: scripts/setup installs assimp-testmodels";
  bvh::Clip clip;
  body::Model m;
  std::string error;
  ASSERT_TRUE(bvh::load(kClip, clip, error)) << error;
  ASSERT_TRUE(body::make_model(clip, "01_01", (1.0 / 0.45) * 2.54 / 100.0, m, error)) << error;
  const ikchain::SolverOptions options;
  auto stack = body::make_chain_stack(m, ikchain::SolverKind::kDLS, options);
  EXPECT_EQ(stack->id(), "chain_stack_dls");
  std::vector<double> params(m.dof_count(), 0.0), recorded(m.dof_count());
  body::Pose pose, goal_pose;
  for (int f = 1; f <= 30; ++f) {
    body::recorded_params(clip, m, f, recorded.data());
    body::forward_kinematics(m, recorded.data(), goal_pose);
    const body::Targets t = body::targets_at(m, goal_pose);
    if (f == 1)
      for (int k = 0; k < 6; ++k) params[k] = recorded[k];
    int iterations = 0;
    std::string note;
    ASSERT_TRUE(stack->solve(t, params.data(), iterations, note)) << note;
    body::forward_kinematics(m, params.data(), pose);
    for (int e = 0; e < body::kEffectorCount; ++e) {
      EXPECT_LT(glm::length(body::effector_position(m, pose, e) - t.position[e]), 1e-3) << "frame " << f << " effector " << e;
      EXPECT_GT(std::abs(glm::dot(body::effector_orientation(m, pose, e), t.orientation[e])),
                std::cos(glm::radians(0.5)))
          << "frame " << f << " effector " << e;
    }
    EXPECT_EQ(body::count_limit_violations(m, params.data()), 0) << "frame " << f;
    if (f == 30) {
      // On the recorded pose every goal is met: the stack's solves stop at once and move nothing.
      std::vector<double> again = recorded;
      ASSERT_TRUE(stack->solve(t, again.data(), iterations, note)) << note;
      EXPECT_EQ(iterations, 0);
      for (int i = 0; i < m.dof_count(); ++i) EXPECT_NEAR(again[i], recorded[i], 1e-12) << i;
    }
  }
}

}  // namespace
