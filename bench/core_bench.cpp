// Solver-core benchmark: speed, success rate and precision of every ikchain solver on the
// benchmark chain (n hinges alternating about z and y, unit links), with Orocos KDL's
// ChainIkSolverPos_LMA on the same chains and targets as a reference row.
//
// Writes three JSON files into the output directory (scripts/bench prints and plots them):
//   core.json        one record per (solver, joints): success rate, median/p90 time, iterations
//   precision.json   the lecture's precision case: a target 2 units beyond full reach
//   convergence.json error after k iterations, k = 1..K, for one fixed target at n = 10
//   limits.json      joint limits on: two synthetic limited arms (6 and 7 hinges) and a ball
//                    arm (cone and twist limits), position-only and full-pose goals made by FK of
//                    random in-limit poses, started at the middle of the limits (the ball arm also
//                    on its limits); success = within tolerance and within limits by our FK;
//                    and the time budget's overrun on a 100-joint chain
// and prints the multi-goal stage (6 position goals on a 7-ball-joint chain, time per solve).
//
// Method (see docs/benchmarks.md): targets are FK tips of seeded random joint vectors (so they are
// reachable), every solve starts from the rest pose (warm_start = false), success is judged by our
// own FK of the returned pose (distance <= 1e-5 * L, L = chain length), and each solve is timed
// with std::chrono::steady_clock around the solve() call (the dispatcher's validation and
// error measurement included: what a caller pays). Medians over many solves, after a warm-up.
//
// Usage: core_bench [--out DIR] [--quick] [--limits-only] [--multi-goal-only]
//   --quick: few trials, for smoke runs; --limits-only: only limits.json; --multi-goal-only: only
//   the multi-goal stage (printed, no JSON): 6 position goals on a 7-ball-joint chain
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/frames.hpp>
#include <kdl/jntarray.hpp>

#include "ball_arm.hpp"
#include "bench_common.hpp"
#include "core/kinematics_internal.hpp"
#include "ikchain/ikchain.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using ikchain::Chain;
using ikchain::SolverKind;
using bench::json_number;
using bench::json_string;
using bench::kdl_reason;
using bench::quantile;
using bench::start_loadavg;
using bench::write_file;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRelTolerance = 1e-5;  // success: distance <= kRelTolerance * L
constexpr int kKdlMaxIterations = 500;  // KDL's own default
constexpr const char* kKdlName = "kdl_lma";

// ------------------------------------------------------------------------------------ chains

// n hinges alternating about z and y, unit links along +Y: a copy of tests/core/test_util.hpp's
// make_hinge_chain (the bench does not depend on the test tree). Planar: every hinge about z.
Chain make_hinge_chain(int n, bool planar = false, double link = 1.0) {
  ikchain::ChainBuilder b;
  for (int i = 0; i < n; ++i) {
    ikchain::JointDesc j;
    j.type = ikchain::JointType::kHinge;
    j.axis = (planar || i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, link, 0);
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, link, 0));
  Chain c;
  const ikchain::Message m = b.build(c).message;
  if (!m.empty()) {
    std::fprintf(stderr, "chain build failed: %s\n", m.c_str());
    std::exit(2);
  }
  return c;
}

// The same chain for KDL: segment i = hinge (RotZ / RotY) followed by a unit link along +Y, so
// segment tip i is joint origin i+1 (and the last one is our tip). Checked by check_kdl_matches().
KDL::Chain make_kdl_chain(int n, bool planar = false, double link = 1.0) {
  KDL::Chain c;
  for (int i = 0; i < n; ++i) {
    const KDL::Joint joint((planar || i % 2 == 0) ? KDL::Joint::RotZ : KDL::Joint::RotY);
    c.addSegment(KDL::Segment(joint, KDL::Frame(KDL::Vector(0.0, link, 0.0))));
  }
  return c;
}

glm::dvec3 tip_of(const Chain& chain, const double* params, ikchain::Workspace& ws) {
  ikchain::forward_kinematics(chain, params, ws);
  return ws.tip;
}

// Reachable targets: FK tips of uniform random joint vectors in [-pi, pi]^n (seeded).
std::vector<glm::dvec3> random_targets(const Chain& chain, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  ikchain::Workspace ws(chain, 1);
  Eigen::VectorXd q(chain.dof_count());
  std::vector<glm::dvec3> out;
  out.reserve(count);
  for (int t = 0; t < count; ++t) {
    for (int i = 0; i < q.size(); ++i) q[i] = u(rng);
    out.push_back(tip_of(chain, q.data(), ws));
  }
  return out;
}

