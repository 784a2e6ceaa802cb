// The body bench's replay (bench/body_bench.cpp) in small, for the tree solver tests: the first
// frames of a CMU clip, every frame's six 6-D goals solved by a tree solver as body_bench solves
// them (bench/body_tree.cpp, its options without the time cap), warm (each frame from the previous result) or cold (each from the
// rest pose with the root at the recorded hips), and the bench's success: every effector within
// 1 mm and 1 degree of the recording.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "body_model.hpp"
#include "body_solvers.hpp"
#include "bvh.hpp"
#include "ikchain/options.hpp"

namespace ikchain {
namespace test {

constexpr const char* kBoxingClip = "/usr/share/assimp/models/BVH/Boxing_Toes.bvh";  // in centimetres
// CMU subject 01's clips: ASF lengths in inches at the header's scale 0.45 (docs/benchmarks.md, "Units").
constexpr const char* kLadderClip = "/usr/share/assimp/models/BVH/01_03.bvh";
constexpr double kCmuMetresPerUnit = (1.0 / 0.45) * 2.54 / 100.0;

struct Replay {
  bool loaded = false;
  int successes = 0;
  double worst_mm = 0.0, worst_deg = 0.0;
  double mpjpe_mm = 0.0;        // body_bench's: every joint's distance to the recording, mean over frames
  std::vector<int> iterations;  // per frame
};

// Frames 1..frames of `path` (metres_per_unit: the clip's unit) solved by the bench's tree solver
// `solver_id` ("fabrik", "ccd", ...). `loaded` false when the clip is missing (assimp-testmodels).
inline Replay replay_clip(const char* path, double metres_per_unit, const std::string& solver_id, bool warm,
                          int frames) {
  Replay out;
  if (!std::ifstream(path)) return out;
  bvh::Clip clip;
  body::Model m;
  std::string error;
  if (!bvh::load(path, clip, error) || !body::make_model(clip, "clip", metres_per_unit, m, error)) {
    ADD_FAILURE() << error;
    return out;
  }
  out.loaded = true;
  std::string note;
  SolverOptions options;  // body_bench's (the defaults), without the time cap: the verdict
  options.time_cap_usec = 0.0;  // must not depend on the machine's load
  std::vector<std::unique_ptr<body::BodySolver>> solvers = body::make_tree_solvers(m, options, note);
  body::BodySolver* solver = nullptr;
  for (auto& s : solvers)
    if (s->id() == solver_id) solver = s.get();
  if (!solver) {
    ADD_FAILURE() << "no tree solver " << solver_id << ": " << note;
    return out;
  }
  std::vector<double> params(m.dof_count(), 0.0), recorded(m.dof_count());
  body::Pose pose, recorded_pose;
  for (int f = 1; f <= frames && f < clip.frame_count; ++f) {
    body::recorded_params(clip, m, f, recorded.data());
    body::forward_kinematics(m, recorded.data(), recorded_pose);
    const body::Targets t = body::targets_at(m, recorded_pose);
    if (!warm || f == 1) {
      std::fill(params.begin(), params.end(), 0.0);
      std::copy(recorded.begin(), recorded.begin() + 6, params.begin());
    }
    int iterations = 0;
    EXPECT_TRUE(solver->solve(t, params.data(), iterations, note)) << note;
    out.iterations.push_back(iterations);
    body::forward_kinematics(m, params.data(), pose);
    double frame_mm = 0.0, frame_deg = 0.0;
    for (int e = 0; e < body::kEffectorCount; ++e) {
      frame_mm = std::max(frame_mm, 1e3 * glm::length(body::effector_position(m, pose, e) - t.position[e]));
      const double d = std::min(1.0, std::abs(glm::dot(body::effector_orientation(m, pose, e), t.orientation[e])));
      frame_deg = std::max(frame_deg, glm::degrees(2.0 * std::acos(d)));
    }
    out.successes += frame_mm <= 1.0 && frame_deg <= 1.0;
    double joints_mm = 0.0;
    for (int j = 0; j < m.joint_count; ++j) joints_mm += 1e3 * glm::length(pose.origins[j] - recorded_pose.origins[j]);
    out.mpjpe_mm += joints_mm / m.joint_count;
    out.worst_mm = std::max(out.worst_mm, frame_mm);
    out.worst_deg = std::max(out.worst_deg, frame_deg);
  }
  if (!out.iterations.empty()) out.mpjpe_mm /= static_cast<double>(out.iterations.size());
  return out;
}

}  // namespace test
}  // namespace ikchain
