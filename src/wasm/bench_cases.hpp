// The benchmark's cases (bench/core_bench.cpp), engine-free and without KDL, so the web page's live
// charts measure the same problems the native benchmark does: the n-hinge chain alternating z/y
// with unit links, seeded reachable targets, the lecture's precision case and the convergence
// trace (error after a budget of k iterations, run afresh from the rest pose).
//
// Same definitions, same seeds. uniform_real_distribution is not specified bit for bit, but
// emscripten's libc++ and the host's libstdc++ draw the same targets here (checked for n = 10,
// seed 1010: equal to the last digit).
#pragma once
#include <cmath>
#include <random>
#include <vector>

#include "ikchain/ikchain.hpp"

namespace ikchain {
namespace bench_cases {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRelTolerance = 1e-5;      // success: tip distance <= kRelTolerance * L
constexpr unsigned kTargetSeedBase = 1000;  // the targets of an n-joint cell use seed 1000 + n
constexpr unsigned kConvergenceSeed = 4242; // the convergence trace's one target (10 joints)
constexpr int kConvergenceJoints = 10;
constexpr int kConvergenceMaxBudget = 200;
constexpr int kPrecisionJoints = 10;
constexpr double kPrecisionOptimal = 2.0;   // the target is this far beyond full reach
constexpr double kPrecisionDirectionAngle = 0.7;  // rad, in the xy-plane

// The benchmark's iteration budgets: Newton-like methods 100, CCD and FABRIK 500 sweeps, two-bone 1.
inline int max_iterations_for(SolverKind kind) {
  switch (kind) {
    case SolverKind::kTwoBone: return 1;
    case SolverKind::kCCD:
    case SolverKind::kFABRIK: return 500;
    default: return 100;
  }
}

// n hinges alternating about z and y (planar: all about z), links of `link` along +Y, tip one link
// beyond the last joint. Returns the build message (empty on success).
inline Message make_hinge_chain(int n, bool planar, double link, Chain& out) {
  ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = (planar || i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, link, 0);
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, link, 0));
  return b.build(out).message;
}

// Reachable targets: FK tips of uniform random joint vectors in [-pi, pi]^dofs (seeded).
inline std::vector<glm::dvec3> random_targets(const Chain& chain, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  Workspace ws(chain, 1);
  Eigen::VectorXd q(chain.dof_count());
  std::vector<glm::dvec3> out;
  out.reserve(count > 0 ? count : 0);
  for (int t = 0; t < count; ++t) {
    for (int i = 0; i < q.size(); ++i) q[i] = u(rng);
    forward_kinematics(chain, q.data(), ws);
    out.push_back(ws.tip);
  }
  return out;
}

// The lecture's precision case on a 10-joint chain: start bent (planar: every hinge 0.35 rad;
// 3-D: z hinges 0.35, y hinges -0.25), target at distance L + 2 from the root along
// (cos 0.7, sin 0.7, 0). The best reach leaves distance 2 (the lecture: JI 5.85, CCD 3.37, BFGS 2.53).
struct PrecisionCase {
  Eigen::VectorXd start;
  glm::dvec3 target{0.0};
};
inline PrecisionCase precision_case(const Chain& chain, bool planar) {
  PrecisionCase c;
  c.start.resize(chain.dof_count());
  for (int i = 0; i < chain.dof_count(); ++i) c.start[i] = planar ? 0.35 : (i % 2 == 0 ? 0.35 : -0.25);
  const glm::dvec3 direction(std::cos(kPrecisionDirectionAngle), std::sin(kPrecisionDirectionAngle), 0.0);
  c.target = chain.root_in_base() + direction * (chain.total_length() + kPrecisionOptimal);
  return c;
}

}  // namespace bench_cases
}  // namespace ikchain