// KDL's FK must equal ours on random poses, or the kdl_lma row would not be the same problem.
void check_kdl_matches(int n, bool planar) {
  const Chain chain = make_hinge_chain(n, planar);
  const KDL::Chain kchain = make_kdl_chain(n, planar);
  KDL::ChainFkSolverPos_recursive fk(kchain);
  ikchain::Workspace ws(chain, 1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  Eigen::VectorXd q(n);
  KDL::JntArray kq(n);
  for (int t = 0; t < 20; ++t) {
    for (int i = 0; i < n; ++i) kq(i) = q[i] = u(rng);
    KDL::Frame f;
    fk.JntToCart(kq, f);
    const glm::dvec3 ours = tip_of(chain, q.data(), ws);
    const double d = glm::length(ours - glm::dvec3(f.p.x(), f.p.y(), f.p.z()));
    if (!(d < 1e-9 * n)) {
      std::fprintf(stderr, "KDL and ikchain FK differ by %g on the %d-joint chain: not the same chain\n", d, n);
      std::exit(3);
    }
  }
}

// ------------------------------------------------------------------------------------ solvers

struct SolverSpec {
  const char* name;
  bool is_kdl;
  SolverKind kind;
  int max_iterations;
};

// Iteration budgets: 100 for the Newton-like methods (pinv, DLS, BFGS, KDL's LMA gets its default
// 500), 500 sweeps for CCD and FABRIK, whose linear convergence needs many more (cheaper) steps.
std::vector<SolverSpec> solver_specs() {
  return {
      {"two_bone", false, SolverKind::kTwoBone, 1},
      {"ccd", false, SolverKind::kCCD, 500},
      {"fabrik", false, SolverKind::kFABRIK, 500},
      {"jacobian_pinv", false, SolverKind::kJacobianPinv, 100},
      {"dls", false, SolverKind::kDLS, 100},
      {"bfgs", false, SolverKind::kBFGS, 100},
      {kKdlName, true, SolverKind::kDLS, kKdlMaxIterations},
  };
}

// One solve: the outcome a caller sees, with the distance measured by our own FK.
struct Outcome {
  double us = 0.0;
  int iterations = 0;
  double distance = 0.0;
  std::string reason;
};

// Runs one solver on one chain; owns the workspace / KDL solver so a solve allocates nothing.
class Runner {
 public:
  Runner(const SolverSpec& spec, int n, bool planar)
      : spec_(spec),
        chain_(make_hinge_chain(n, planar)),
        kchain_(make_kdl_chain(n, planar)),
        ws_(chain_, 1),
        fk_ws_(chain_, 1),
        params_(Eigen::VectorXd::Zero(chain_.dof_count())),
        kq_init_(n),
        kq_out_(n) {
    options_.warm_start = false;
    options_.position_tolerance = kRelTolerance * chain_.total_length();
    options_.max_iterations = spec.max_iterations;
    if (spec.is_kdl) make_kdl(spec.max_iterations);
  }

  const Chain& chain() const { return chain_; }
  double tolerance() const { return options_.position_tolerance; }

  // Budget override (convergence traces) and start pose (precision case: warm start from it).
  void set_max_iterations(int k) {
    options_.max_iterations = k;
    if (spec_.is_kdl) make_kdl(k);
  }
  void set_start(const Eigen::VectorXd& start) {
    start_ = start;
    options_.warm_start = true;
  }

  Outcome solve(const glm::dvec3& target) {
    Outcome out;
    if (spec_.is_kdl) {
      for (int i = 0; i < chain_.dof_count(); ++i) kq_init_(i) = start_.size() ? start_[i] : 0.0;
      const KDL::Frame goal(KDL::Vector(target.x, target.y, target.z));
      const Clock::time_point t0 = Clock::now();
      const int rc = kdl_->CartToJnt(kq_init_, goal, kq_out_);
      const Clock::time_point t1 = Clock::now();
      out.us = std::chrono::duration<double, std::micro>(t1 - t0).count();
      out.iterations = kdl_->lastNrOfIter;
      out.reason = kdl_reason(rc);
      for (int i = 0; i < chain_.dof_count(); ++i) params_[i] = kq_out_(i);
    } else {
      if (start_.size()) params_ = start_;
      const ikchain::Goal goal = ikchain::Goal::position(target);
      const Clock::time_point t0 = Clock::now();
      const ikchain::SolveResult r =
          ikchain::solve(spec_.kind, chain_, ikchain::Span<const ikchain::Goal>(&goal, 1), options_, ws_, params_);
      const Clock::time_point t1 = Clock::now();
      out.us = std::chrono::duration<double, std::micro>(t1 - t0).count();
      out.iterations = r.iterations;
      out.reason = ikchain::to_string(r.reason);
    }
    out.distance = glm::length(tip_of(chain_, params_.data(), fk_ws_) - target);
    if (!std::isfinite(out.distance)) out.distance = INFINITY;
    return out;
  }

 private:
  void make_kdl(int max_iterations) {
    // Position only: weights L = (1,1,1,0,0,0). KDL's stop test is |L .* dx| < eps on the weighted
    // Cartesian error, i.e. the tip distance here, so eps = our success tolerance.
    Eigen::Matrix<double, 6, 1> weights;
    weights << 1, 1, 1, 0, 0, 0;
    kdl_.reset(new KDL::ChainIkSolverPos_LMA(kchain_, weights, options_.position_tolerance, max_iterations));
  }

  SolverSpec spec_;
  Chain chain_;
  KDL::Chain kchain_;  // must outlive kdl_ (the solver keeps a reference)
  ikchain::SolverOptions options_;
  ikchain::Workspace ws_;
  ikchain::Workspace fk_ws_;
  Eigen::VectorXd params_;
  Eigen::VectorXd start_;
  KDL::JntArray kq_init_;
  KDL::JntArray kq_out_;
  std::unique_ptr<KDL::ChainIkSolverPos_LMA> kdl_;
};

// ------------------------------------------------------------------------------------ JSON

std::string meta_json(bool quick) {
  std::string s = bench::meta_json_head(quick);
  s += ", \"chain\": \"n hinges alternating z/y, unit links along +Y, tip 1 beyond the last joint (L = n)\"";
  s += ", \"success\": \"own-FK tip distance <= 1e-5 * L\"";
  s += ", \"start\": \"rest pose (warm_start = false; KDL: q_init = 0)\"";
  s += ", \"max_iterations\": {";
  bool first = true;
  for (const SolverSpec& sp : solver_specs()) {
    s += (first ? "" : ", ") + json_string(sp.name) + ": " + std::to_string(sp.max_iterations);
    first = false;
  }
  s += "}}";
  return s;
}

// ------------------------------------------------------------------------------------ core.json

// Trials per chain length: many for the cheap small chains, fewer for the long ones. A cell also
// stops after kCellSeconds (with at least kMinTrials) so the whole run stays well under 3 minutes
// on a 2-core machine whatever the solvers cost; the record states the trials actually run.
int max_trials(int n, bool quick) {
  const int t = n <= 5 ? 5000 : n <= 10 ? 3000 : n <= 20 ? 2000 : n <= 50 ? 1000 : 500;
  return quick ? std::max(10, t / 100) : t;
}
constexpr double kCellSeconds = 1.5;
constexpr double kWarmupSeconds = 0.2;
constexpr int kMinTrials = 30;

std::string run_cell(const SolverSpec& spec, int n, const std::vector<glm::dvec3>& targets, bool quick) {
  Runner runner(spec, n, false);
  const int trials_wanted = std::min<int>(max_trials(n, quick), targets.size());

  // Warm-up: caches, branch predictors, CPU frequency; results discarded.
  const Clock::time_point warm_start = Clock::now();
  for (int t = 0; t < std::min(trials_wanted, 50); ++t) {
    runner.solve(targets[t]);
    if (std::chrono::duration<double>(Clock::now() - warm_start).count() > kWarmupSeconds) break;
  }

  std::vector<double> us, iterations, distances;
  std::map<std::string, int> reasons;
  double sum_us = 0.0, sum_iterations = 0.0;
  int successes = 0;
  const Clock::time_point cell_start = Clock::now();
  for (int t = 0; t < trials_wanted; ++t) {
    const Outcome o = runner.solve(targets[t]);
    us.push_back(o.us);
    iterations.push_back(o.iterations);
    distances.push_back(o.distance);
    sum_us += o.us;
    sum_iterations += o.iterations;
    if (o.distance <= runner.tolerance()) ++successes;
    ++reasons[o.reason];
    if (t + 1 >= kMinTrials &&
        std::chrono::duration<double>(Clock::now() - cell_start).count() > kCellSeconds)
      break;
  }
  const int trials = static_cast<int>(us.size());
  std::string s = "{";
  s += "\"solver\": " + json_string(spec.name);
  s += ", \"joints\": " + std::to_string(n);
  s += ", \"trials\": " + std::to_string(trials);
  s += ", \"max_iterations\": " + std::to_string(spec.max_iterations);
  s += ", \"success_rate\": " + json_number(static_cast<double>(successes) / trials, "%.4f");
  s += ", \"median_us\": " + json_number(quantile(us, 0.5), "%.4g");
  s += ", \"p90_us\": " + json_number(quantile(us, 0.9), "%.4g");
  s += ", \"median_iterations\": " + json_number(quantile(iterations, 0.5), "%.4g");
  // Mean cost of one iteration: all time over all iterations (fixed per-solve overhead included).
  s += ", \"us_per_iteration\": " + json_number(sum_iterations > 0 ? sum_us / sum_iterations : NAN, "%.4g");
  s += ", \"median_final_error\": " + json_number(quantile(distances, 0.5), "%.3e");
  s += ", \"p90_final_error\": " + json_number(quantile(distances, 0.9), "%.3e");
  s += ", \"tolerance\": " + json_number(runner.tolerance(), "%.3e");
  s += ", \"reasons\": {";
  bool first = true;
  for (const auto& kv : reasons) {
    s += (first ? "" : ", ") + json_string(kv.first) + ": " + std::to_string(kv.second);
    first = false;
  }
  s += "}}";
  std::fprintf(stderr, "  %-14s n=%-3d trials=%-5d success=%6.1f%%  median=%9.2f us  iters=%g\n", spec.name, n,
               trials, 100.0 * successes / trials, quantile(us, 0.5), quantile(iterations, 0.5));
  return s;
}

// The shared building blocks every solver iteration uses, timed alone: one forward_kinematics()
// pass, and FK + compute_dof_axes() + compute_jacobian() for one position goal. A yardstick for
// us_per_iteration (how many FK passes an iteration costs) and for the dispatcher's fixed cost.
std::string run_baseline(int n) {
  const Chain chain = make_hinge_chain(n);
  ikchain::Workspace ws(chain, 1);
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  Eigen::VectorXd q(n);
  for (int i = 0; i < n; ++i) q[i] = u(rng);
  const ikchain::Goal goal = ikchain::Goal::position(glm::dvec3(0.5, 0.5, 0.5));
  const ikchain::Span<const ikchain::Goal> goals(&goal, 1);
  auto time_us = [&](auto&& body) {
    const int reps = std::max(200, 200000 / n);
    for (int r = 0; r < reps / 10; ++r) body();  // warm-up
    std::vector<double> batches;
    for (int b = 0; b < 9; ++b) {  // median of 9 batches, each timing reps/9 calls
      const Clock::time_point t0 = Clock::now();
      for (int r = 0; r < reps / 9; ++r) body();
      batches.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / (reps / 9));
    }
    return quantile(batches, 0.5);
  };
  volatile double sink = 0.0;
  const double fk_us = time_us([&] {
    ikchain::forward_kinematics(chain, q.data(), ws);
    sink = sink + ws.tip.x;
  });
  const double jac_us = time_us([&] {
    ikchain::forward_kinematics(chain, q.data(), ws);
    ikchain::compute_dof_axes(chain, q.data(), ws);
    ikchain::compute_jacobian(chain, goals, ws, ws.jacobian.topRows(3));
    sink = sink + ws.jacobian(0, 0);
  });
  std::string s = "{\"joints\": " + std::to_string(n);
  s += ", \"fk_us\": " + json_number(fk_us, "%.4g");
  s += ", \"fk_jacobian_us\": " + json_number(jac_us, "%.4g") + "}";
  return s;
}

