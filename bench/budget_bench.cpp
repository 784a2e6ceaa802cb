// The time budget in CPU time (issue 16, item 6): "every solve <= 1.1 x budget + 20 us CPU".
// A measured number, so a benchmark prints it (a timed test fails under a shared machine's load;
// the exact budget schedule is tested on a fake clock in tests/core and fuzzed in tests/fuzz).
//
// Draws budget-bound solves for a given time, each from its own seed (case i of seed s is the same
// case on every run): every chain solver and every tree solver, hostile problems (chains of 2 to 200
// hinges, balls, limited and not, 7 hinges with 6 position goals that no pose meets - a
// rank-deficient Gram matrix every iteration -, straight legs with the knee on its limit, targets
// out of reach, tolerances no solve meets so that the budget is what stops it, restarts, warm and
// cold starts; trees: random branched skeletons with goals at several priority levels, and the tests'
// humanoid (17 joints, 43 DOF, 46 with its floating root) with pose goals on its six effectors), budgets
// log-uniform in 20 us .. 2 ms. Each solve's thread CPU time (Deadline::thread_cpu_now_us, the
// safety cap's clock, CLOCK_THREAD_CPUTIME_ID: what the solve itself used, whatever else the machine
// runs) is compared with 1.1 x budget + 20 us. The deadline itself runs on the steady clock, as in
// a game (the budget is wall-clock time; under load it ends a solve before its CPU time reaches it),
// or with --cpu-clock on the thread's CPU clock, so that a preempted time slice cannot hide an
// overrun.
//
//   budget_bench [--seconds S] [--seed N] [--cpu-clock] [--case I] [--out DIR] [--list-over]
// Prints one line per solver (solves, budget-bound ones, those stopped before their first iteration,
// solves over the bound, worst CPU / budget and worst excess over the bound, with the case that
// made it) and writes DIR/budget.json
// (default build/bench). A solve over the bound is re-run twice and judged by its least CPU time
// (a shared machine charges a run interrupts and cache flushes that are not the solve's); the
// count on first runs is printed too. Every solve follows an untimed warm-up solve of the same
// problem on its workspace (a game reuses its workspace; first-touch page faults are not the
// solver's). --case I re-runs case I alone, three times, and prints what it was and where each run's
// time went (the longest CPU time between two clock readings, the time after the last, the longest
// charged stretch).
// --list-over prints every solve over the bound (after its re-runs) with the same numbers.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../tests/core/tree_test_util.hpp"  // the humanoid the tree tests solve (make_humanoid)
#include "bench_common.hpp"
#include "joint_desc.hpp"  // ikchain::bench; the JSON helpers are ::bench (bench_common.hpp)
#include "ikchain/deadline.hpp"
#include "ikchain/ikchain.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/tree.hpp"
#include "ikchain/tree_solve.hpp"

using namespace ikchain;