// ------------------------------------------------------------------------------------ precision

// The lecture's precision case: a 10-joint chain, a target 2 units beyond full reach (distance
// L + 2 from the root, in a generic direction of the xy-plane), from a bent start. The best reach
// is the stretched chain pointing at the target: distance 2. Two chains: the planar one (all
// hinges about z; the lecture's figure is planar) and the 3-D benchmark chain, bent out of the
// plane at the start. (The 3-D chain can only stretch straight within the xy-plane: joint 0 turns
// about z and the y-hinges twist about their own straight bones, so a target direction with a z
// component would make the best reach worse than 2; hence an xy-plane direction for both.)
std::string run_precision(const SolverSpec& spec, bool planar) {
  const int n = 10;
  Runner runner(spec, n, planar);
  Eigen::VectorXd bent(n);
  for (int i = 0; i < n; ++i) bent[i] = planar ? 0.35 : (i % 2 == 0 ? 0.35 : -0.25);
  runner.set_start(bent);
  const glm::dvec3 direction(std::cos(0.7), std::sin(0.7), 0.0);
  const double optimal = 2.0;
  const glm::dvec3 target = runner.chain().root_in_base() + direction * (runner.chain().total_length() + optimal);
  const Outcome o = runner.solve(target);
  std::string s = "{";
  s += "\"solver\": " + json_string(spec.name);
  s += ", \"chain\": " + json_string(planar ? "planar10" : "hinge10");
  s += ", \"joints\": 10";
  s += ", \"distance_to_goal\": " + json_number(o.distance, "%.10g");
  s += ", \"optimal\": " + json_number(optimal);
  s += ", \"excess\": " + json_number(o.distance - optimal, "%.3e");
  s += ", \"reason\": " + json_string(o.reason);
  s += ", \"iterations\": " + std::to_string(o.iterations);
  s += ", \"max_iterations\": " + std::to_string(spec.max_iterations);
  s += "}";
  return s;
}