namespace {

constexpr double kRatio = 1.1;      // the bound: kRatio x budget + kSlackUs of CPU time
constexpr double kSlackUs = 20.0;
constexpr double kMinBudgetUs = 20.0, kMaxBudgetUs = 2000.0;

using Rng = std::mt19937_64;
double uniform(Rng& r, double a, double b) { return std::uniform_real_distribution<double>(a, b)(r); }
int uniform_int(Rng& r, int a, int b) { return std::uniform_int_distribution<int>(a, b)(r); }
bool coin(Rng& r, double p = 0.5) { return uniform(r, 0.0, 1.0) < p; }
glm::dvec3 random_unit(Rng& r) {
  for (;;) {
    const glm::dvec3 v(uniform(r, -1, 1), uniform(r, -1, 1), uniform(r, -1, 1));
    const double l = glm::length(v);
    if (l > 0.1 && l <= 1.0) return v / l;
  }
}
glm::dquat random_rotation(Rng& r) { return glm::angleAxis(uniform(r, 0.0, 3.14159), random_unit(r)); }

// ------------------------------------------------------------------------------------ chains
enum class Shape { kHingeChain, kBallChain, kMixedLimited, kRankDeficient, kStraightLeg, kTwoBone };
const char* shape_name(Shape s) {
  switch (s) {
    case Shape::kHingeChain: return "hinge_chain";
    case Shape::kBallChain: return "ball_chain";
    case Shape::kMixedLimited: return "mixed_limited";
    case Shape::kRankDeficient: return "7_hinges_6_goals";
    case Shape::kStraightLeg: return "straight_leg";
    case Shape::kTwoBone: return "two_bone";
  }
  return "?";
}

struct ChainCase {
  Shape shape = Shape::kHingeChain;
  Chain chain;
  std::vector<Goal> goals;
  SolverKind kind = SolverKind::kDLS;
  SolverOptions options;
  Eigen::VectorXd start;
};

// n joints (log-uniform 2..200) of `length` total, hinges about z and x alternately (x bends, z
// twists); balls or a mix; limits on some.
Chain random_chain(Rng& r, Shape shape, int n) {
  ChainBuilder b;
  const double bone = 1.0 / n;
  for (int i = 0; i < n; ++i) {
    JointDesc j;
    const bool ball = shape == Shape::kBallChain || (shape == Shape::kMixedLimited && coin(r, 0.4));
    j.type = ball ? JointType::kBall : JointType::kHinge;
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, bone, 0);
    j.axis = i % 2 == 0 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
    if (shape == Shape::kMixedLimited || coin(r, 0.2)) {
      if (ball) {
        j.limits.has_cone_limit = true;
        j.limits.cone_angle = uniform(r, 0.1, 2.0);
        j.limits.has_twist_limit = coin(r);
        j.limits.twist_min = -uniform(r, 0.05, 1.5);
        j.limits.twist_max = uniform(r, 0.05, 1.5);
      } else {
        j.limits.has_hinge_limit = true;
        j.limits.hinge_min = -uniform(r, 0.0, 2.0);
        j.limits.hinge_max = uniform(r, 0.0, 2.0);
      }
    }
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, bone, 0));
  Chain c;
  if (!b.build(c).ok()) std::abort();
  return c;
}

// A leg (hip ball, knee hinge on its limit at 0 with the leg straight), the foot target closer.
Chain straight_leg() {
  ChainBuilder b = ikchain::bench::straight_leg_builder(0.42, 0.42, /*hip_cone=*/1.5);
  Chain c;
  if (!b.build(c).ok()) std::abort();
  return c;
}

Chain two_bone_arm(Rng& r) {
  ChainBuilder b;
  JointDesc a;
  b.add_joint(a);
  JointDesc e;
  e.offset_translation = glm::dvec3(0, uniform(r, 0.1, 1.0), 0);
  b.add_joint(e);
  b.set_tip_offset(glm::dvec3(0, uniform(r, 0.1, 1.0), 0));
  Chain c;
  if (!b.build(c).ok()) std::abort();
  return c;
}

glm::dvec3 fk_point(const Chain& c, Workspace& ws, const Eigen::VectorXd& p, int effector) {
  forward_kinematics(c, p.data(), ws);
  return effector_position(c, ws, effector);
}

Eigen::VectorXd random_params(const Chain& c, Rng& r, double spread) {
  Eigen::VectorXd p(c.dof_count());
  for (int i = 0; i < p.size(); ++i) p[i] = uniform(r, -spread, spread);
  project_to_limits(c, p.data());
  return p;
}

ChainCase make_chain_case(Rng& r) {
  ChainCase k;
  const double pick = uniform(r, 0.0, 1.0);
  k.shape = pick < 0.3    ? Shape::kHingeChain
            : pick < 0.5  ? Shape::kBallChain
            : pick < 0.7  ? Shape::kMixedLimited
            : pick < 0.85 ? Shape::kRankDeficient
            : pick < 0.95 ? Shape::kStraightLeg
                          : Shape::kTwoBone;
  const int n = k.shape == Shape::kRankDeficient ? 7
                : k.shape == Shape::kStraightLeg || k.shape == Shape::kTwoBone
                    ? 2
                    : static_cast<int>(std::lround(std::exp(uniform(r, std::log(2.0), std::log(200.0)))));
  k.chain = k.shape == Shape::kStraightLeg ? straight_leg()
            : k.shape == Shape::kTwoBone   ? two_bone_arm(r)
                                           : random_chain(r, k.shape, n);
  const Chain& c = k.chain;
  Workspace ws(c, 8);
  const double reach = c.total_length();
  // Goals: FK of a random pose (reachable), or a random point (often not), and extras.
  const Eigen::VectorXd pose = random_params(c, r, 1.5);
  const glm::dvec3 tip = fk_point(c, ws, pose, 0);
  if (k.shape == Shape::kRankDeficient) {
    // 6 position goals on effectors 2..7 at random points within reach: no pose meets them all, and
    // 18 rows on 7 DOF give a rank-deficient J^T J at every iteration.
    for (int e = 2; e <= 7; ++e) k.goals.push_back(Goal::position(random_unit(r) * uniform(r, 0.0, reach), e));
  } else if (k.shape == Shape::kStraightLeg) {
    k.goals.push_back(Goal::position(glm::dvec3(uniform(r, -0.05, 0.05), -uniform(r, 0.5, 0.83), uniform(r, -0.05, 0.05))));
  } else if (k.shape == Shape::kTwoBone) {
    k.goals.push_back(Goal::position(random_unit(r) * uniform(r, 0.0, 1.2 * reach)));
  } else {
    const double mode = uniform(r, 0.0, 1.0);
    if (mode < 0.4) {
      k.goals.push_back(Goal::position(tip));
    } else if (mode < 0.55) {
      k.goals.push_back(Goal::position(random_unit(r) * uniform(r, 0.5, 2.0) * reach));  // maybe out of reach
    } else if (mode < 0.8) {  // a full pose
      forward_kinematics(c, pose.data(), ws);
      for (const Goal& g : Goal::pose(tip, effector_orientation(c, ws, c.joint_count()) * random_rotation(r), reach))
        k.goals.push_back(g);
    } else {  // several goals on inner effectors, an aim
      const int count = uniform_int(r, 2, 6);
      for (int g = 0; g < count; ++g) {
        const int e = uniform_int(r, 1, c.joint_count());
        k.goals.push_back(Goal::position(fk_point(c, ws, random_params(c, r, 1.5), e), e));
      }
      k.goals.push_back(Goal::aim(glm::dvec3(0, 1, 0), random_unit(r)));
    }
  }
  // The solver: any that takes the problem (validation rejects the rest; they are drawn again).
  static const SolverKind kinds[] = {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS,
                                     SolverKind::kFABRIK, SolverKind::kTwoBone};
  k.kind = k.shape == Shape::kTwoBone && coin(r) ? SolverKind::kTwoBone : kinds[uniform_int(r, 0, 4)];
  SolverOptions& o = k.options;
  o.max_iterations = coin(r, 0.7) ? 100000 : uniform_int(r, 10, 1000);
  // Usually a tolerance no solve meets, so the budget (or a stall) is what stops it.
  o.position_tolerance = coin(r, 0.7) ? 1e-300 : 1e-6 * reach;
  o.orientation_tolerance = coin(r, 0.7) ? 1e-300 : 1e-6;
  o.stall_tolerance = coin(r, 0.5) ? 0.0 : 1e-10;
  o.max_restarts = coin(r, 0.4) ? uniform_int(r, 1, 1000) : 0;
  o.warm_start = coin(r);
  o.max_step_angle = coin(r, 0.2) ? uniform(r, 0.01, 0.5) : 0.0;
  k.start = k.shape == Shape::kStraightLeg ? Eigen::VectorXd::Zero(c.dof_count()) : random_params(c, r, 0.5);
  return k;
}

// ------------------------------------------------------------------------------------ trees
struct TreeCase {
  bool humanoid = false;
  Tree tree;
  std::vector<TreeGoal> goals;
  std::vector<double> posture;
  SolverKind kind = SolverKind::kDLS;
  SolverOptions options;
  Eigen::VectorXd start;
  int joints = 0;
};