// ------------------------------------------------------------------------------------ convergence

// Error after k iterations for k = 1..K: the solver is run afresh from the rest pose with
// max_iterations = k (simple and honest: no instrumentation inside the solvers). The trace stops
// once a run ends before its budget (the solver stopped on its own: converged or stalled).
std::string run_convergence(const SolverSpec& spec, const glm::dvec3& target, int max_k) {
  const int n = 10;
  Runner runner(spec, n, false);
  std::string errors;
  std::string reason = "budget";
  ikchain::Workspace ws(runner.chain(), 1);
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(n);
  errors = json_number(glm::length(tip_of(runner.chain(), rest.data(), ws) - target), "%.6e");  // k = 0
  for (int k = 1; k <= max_k; ++k) {
    runner.set_max_iterations(k);
    const Outcome o = runner.solve(target);
    errors += ", " + json_number(o.distance, "%.6e");
    if (o.iterations < k) {
      reason = o.reason;
      break;
    }
  }
  std::string s = "{";
  s += "\"solver\": " + json_string(spec.name);
  s += ", \"joints\": 10";
  s += ", \"tolerance\": " + json_number(runner.tolerance(), "%.3e");
  s += ", \"stopped\": " + json_string(reason);
  s += ", \"errors\": [" + errors + "]";  // errors[k] = distance after a budget of k iterations
  s += "}";
  return s;
}