// The options every tree case draws.
void draw_tree_options(Rng& r, TreeCase& k) {
  static const SolverKind kinds[] = {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kCCD, SolverKind::kFABRIK};
  k.kind = kinds[uniform_int(r, 0, 3)];
  if (k.kind == SolverKind::kDLS && coin(r)) k.posture.assign(k.tree.dof_count(), 0.0);
  SolverOptions& o = k.options;
  o.max_iterations = coin(r, 0.7) ? 100000 : uniform_int(r, 10, 1000);
  o.position_tolerance = coin(r, 0.7) ? 1e-300 : 1e-6;
  o.orientation_tolerance = coin(r, 0.7) ? 1e-300 : 1e-6;
  o.stall_tolerance = coin(r, 0.5) ? 0.0 : 1e-10;
  o.max_restarts = coin(r, 0.3) ? uniform_int(r, 1, 100) : 0;
  o.warm_start = coin(r);
}

// The tree tests' humanoid (tests/core/tree_test_util.hpp: hips, spine, chest, neck, head, arms
// with hinge elbows, legs with hinge knees; limits on or off, the root floating or not): pose
// goals (position and orientation) on 1..6 of its effectors at levels 1..3, from a random pose
// (reachable together) or each from its own (not).
TreeCase make_humanoid_case(Rng& r) {
  TreeCase k;
  k.humanoid = true;
  k.tree = test::make_humanoid(coin(r, 0.7), coin(r, 0.8));
  k.joints = k.tree.joint_count();
  TreeWorkspace ws(k.tree, 1);
  const int effectors = uniform_int(r, 1, k.tree.effector_count());
  const bool together = coin(r);
  Eigen::VectorXd q(k.tree.dof_count());
  for (int e = 0; e < effectors; ++e) {
    if (e == 0 || !together) {
      for (int i = 0; i < q.size(); ++i) q[i] = uniform(r, -1.0, 1.0);
      if (k.tree.floating_root())
        for (int i = 0; i < 3; ++i) q[i] = uniform(r, -0.3, 0.3);
      project_tree_to_limits(k.tree, q.data());
      tree_forward_kinematics(k.tree, q.data(), ws);
    }
    const int level = uniform_int(r, 1, 3);
    k.goals.push_back({Goal::position(tree_effector_position(k.tree, ws, e), e), level});
    if (coin(r, 0.6)) k.goals.push_back({Goal::orientation(tree_effector_orientation(k.tree, ws, e), e), level});
  }
  draw_tree_options(r, k);
  k.start = Eigen::VectorXd::Zero(k.tree.dof_count());
  for (int i = 0; i < k.start.size(); ++i) k.start[i] = uniform(r, -0.3, 0.3);
  return k;
}

// A random branched skeleton of 5..120 joints (each joint's parent one of the last few, so it has
// limbs), balls and hinges with limits on some, a floating root sometimes; 1..12 goals on random
// effectors at levels 1..3.
TreeCase make_tree_case(Rng& r) {
  if (coin(r, 0.25)) return make_humanoid_case(r);
  TreeCase k;
  TreeBuilder b;
  const int n = static_cast<int>(std::lround(std::exp(uniform(r, std::log(5.0), std::log(120.0)))));
  k.joints = n;
  for (int i = 0; i < n; ++i) {
    TreeJointDesc d;
    d.parent = i == 0 ? -1 : std::max(0, i - uniform_int(r, 1, 4));
    const bool hinge = i > 0 && coin(r, 0.4);
    d.type = hinge ? JointType::kHinge : JointType::kBall;
    d.offset_in_parent = i == 0 ? glm::dvec3(0.0) : random_unit(r) * uniform(r, 0.05, 0.4);
    d.axis = random_unit(r);
    if (coin(r, 0.6)) {
      if (hinge) {
        d.limits.has_hinge_limit = true;
        d.limits.hinge_min = -uniform(r, 0.0, 2.0);
        d.limits.hinge_max = uniform(r, 0.0, 2.0);
      } else {
        d.limits.has_cone_limit = true;
        d.limits.cone_angle = uniform(r, 0.1, 2.0);
      }
    }
    b.add_joint(d);
  }
  const int effectors = uniform_int(r, 1, 12);
  for (int e = 0; e < effectors; ++e) {
    TreeEffectorDesc d;
    d.joint = uniform_int(r, 0, n - 1);
    d.offset = random_unit(r) * uniform(r, 0.0, 0.3);
    b.add_effector(d);
  }
  b.set_floating_root(coin(r, 0.3));
  if (!b.build(k.tree).ok()) std::abort();
  for (int e = 0; e < effectors; ++e) {
    TreeGoal g;
    g.goal = Goal::position(random_unit(r) * uniform(r, 0.0, 2.0), e);
    if (coin(r, 0.3)) g.goal = Goal::orientation(random_rotation(r), e);
    g.level = uniform_int(r, 1, 3);
    k.goals.push_back(g);
  }
  draw_tree_options(r, k);
  k.start = Eigen::VectorXd::Zero(k.tree.dof_count());
  for (int i = 0; i < k.start.size(); ++i) k.start[i] = uniform(r, -0.3, 0.3);
  return k;
}