// ------------------------------------------------------------------------------------ limits.json

// Synthetic limited arms, bones along +Y, hinges about the bone (Y, a "twist") and across it (Z)
// alternately. arm7 follows the Franka Panda's joint pattern and limit ranges (rad; joint 4 must
// stay bent, joint 6 mostly positive), arm6 a 6-axis industrial pattern with asymmetric ranges.
struct LimitedArm {
  const char* name;
  std::vector<char> axes;  // 'y' or 'z'
  std::vector<double> links, lower, upper;
};

std::vector<LimitedArm> limited_arms() {
  return {
      {"arm7", {'y', 'z', 'y', 'z', 'y', 'z', 'y'}, {0.333, 0.316, 0.0825, 0.384, 0.088, 0.107, 0.1},
       {-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973},
       {2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973}},
      {"arm6", {'y', 'z', 'z', 'y', 'z', 'y'}, {0.4, 0.45, 0.42, 0.1, 0.1, 0.08},
       {-3.0, -1.2, -2.4, -3.0, -2.0, -3.0}, {3.0, 2.5, 0.6, 3.0, 2.0, 3.0}},
  };
}

Chain build_or_exit(const ikchain::ChainBuilder& b, const char* name) {
  Chain c;
  const ikchain::Message m = b.build(c).message;
  if (!m.empty()) {
    std::fprintf(stderr, "limited arm %s: %s\n", name, m.c_str());
    std::exit(2);
  }
  return c;
}

Chain make_limited_arm(const LimitedArm& arm) {
  ikchain::ChainBuilder b;
  const int n = static_cast<int>(arm.axes.size());
  for (int i = 0; i < n; ++i) {
    ikchain::JointDesc j;
    j.type = ikchain::JointType::kHinge;
    j.axis = arm.axes[i] == 'y' ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, arm.links[i - 1], 0);
    j.limits.has_hinge_limit = true;
    j.limits.hinge_min = arm.lower[i];
    j.limits.hinge_max = arm.upper[i];
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, arm.links[n - 1], 0));
  return build_or_exit(b, arm.name);
}

// The human-like ball-jointed arm ("ball3") and limited_pose(): ball_arm.hpp, shared with the
// core's limits tests.
Chain make_ball_arm() { return build_or_exit(ikchain::bench::ball_arm_builder(), "ball3"); }
using ikchain::bench::limited_pose;

// One arm of the limits stage: the chain, and how the goals (FK of random in-limit poses) and
// every solve's start pose are drawn.
struct LimitsCase {
  std::string name;
  Chain chain;
  std::vector<double> middle;  // the start pose, unless start_on_boundary
  bool start_on_boundary = false;
};

std::vector<LimitsCase> limits_cases() {
  std::vector<LimitsCase> cases;
  for (const LimitedArm& arm : limited_arms()) {
    LimitsCase c{arm.name, make_limited_arm(arm), {}, false};
    for (size_t i = 0; i < arm.lower.size(); ++i) c.middle.push_back(0.5 * (arm.lower[i] + arm.upper[i]));
    cases.push_back(c);
  }
  // The ball arm from the middle of its limits (balls at rest, elbow half bent) and from random
  // poses with every joint on a limit (the start that stalled projection-only steps).
  const Chain ball = make_ball_arm();
  std::vector<double> middle(ball.dof_count(), 0.0);
  middle[3] = 1.3;
  cases.push_back({"ball3", ball, middle, false});
  cases.push_back({"ball3_edge", ball, middle, true});
  return cases;
}