// ------------------------------------------------------------------------------------ the run
struct Stats {
  std::string name;
  long solves = 0, exhausted = 0, over = 0;
  long unmoved = 0;  // budget_exhausted before the first iteration (0 iterations)
  double worst_ratio = 0.0;         // CPU / budget
  double worst_excess = -INFINITY;  // CPU - (kRatio budget + kSlackUs), us
  long worst_case = -1;
  std::string worst_what;
};

// The untimed warm-up solve's options: no budget, at most 3 iterations, no restarts.
SolverOptions warm_up_options(SolverOptions o) {
  o.time_budget_usec = 0.0;
  o.max_iterations = std::min(o.max_iterations, 3);
  o.max_restarts = 0;
  return o;
}

bool g_cpu_clock = false;
// On the CPU clock, the longest CPU time between two of the solve's clock readings (or from its
// start to the first): where an overrun comes from, printed by --case.
double g_last_reading = 0.0, g_longest_gap = 0.0;
double cpu_clock_us() {
  const double now = Deadline::thread_cpu_now_us();
  g_longest_gap = std::max(g_longest_gap, now - g_last_reading);
  return g_last_reading = now;
}

struct Outcome {
  std::string solver, what;
  bool tree = false, humanoid = false, exhausted = false;
  int dofs = 0;
  double budget = 0.0, cpu = 0.0, wall = 0.0;
  int iterations = 0, restarts = 0;
  const char* reason = "";
  // Between clock readings: the longest CPU time and the time after the last (--cpu-clock), and
  // the longest charged stretch against its bound (Deadline::stretch_bound).
  double longest_gap_us = 0.0, tail_us = 0.0, longest_flops = 0.0, flops_bound = 0.0, setup_us = 0.0;
};

// Case `index` of `seed`: draws the problem, solves it once on a budget, measures it.
bool run_case(uint64_t seed, long index, Outcome& out) {
  Rng r(seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(index));
  const double budget = std::exp(uniform(r, std::log(kMinBudgetUs), std::log(kMaxBudgetUs)));
  out.budget = budget;
  char what[256];
  if (coin(r, 0.75)) {
    ChainCase k = make_chain_case(r);
    k.options.time_budget_usec = budget;
    Workspace ws(k.chain, static_cast<int>(k.goals.size()));
    if (g_cpu_clock) ws.deadline.clock_us = &cpu_clock_us;
    Eigen::VectorXd p = k.start;
    if (!validate_inputs(k.kind, k.chain, Span<const Goal>(k.goals), k.options, ws, p).empty()) return false;
    // A game solves on a workspace it reuses: the first solve on a fresh one pays the page faults
    // of its first touch (milliseconds on a 600-DOF BFGS matrix), which no budget check can bound.
    // The warm-up runs without the budget (a budget spent at once would leave buffers the exit
    // work reads untouched), a few iterations.
    solve(k.kind, k.chain, Span<const Goal>(k.goals), warm_up_options(k.options), ws, p);
    p = k.start;
    const double w0 = Deadline::steady_now_us(), c0 = Deadline::thread_cpu_now_us();
    g_last_reading = c0;
    g_longest_gap = 0.0;
    const SolveResult res = solve(k.kind, k.chain, Span<const Goal>(k.goals), k.options, ws, p);
    out.cpu = Deadline::thread_cpu_now_us() - c0;
    out.tail_us = c0 + out.cpu - g_last_reading;
    out.longest_gap_us = g_longest_gap;
    out.longest_flops = ws.deadline.longest_stretch;
    out.setup_us = ws.deadline.setup_gap_us;
    out.flops_bound =
        Deadline::stretch_bound(k.chain.joint_count(), k.chain.dof_count(), 3 * static_cast<int>(k.goals.size()));
    out.wall = Deadline::steady_now_us() - w0;
    out.solver = to_string(k.kind);
    out.dofs = k.chain.dof_count();
    out.exhausted = res.budget_exhausted;
    out.iterations = res.iterations;
    out.restarts = res.restarts;
    out.reason = to_string(res.reason);
    std::snprintf(what, sizeof what, "%s %d joints %d dof %zu goals, restarts<=%d, warm %d, tol %g", shape_name(k.shape),
                  k.chain.joint_count(), k.chain.dof_count(), k.goals.size(), k.options.max_restarts,
                  k.options.warm_start ? 1 : 0, k.options.position_tolerance);
  } else {
    TreeCase k = make_tree_case(r);
    k.options.time_budget_usec = budget;
    TreeWorkspace ws(k.tree, static_cast<int>(k.goals.size()));
    if (g_cpu_clock) ws.deadline.clock_us = &cpu_clock_us;
    TreeProblem problem;
    problem.goals = Span<const TreeGoal>(k.goals);
    problem.posture = Span<const double>(k.posture.data(), static_cast<int>(k.posture.size()));
    Eigen::VectorXd p = k.start;
    solve_tree(k.kind, k.tree, problem, warm_up_options(k.options), ws, p);  // the warm-up, as for chains
    p = k.start;
    const double w0 = Deadline::steady_now_us(), c0 = Deadline::thread_cpu_now_us();
    g_last_reading = c0;
    g_longest_gap = 0.0;
    const TreeSolveResult res = solve_tree(k.kind, k.tree, problem, k.options, ws, p);
    out.cpu = Deadline::thread_cpu_now_us() - c0;
    out.tail_us = c0 + out.cpu - g_last_reading;
    out.longest_gap_us = g_longest_gap;
    out.setup_us = ws.deadline.setup_gap_us;
    out.wall = Deadline::steady_now_us() - w0;
    if (res.summary.reason == TerminationReason::kInvalidInput) return false;
    out.tree = true;
    out.solver = std::string("tree_") + to_string(k.kind);
    out.dofs = k.tree.dof_count();
    out.exhausted = res.summary.budget_exhausted;
    out.iterations = res.summary.iterations;
    out.restarts = res.summary.restarts;
    out.reason = to_string(res.summary.reason);
    out.humanoid = k.humanoid;
    std::snprintf(what, sizeof what, "%s %d joints %d dof %zu goals%s, restarts<=%d, warm %d, tol %g",
                  k.humanoid ? "humanoid tree" : "tree", k.joints,
                  k.tree.dof_count(), k.goals.size(), k.posture.empty() ? "" : " +posture", k.options.max_restarts,
                  k.options.warm_start ? 1 : 0, k.options.position_tolerance);
  }
  out.what = what;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 60.0;
  uint64_t seed = 1;
  long only_case = -1;
  bool list_over = false;
  std::string out_dir = "build/bench";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seconds" && i + 1 < argc) seconds = std::atof(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--case" && i + 1 < argc) only_case = std::atol(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
    else if (a == "--cpu-clock") g_cpu_clock = true;
    else if (a == "--quick") seconds = 10.0;
    else if (a == "--list-over") list_over = true;
    else {
      std::fprintf(stderr, "usage: budget_bench [--seconds S] [--seed N] [--cpu-clock] [--case I] [--out DIR] [--list-over]\n");
      return 2;
    }
  }
  if (only_case >= 0) {
    // Three runs, as a whole run judges a solve over the bound (its least CPU time): the first run of
    // a process pays its first touches (code, tables), 1.5-2.5x on small budgets.
    for (int run = 1; run <= 3; ++run) {
      Outcome o;
      if (!run_case(seed, only_case, o)) {
        std::printf("case %ld: input the solver does not take (skipped in runs)\n", only_case);
        return 0;
      }
      std::printf("case %ld, run %d: %s, %s; budget %.1f us: cpu %.1f us (%.3fx), wall %.1f us, %s, %d iterations, "
                  "%d restarts, budget_exhausted %d\n", only_case, run, o.solver.c_str(), o.what.c_str(), o.budget, o.cpu,
                  o.cpu / o.budget, o.wall, o.reason, o.iterations, o.restarts, o.exhausted ? 1 : 0);
      if (g_cpu_clock)
        std::printf("  longest CPU time between clock readings %.1f us, after the last %.1f us\n", o.longest_gap_us,
                    o.tail_us);
      if (o.flops_bound > 0.0)
        std::printf("  longest charged stretch %.0f flops (Deadline::stretch_bound %.0f)\n", o.longest_flops,
                    o.flops_bound);
    }
    return 0;
  }
  std::vector<Stats> stats;
  auto stats_of = [&](const std::string& name) -> Stats& {
    for (Stats& s : stats)
      if (s.name == name) return s;
    stats.emplace_back();
    stats.back().name = name;
    return stats.back();
  };
  Stats all;
  all.name = "all";
  // Solves over the bound by problem size: one FK pass, or one O(n^2) quasi-Newton product, of a
  // large problem can alone outgrow the bound's 20 us of slack.
  const int kBuckets = 4;
  const int bucket_top[kBuckets] = {30, 100, 300, 1 << 30};
  long bucket_solves[kBuckets] = {0}, bucket_over[kBuckets] = {0}, bucket_unmoved[kBuckets] = {0};
  const double t_end = Deadline::steady_now_us() + seconds * 1e6;
  long index = 0, skipped = 0, raw_over = 0;
  long humanoid_solves = 0, humanoid_over = 0;
  const int kRetries = 2;
  for (; Deadline::steady_now_us() < t_end; ++index) {
    Outcome o;
    if (!run_case(seed, index, o)) {
      ++skipped;
      continue;
    }
    // A solve over the bound is run twice more and judged by its least CPU time: one run on a shared
    // machine can be charged an interrupt or a cache flush that is not the solve's (a 2-joint leg
    // once measured 158 us on a 55 us budget and 56-58 us on each re-run).
    const bool over_once = o.cpu - (kRatio * o.budget + kSlackUs) > 0.0;
    raw_over += over_once;
    for (int retry = 0; retry < kRetries && o.cpu - (kRatio * o.budget + kSlackUs) > 0.0; ++retry) {
      Outcome again;
      run_case(seed, index, again);
      if (again.cpu < o.cpu) o = again;
    }
    const double excess = o.cpu - (kRatio * o.budget + kSlackUs);
    if (list_over && excess > 0.0)
      std::printf("over: case %ld %s %d dof, budget %.1f us, cpu %.1f us (%+.1f us), %s, %d it, longest gap %.1f us, "
                  "set-up %.1f us, after the last reading %.1f us; %s\n", index, o.solver.c_str(), o.dofs, o.budget,
                  o.cpu, excess, o.reason, o.iterations, o.longest_gap_us, o.setup_us, o.tail_us, o.what.c_str());
    humanoid_solves += o.humanoid;
    humanoid_over += o.humanoid && excess > 0.0;
    for (int b = 0; b < kBuckets; ++b)
      if (o.dofs <= bucket_top[b]) {
        ++bucket_solves[b];
        bucket_over[b] += excess > 0.0;
        bucket_unmoved[b] += o.exhausted && o.iterations == 0;
        break;
      }
    for (Stats* s : {&stats_of(o.solver), &all}) {
      ++s->solves;
      s->exhausted += o.exhausted;
      s->unmoved += o.exhausted && o.iterations == 0;
      s->over += excess > 0.0;
      s->worst_ratio = std::max(s->worst_ratio, o.cpu / o.budget);
      if (excess > s->worst_excess) {
        s->worst_excess = excess;
        s->worst_case = index;
        char buf[512];
        std::snprintf(buf, sizeof buf, "%s; budget %.1f us, cpu %.1f us, %s, %d it, %d restarts", o.what.c_str(),
                      o.budget, o.cpu, o.reason, o.iterations, o.restarts);
        s->worst_what = buf;
      }
    }
  }
  std::sort(stats.begin(), stats.end(), [](const Stats& a, const Stats& b) { return a.name < b.name; });
  std::printf("time budget in CPU time, bound %.2f x budget + %.0f us; budgets %.0f..%.0f us log-uniform; seed %llu, "
              "%ld cases (%ld skipped: input the drawn solver does not take), %.0f s, deadline on the %s clock\n",
              kRatio, kSlackUs, kMinBudgetUs, kMaxBudgetUs, static_cast<unsigned long long>(seed), index, skipped,
              seconds, g_cpu_clock ? "thread CPU" : "steady");
  std::printf("  %-16s %8s %10s %8s %6s %12s %14s  %s\n", "solver", "solves", "exhausted", "0 it", "over", "worst x bud",
              "worst excess", "worst case (budget_bench --seed S --case I)");
  stats.push_back(all);
  std::string json = "{\"meta\": " + ::bench::meta_json_head(false) + ", \"seconds\": " + ::bench::json_number(seconds) +
                     ", \"seed\": " + std::to_string(seed) + ", \"deadline_clock\": " +
                     ::bench::json_string(g_cpu_clock ? "thread_cpu" : "steady") +
                     ", \"over_bound_first_run\": " + std::to_string(raw_over) + ", \"bound\": \"" +
                     std::to_string(kRatio).substr(0, 3) + " x budget + 20 us\"}, \"solvers\": [";
  for (size_t i = 0; i < stats.size(); ++i) {
    const Stats& s = stats[i];
    std::printf("  %-16s %8ld %10ld %8ld %6ld %11.3fx %+12.1f us  case %ld: %s\n", s.name.c_str(), s.solves, s.exhausted,
                s.unmoved, s.over, s.worst_ratio, s.worst_excess, s.worst_case, s.worst_what.c_str());
    json += std::string(i ? ", " : "") + "{\"solver\": " + ::bench::json_string(s.name) +
            ", \"solves\": " + std::to_string(s.solves) + ", \"budget_exhausted\": " + std::to_string(s.exhausted) +
            ", \"over_bound\": " + std::to_string(s.over) +
            ", \"exhausted_before_first_iteration\": " + std::to_string(s.unmoved) +
            ", \"worst_cpu_over_budget\": " + ::bench::json_number(s.worst_ratio, "%.4f") +
            ", \"worst_excess_us\": " + ::bench::json_number(s.worst_excess, "%.2f") +
            ", \"worst_case\": " + std::to_string(s.worst_case) + ", \"worst_case_what\": " +
            ::bench::json_string(s.worst_what) + "}";
  }
  json += "]";
  std::printf("  over the bound by DOF: ");
  json += ", \"by_dofs\": [";
  for (int b = 0; b < kBuckets; ++b) {
    const int lo = b ? bucket_top[b - 1] + 1 : 1;
    char label[32];
    if (b + 1 < kBuckets) std::snprintf(label, sizeof label, "%d-%d", lo, bucket_top[b]);
    else std::snprintf(label, sizeof label, "%d+", lo);
    std::printf("%s%s: %ld of %ld (%ld stopped before the first iteration)", b ? ", " : "", label, bucket_over[b],
                bucket_solves[b], bucket_unmoved[b]);
    json += std::string(b ? ", " : "") + "{\"dofs\": " + ::bench::json_string(label) +
            ", \"solves\": " + std::to_string(bucket_solves[b]) + ", \"over_bound\": " + std::to_string(bucket_over[b]) +
            ", \"exhausted_before_first_iteration\": " + std::to_string(bucket_unmoved[b]) + "}";
  }
  json += "], \"humanoid_trees\": {\"solves\": " + std::to_string(humanoid_solves) +
          ", \"over_bound\": " + std::to_string(humanoid_over) + "}}\n";
  std::printf("; humanoid trees: %ld of %ld\n", humanoid_over, humanoid_solves);
  const std::string path = out_dir + "/budget.json";
  if (::bench::write_file(path, json)) std::printf("JSON: %s\n", path.c_str());
  std::printf("budget: %ld of %ld solves over %.2f x budget + %.0f us CPU (least of 3 runs; %ld on their first run); "
              "%ld stopped by the budget before the first iteration\n",
              all.over, all.solves, kRatio, kSlackUs, raw_over, all.unmoved);
  return 0;
}