// One (arm, goal kind, solver) cell: `trials` FK-made goals, each solved from the case's start.
// Full pose = tip position + tip orientation, the orientation weighted by L^2 (a radian counts
// like one chain length).
std::string run_limits_cell(const LimitsCase& arm, bool full_pose, const SolverSpec& spec, int restarts,
                            int trials, std::string& table) {
  const Chain& chain = arm.chain;
  const int n = chain.dof_count();
  const double length = chain.total_length();
  ikchain::SolverOptions o;
  o.position_tolerance = kRelTolerance * length;
  o.orientation_tolerance = 1e-4;
  o.max_iterations = spec.max_iterations;
  o.warm_start = true;
  o.max_restarts = restarts;
  ikchain::Workspace ws(chain, 2), fk(chain, 1);
  Eigen::VectorXd truth(n), params(n);
  std::mt19937 rng(77u + (full_pose ? 1000u : 0u) + static_cast<unsigned>(n));
  std::mt19937 start_rng(5u + (full_pose ? 1000u : 0u));
  std::vector<double> us, iterations, restart_counts;
  std::map<std::string, int> reasons;
  int successes = 0;
  for (int t = 0; t < trials; ++t) {
    limited_pose(chain, false, rng, truth.data());
    ikchain::forward_kinematics(chain, truth.data(), fk);
    ikchain::Goal goals[2] = {ikchain::Goal::position(fk.tip),
                              ikchain::Goal::orientation(ikchain::effector_orientation(chain, fk, 0), 0, length * length)};
    if (arm.start_on_boundary)
      limited_pose(chain, true, start_rng, params.data());
    else
      params = Eigen::Map<const Eigen::VectorXd>(arm.middle.data(), n);
    const Clock::time_point t0 = Clock::now();
    const ikchain::SolveResult r =
        ikchain::solve(spec.kind, chain, ikchain::Span<const ikchain::Goal>(goals, full_pose ? 2 : 1), o, ws, params);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    iterations.push_back(r.iterations);
    restart_counts.push_back(r.restarts);
    ++reasons[ikchain::to_string(r.reason)];
    ikchain::forward_kinematics(chain, params.data(), fk);
    const double position_error = glm::length(fk.tip - goals[0].target_position);
    const glm::dquat q = ikchain::effector_orientation(chain, fk, 0);
    const double orientation_error =
        glm::length(ikchain::so3::log(glm::normalize(goals[1].target_orientation * glm::conjugate(q))));
    const bool ok = params.allFinite() && position_error <= o.position_tolerance &&
                    (!full_pose || orientation_error <= o.orientation_tolerance) &&
                    ikchain::within_limits(chain, params.data(), 1e-9);
    successes += ok;
  }
  const double rate = static_cast<double>(successes) / trials;
  const std::string name = std::string(spec.name) + (restarts > 0 ? "+restarts" : "");
  char line[256];
  std::snprintf(line, sizeof(line),
                "  %-10s %-9s %-22s %7.2f %%  median %8.1f us  p99 %9.1f us  median it %5.0f  p99 restarts %3.0f\n",
                arm.name.c_str(), full_pose ? "full_pose" : "position", name.c_str(), 100.0 * rate,
                quantile(us, 0.5), quantile(us, 0.99), quantile(iterations, 0.5), quantile(restart_counts, 0.99));
  table += line;
  std::string s = "{";
  s += "\"arm\": " + json_string(arm.name);
  s += ", \"start\": " + json_string(arm.start_on_boundary ? "on_limits" : "middle");
  s += ", \"goal\": " + json_string(full_pose ? "full_pose" : "position");
  s += ", \"solver\": " + json_string(spec.name);
  s += ", \"max_restarts\": " + std::to_string(restarts);
  s += ", \"trials\": " + std::to_string(trials);
  s += ", \"success_rate\": " + json_number(rate, "%.4f");
  s += ", \"p99_restarts\": " + json_number(quantile(restart_counts, 0.99));
  s += ", \"median_us\": " + json_number(quantile(us, 0.5), "%.4g");
  s += ", \"p90_us\": " + json_number(quantile(us, 0.9), "%.4g");
  s += ", \"p99_us\": " + json_number(quantile(us, 0.99), "%.4g");
  s += ", \"median_iterations\": " + json_number(quantile(iterations, 0.5), "%.4g");
  s += ", \"reasons\": {";
  bool first = true;
  for (const auto& kv : reasons) {
    s += (first ? "" : ", ") + json_string(kv.first) + ": " + std::to_string(kv.second);
    first = false;
  }
  s += "}}";
  return s;
}

// The time budget on a 100-joint chain: solves that cannot finish (tolerance 1e-14 L) under a
// budget; the worst overrun over the budget, as a fraction of it, and the median time per iteration.
std::string run_budget_cell(const SolverSpec& spec, double budget_us, int trials, std::string& table) {
  const Chain chain = make_hinge_chain(100, false, 0.1);
  ikchain::SolverOptions o;
  o.position_tolerance = 1e-14 * chain.total_length();
  o.stall_tolerance = 0.0;
  o.max_iterations = 100000;
  o.warm_start = false;
  o.time_budget_usec = budget_us;
  ikchain::Workspace ws(chain, 1);
  Eigen::VectorXd params(chain.dof_count());
  const std::vector<glm::dvec3> targets = random_targets(chain, trials, 9090u);
  std::vector<double> overrun, per_iteration;
  int exhausted = 0;
  for (const glm::dvec3& target : targets) {
    const ikchain::Goal goal = ikchain::Goal::position(target);
    params.setZero();
    const ikchain::SolveResult r =
        ikchain::solve(spec.kind, chain, ikchain::Span<const ikchain::Goal>(&goal, 1), o, ws, params);
    if (!r.budget_exhausted) continue;
    ++exhausted;
    overrun.push_back((r.elapsed_us - budget_us) / budget_us);
    per_iteration.push_back(r.elapsed_us / std::max(1, r.iterations));
  }
  const double worst = overrun.empty() ? NAN : *std::max_element(overrun.begin(), overrun.end());
  char line[256];
  std::snprintf(line, sizeof(line), "  budget %6.0f us  %-14s exhausted %4d / %4d  median overrun %+6.2f %%  worst %+7.2f %%  (%.1f us/iteration)\n",
                budget_us, spec.name, exhausted, trials, 100.0 * quantile(overrun, 0.5), 100.0 * worst,
                quantile(per_iteration, 0.5));
  table += line;
  std::string s = "{";
  s += "\"solver\": " + json_string(spec.name);
  s += ", \"budget_us\": " + json_number(budget_us);
  s += ", \"trials\": " + std::to_string(trials);
  s += ", \"exhausted\": " + std::to_string(exhausted);
  s += ", \"median_overrun\": " + json_number(quantile(overrun, 0.5), "%.4f");
  s += ", \"worst_overrun\": " + json_number(worst, "%.4f");
  s += ", \"median_us_per_iteration\": " + json_number(quantile(per_iteration, 0.5), "%.4g") + "}";
  return s;
}

// ------------------------------------------------------------------------------------ multi-goal
// Several goals on one short chain: 7 ball joints (unit bones along +Y, a Godot-style bone chain)
// with a position goal on each of effectors 2..7 (the tip), FK of seeded random poses, solved from
// the rest pose. 18 residual rows over 21 DOFs, so the Jacobian solvers decompose the 18 x 18
// J J^T every iteration, and it is rank-deficient (the goals on the inner joints pin fewer
// directions than their rows): the case where the Jacobi eigen-decomposition's old stop test
// never fired (issue 16, item 7). Prints the median and p90 time per solve.
void run_multi_goal(bool quick) {
  constexpr int kJoints = 7, kGoals = 6;
  ikchain::ChainBuilder builder;
  for (int i = 0; i < kJoints; ++i) {
    ikchain::JointDesc j;
    j.type = ikchain::JointType::kBall;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    builder.add_joint(j);
  }
  builder.set_tip_offset(glm::dvec3(0, 1, 0));
  const Chain chain = build_or_exit(builder, "ball7");
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const int trials = quick ? 50 : 1000;
  std::mt19937 rng(1616u);
  ikchain::Workspace fk(chain, 1);
  std::vector<std::vector<ikchain::Goal>> problems;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> q(chain.dof_count());
    for (double& v : q) v = unit(rng);  // rotation vectors within 1.7 rad
    ikchain::forward_kinematics(chain, q.data(), fk);
    std::vector<ikchain::Goal> goals;
    for (int k = kJoints - kGoals + 1; k <= kJoints; ++k)
      goals.push_back(ikchain::Goal::position(k == kJoints ? fk.tip : fk.joint_origins[k], k));
    problems.push_back(goals);
  }
  std::printf("multi-goal: %d ball joints, %d position goals (effectors 2..%d), rest start, max_iterations 100, %d "
              "problems\n", kJoints, kGoals, kJoints, trials);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS}) {
    ikchain::SolverOptions o;
    o.position_tolerance = kRelTolerance * chain.total_length();
    o.warm_start = false;
    ikchain::Workspace ws(chain, kGoals);
    Eigen::VectorXd params(chain.dof_count());
    std::vector<double> us, cpu_us;
    int converged = 0;
    for (int pass = 0; pass < 2; ++pass) {  // the first pass warms up
      us.clear();
      cpu_us.clear();
      converged = 0;
      for (const std::vector<ikchain::Goal>& goals : problems) {
        params.setZero();
        // Thread CPU time beside the wall clock: on a shared machine the wall clock's tail is preemption.
        const double c0 = ikchain::Deadline::thread_cpu_now_us();
        const Clock::time_point t0 = Clock::now();
        const ikchain::SolveResult r = ikchain::solve(kind, chain, ikchain::Span<const ikchain::Goal>(goals), o, ws,
                                                      params);
        us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
        cpu_us.push_back(ikchain::Deadline::thread_cpu_now_us() - c0);
        converged += r.reason == ikchain::TerminationReason::kConverged;
      }
    }
    std::printf("  %-14s median %8.1f us per solve  p90 %8.1f us  CPU: median %8.1f us  p90 %8.1f us  converged %5.1f %%\n",
                ikchain::to_string(kind), quantile(us, 0.5), quantile(us, 0.9), quantile(cpu_us, 0.5),
                quantile(cpu_us, 0.9), 100.0 * converged / trials);
  }
  std::fflush(stdout);
}

constexpr int kBenchRestarts = 20;

bool write_limits_json(const std::string& out_dir, bool quick) {
  std::string records, table = "limits on (success by our FK, within limits):\n";
  const int trials = quick ? 100 : 2000;
  for (const LimitsCase& arm : limits_cases())
    for (bool full_pose : {false, true})
      for (const SolverSpec& spec : solver_specs()) {
        if (spec.is_kdl || spec.kind == SolverKind::kTwoBone) continue;
        records += (records.empty() ? "\n  " : ",\n  ") + run_limits_cell(arm, full_pose, spec, 0, trials, table);
        // Seeded restarts (off by default) for the Newton-like solvers.
        if (spec.kind == SolverKind::kDLS || spec.kind == SolverKind::kJacobianPinv || spec.kind == SolverKind::kBFGS)
          records += ",\n  " + run_limits_cell(arm, full_pose, spec, kBenchRestarts, trials, table);
      }
  std::string budget;
  table += "time budget, 100-joint chain:\n";
  for (const SolverSpec& spec : solver_specs()) {
    if (spec.is_kdl || spec.kind == SolverKind::kTwoBone) continue;
    for (double b : {200.0, 1000.0})
      budget += (budget.empty() ? "\n  " : ",\n  ") + run_budget_cell(spec, b, quick ? 10 : 100, table);
  }
  std::fputs(table.c_str(), stdout);
  return write_file(out_dir + "/limits.json", "{\"meta\": " + meta_json(quick) + ",\n\"records\": [" + records +
                                                  "\n],\n\"budget\": [" + budget + "\n]}\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir = "build/bench";
  bool quick = false, limits_only = false, multi_goal_only = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
    } else if (!std::strcmp(argv[i], "--limits-only")) {
      limits_only = true;
    } else if (!std::strcmp(argv[i], "--multi-goal-only")) {
      multi_goal_only = true;
    } else {
      std::fprintf(stderr, "usage: %s [--out DIR] [--quick] [--limits-only] [--multi-goal-only]\n", argv[0]);
      return 2;
    }
  }
  if (limits_only) return write_limits_json(out_dir, quick) ? 0 : 1;
  if (multi_goal_only) {
    run_multi_goal(quick);
    return 0;
  }
  const Clock::time_point run_start = Clock::now();
  start_loadavg();
  const std::vector<int> joint_counts = {2, 3, 5, 7, 10, 15, 20, 30, 50, 70, 100};
  const std::vector<SolverSpec> specs = solver_specs();
  for (int n : {2, 10, 100}) {
    check_kdl_matches(n, false);
    check_kdl_matches(n, true);
  }

  // core.json
  std::string records;
  for (int n : joint_counts) {
    const Chain chain = make_hinge_chain(n);
    // Same targets for every solver at this n (seed = n), the first k of them in a short cell.
    const std::vector<glm::dvec3> targets = random_targets(chain, max_trials(n, quick), 1000u + n);
    for (const SolverSpec& spec : specs) {
      if (!spec.is_kdl && spec.kind == SolverKind::kTwoBone && n != 2) continue;  // exactly 2 joints
      records += (records.empty() ? "\n  " : ",\n  ") + run_cell(spec, n, targets, quick);
    }
  }
  std::string baseline;
  for (int n : joint_counts) baseline += (baseline.empty() ? "\n  " : ",\n  ") + run_baseline(n);
  if (!write_file(out_dir + "/core.json", "{\"meta\": " + meta_json(quick) + ",\n\"records\": [" + records +
                                              "\n],\n\"baseline\": [" + baseline + "\n]}\n"))
    return 1;

  // precision.json
  std::string precision;
  for (bool planar : {true, false}) {
    for (const SolverSpec& spec : specs) {
      if (!spec.is_kdl && spec.kind == SolverKind::kTwoBone) continue;
      precision += (precision.empty() ? "\n  " : ",\n  ") + run_precision(spec, planar);
    }
  }
  if (!write_file(out_dir + "/precision.json",
                  "{\"meta\": " + meta_json(quick) +
                      ",\n\"setup\": \"10 joints, unit links; target at distance L + 2 = 12 from the root along "
                      "(cos 0.7, sin 0.7, 0); warm start from a bent pose: planar10 all 0.35 rad, hinge10 0.35 (z "
                      "hinges) / -0.25 (y hinges); per-solver max_iterations as in meta\","
                      "\n\"lecture\": {\"jacobian_inverse\": 5.85, \"ccd\": 3.37, \"bfgs\": 2.53, \"optimal\": 2},"
                      "\n\"records\": [" + precision + "\n]}\n"))
    return 1;

  // convergence.json: one fixed reachable target on the 10-joint chain.
  const glm::dvec3 target = random_targets(make_hinge_chain(10), 1, 4242u)[0];
  std::string traces;
  for (const SolverSpec& spec : specs) {
    if (!spec.is_kdl && spec.kind == SolverKind::kTwoBone) continue;
    traces += (traces.empty() ? "\n  " : ",\n  ") + run_convergence(spec, target, std::min(spec.max_iterations, 200));
  }
  char target_json[128];
  std::snprintf(target_json, sizeof(target_json), "[%.9g, %.9g, %.9g]", target.x, target.y, target.z);
  if (!write_file(out_dir + "/convergence.json", "{\"meta\": " + meta_json(quick) + ",\n\"target\": " +
                                                     target_json + ",\n\"traces\": [" + traces + "\n]}\n"))
    return 1;

  if (!write_limits_json(out_dir, quick)) return 1;
  run_multi_goal(quick);

  std::fprintf(stderr, "benchmark finished in %.1f s\n",
               std::chrono::duration<double>(Clock::now() - run_start).count());
  return 0;
}
