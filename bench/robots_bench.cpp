// Real-robot benchmark: every ikchain solver and Orocos KDL's ChainIkSolverPos_LMA and
// ChainIkSolverPos_NR_JL on real arm kinematics (URDFs of the PyPI package example-robot-data,
// turned into chain files by tools/urdf_chain.py; scripts/bench does both), limits on.
//
// Per arm: our forward kinematics must equal KDL's (built from the URDF joints as written; see
// bench/robot_chain.hpp) on random in-limit poses, or the run aborts. Then 2,000 goals, each the
// tip pose (KDL's FK) of a seeded random in-limit joint vector, so every goal is reachable within
// the limits; two kinds: position only, and the full pose (position + the tool frame's
// orientation, Goal::pose with the chain's length as the characteristic length). Every solve
// starts at the middle of the limits. Success is judged independently of the solver: KDL's FK of
// the returned joints within position_tolerance (1e-5 * L, L = the chain's length) and
// orientation_tolerance (1e-4 rad) of the goal, and every joint within its URDF limits (1e-9 slack).
// Each solve is timed around the call by this thread's CPU time (the measure of the targets: the
// machine is shared, and wall-clock percentiles include the time other processes hold the core)
// and by std::chrono::steady_clock (wall clock, also recorded).
//
// Rows: our solvers without restarts (position and full pose) and with kRestarts seeded restarts
// (full pose; CCD and FABRIK on the first kGeometricRestartGoals goals only: most of their runs fail
// at 20 x 500 sweeps each); KDL's solvers from the same start, and "+restarts": re-run from seeded random
// in-limit starts (up to kRestarts times) while KDL reports failure or returns joints outside the
// limits, which is what TRAC-IK's KDL thread does until its timeout. Then the time budget: our
// solvers on the full poses with restarts and time_budget_usec = kBudgetUs; the largest
// elapsed / budget over all solves (target <= 1.10).
//
// Usage: robots_bench [--out DIR] [--quick] [--solvers a,b] [--iterations N] CHAIN_FILE...   (writes
// DIR/robots.json, prints a table; --solvers keeps only the named solvers' rows, for a quick look at
// a few; --iterations sets the pseudo-inverse's, DLS's and BFGS's max_iterations, 100 by default)
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

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/chainiksolverpos_nr_jl.hpp>
#include <kdl/chainiksolvervel_pinv.hpp>
#include <kdl/jntarray.hpp>

#include "bench_common.hpp"
#include "ikchain/deadline.hpp"
#include "robot_chain.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using ikchain::Deadline;  // thread_cpu_now_us: this thread's CPU time (us), the solves' measure
using ikchain::SolverKind;
using bench::json_number;
using bench::json_string;
using bench::kdl_reason;
using bench::quantile;

constexpr double kRelPositionTolerance = 1e-5;  // success: position error <= 1e-5 * L
constexpr double kOrientationTolerance = 1e-4;  // rad
constexpr double kLimitSlack = 1e-9;            // rad (m): how far outside a limit still counts as within
constexpr int kRestarts = 20;
constexpr double kBudgetUs = 1000.0;
constexpr int kGeometricRestartGoals = 500;  // CCD / FABRIK rows with restarts: the first 500 goals
constexpr double kFkTolerance = 1e-9;           // m and rad: ours vs KDL's FK
constexpr int kKdlLmaIterations = 500;          // KDL's defaults
constexpr int kKdlNrJlIterations = 100;
// Targets of issue 9.
constexpr double kTargetSuccess = 0.999;
constexpr double kTargetMedianUs = 30.0;
constexpr double kTargetP99Us = 1000.0;
constexpr double kTargetOverrun = 1.10;

struct SolverSpec {
  const char* name;
  bool is_kdl;
  SolverKind kind;      // ours
  bool nr_jl;           // KDL: NR_JL (else LMA)
  int max_iterations;   // ours: per run (restarts get the same again)
};

// The Newton-like methods' iteration budget: 100 as in core_bench, or --iterations N (how many
// goals the escapes reach when they have room: issue 16, item 20).
int newton_iterations = 100;

// Iteration budgets as in core_bench: newton_iterations for the Newton-like methods, 500 sweeps for
// CCD and FABRIK.
std::vector<SolverSpec> solver_specs() {
  return {
      {"ccd", false, SolverKind::kCCD, false, 500},
      {"fabrik", false, SolverKind::kFABRIK, false, 500},
      {"jacobian_pinv", false, SolverKind::kJacobianPinv, false, newton_iterations},
      {"dls", false, SolverKind::kDLS, false, newton_iterations},
      {"bfgs", false, SolverKind::kBFGS, false, newton_iterations},
      {"kdl_lma", true, SolverKind::kDLS, false, kKdlLmaIterations},
      {"kdl_nr_jl", true, SolverKind::kDLS, true, kKdlNrJlIterations},
  };
}

// ------------------------------------------------------------------------------------ helpers

double mean(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0.0;
  for (double x : v) s += x;
  return s / v.size();
}

std::string json_counts(const std::map<std::string, int>& m) {
  std::string s = "{";
  for (const auto& kv : m) s += (s.size() > 1 ? ", " : "") + json_string(kv.first) + ": " + std::to_string(kv.second);
  return s + "}";
}

// ------------------------------------------------------------------------------------ an arm

struct Target {
  glm::dvec3 position;
  glm::dquat orientation;
};

struct Arm {
  robots::RobotDescription robot;
  ikchain::Chain chain;
  KDL::Chain kdl;
  double length = 0.0;
  KDL::JntArray q_min, q_max;

  // KDL's FK: the independent judge.
  Target kdl_fk(const Eigen::VectorXd& q) {
    if (!fk_) fk_.reset(new KDL::ChainFkSolverPos_recursive(kdl));
    for (int i = 0; i < q.size(); ++i) kq_(i) = q[i];
    KDL::Frame f;
    fk_->JntToCart(kq_, f);
    Target t;
    robots::from_kdl(f, t.position, t.orientation);
    return t;
  }
  void init_scratch() { kq_.resize(kdl.getNrOfJoints()); }

 private:
  std::unique_ptr<KDL::ChainFkSolverPos_recursive> fk_;
  KDL::JntArray kq_;
};

bool load_arm(const std::string& path, Arm& arm) {
  const std::string error = robots::read_robot(path, arm.robot);
  if (!error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  const ikchain::Message m = robots::build_ikchain(arm.robot, arm.chain);
  if (!m.empty()) {
    std::fprintf(stderr, "%s: chain build failed: %s\n", path.c_str(), m.c_str());
    return false;
  }
  arm.kdl = robots::build_kdl(arm.robot);
  arm.length = arm.chain.total_length();
  arm.init_scratch();
  const int n = arm.chain.dof_count();
  arm.q_min.resize(n);
  arm.q_max.resize(n);
  for (int i = 0; i < n; ++i) {
    const robots::RobotJoint& j = arm.robot.joints[i];
    // A continuous joint: two turns either way (NR_JL needs bounds).
    arm.q_min(i) = j.limited() ? j.lower : -2.0 * 3.14159265358979323846;
    arm.q_max(i) = j.limited() ? j.upper : 2.0 * 3.14159265358979323846;
  }
  return true;
}

// Our FK against KDL's on random in-limit poses; the worst differences (m, rad).
bool check_fk(Arm& arm, int samples, double& worst_position, double& worst_rotation) {
  std::mt19937 rng(20151103u);
  ikchain::Workspace ws(arm.chain, 1);
  Eigen::VectorXd q(arm.chain.dof_count());
  worst_position = worst_rotation = 0.0;
  for (int t = 0; t < samples; ++t) {
    robots::random_in_limits(arm.robot, rng, q);
    ikchain::forward_kinematics(arm.chain, q.data(), ws);
    const Target theirs = arm.kdl_fk(q);
    worst_position = std::max(worst_position, glm::length(ws.tip - theirs.position));
    worst_rotation = std::max(worst_rotation, robots::rotation_distance(ikchain::effector_orientation(arm.chain, ws, 0),
                                                                        theirs.orientation));
  }
  return worst_position <= kFkTolerance && worst_rotation <= kFkTolerance;
}

// ------------------------------------------------------------------------------------ one cell

struct Cell {
  std::string arm, goal, solver;
  int restarts_allowed = 0;
  double budget_us = 0.0;
  int trials = 0, successes = 0, first_run_successes = 0;
  std::vector<double> us, cpu_us, iterations, restarts, solved_us;  // us: wall clock
  std::vector<double> cpu_us_first_run, cpu_us_restarted;  // solves that needed no restart / some
  std::map<std::string, int> reasons, failures;
  double worst_ratio = 0.0, worst_cpu_ratio = 0.0;  // elapsed (wall, CPU) / budget
  int exhausted = 0;
  int cpu_over_target = 0, wall_over_target = 0;  // solves over kTargetOverrun x budget
  bool skipped = false;
  std::string note;

  double rate() const { return trials ? static_cast<double>(successes) / trials : NAN; }
  // One solve's times (wall and CPU, us), iterations and restarts; `failure` is null on success.
  void add(double wall, double cpu, double iters, int restarts_used, const char* reason, const char* failure) {
    ++trials;
    us.push_back(wall);
    cpu_us.push_back(cpu);
    (restarts_used ? cpu_us_restarted : cpu_us_first_run).push_back(cpu);
    iterations.push_back(iters);
    restarts.push_back(restarts_used);
    ++reasons[reason];
    if (!failure) {
      ++successes;
      solved_us.push_back(wall);
      if (restarts_used == 0) ++first_run_successes;
    } else {
      ++failures[failure];
    }
  }
};

struct Judge {
  bool ok;
  const char* why;  // for a failure: "beyond_tolerance" (by KDL's FK) or "outside_limits"
};

Judge judge(Arm& arm, bool full_pose, const Target& goal, const Eigen::VectorXd& q) {
  if (!robots::within_urdf_limits(arm.robot, q, kLimitSlack)) return {false, "outside_limits"};
  const Target reached = arm.kdl_fk(q);
  if (!(glm::length(reached.position - goal.position) <= kRelPositionTolerance * arm.length))
    return {false, "beyond_tolerance"};
  if (full_pose && !(robots::rotation_distance(reached.orientation, goal.orientation) <= kOrientationTolerance))
    return {false, "beyond_tolerance"};
  return {true, ""};
}

Cell run_ours(Arm& arm, const SolverSpec& spec, bool full_pose, int restarts, double budget_us,
              const std::vector<Target>& targets) {
  Cell cell;
  cell.arm = arm.robot.name;
  cell.goal = full_pose ? "full_pose" : "position";
  cell.solver = spec.name;
  cell.restarts_allowed = restarts;
  cell.budget_us = budget_us;
  ikchain::SolverOptions o;
  o.position_tolerance = kRelPositionTolerance * arm.length;
  o.orientation_tolerance = kOrientationTolerance;
  o.max_iterations = spec.max_iterations;
  o.warm_start = true;
  o.max_restarts = restarts;
  o.restart_seed = 1;
  o.time_budget_usec = budget_us;
  // No safety cap (SolverOptions::time_cap_usec, 50 ms of CPU time), the only clock a row without
  // a budget would read: failure counts are compared run against run, and at --iterations 300 one
  // run beside a build failed 2 more of the same 12,000 goals than two quieter runs of the same
  // binary. A budget row has its budget.
  o.time_cap_usec = 0.0;
  const int n = arm.chain.dof_count();
  ikchain::Workspace ws(arm.chain, 2);
  const Eigen::VectorXd middle = robots::middle_of_limits(arm.robot);
  Eigen::VectorXd q(n);
  for (size_t t = 0; t < targets.size(); ++t) {
    const auto goals = ikchain::pose_goals(arm.chain, targets[t].position, targets[t].orientation);
    const ikchain::Span<const ikchain::Goal> span(goals.data(), full_pose ? 2 : 1);
    q = middle;
    o.restart_seed = static_cast<unsigned>(t + 1);
    const double c0 = Deadline::thread_cpu_now_us();
    const Clock::time_point t0 = Clock::now();
    const ikchain::SolveResult r = ikchain::solve(spec.kind, arm.chain, span, o, ws, q);
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    const double cpu = Deadline::thread_cpu_now_us() - c0;
    const Judge j = judge(arm, full_pose, targets[t], q);
    // A failure's reason: the solver's own, or the judge's when the solver claimed convergence.
    const char* reason = ikchain::to_string(r.reason);
    cell.add(us, cpu, r.iterations, r.restarts, reason,
             j.ok ? nullptr : r.reason == ikchain::TerminationReason::kConverged ? j.why : reason);
    if (!j.ok && r.reason == ikchain::TerminationReason::kInvalidInput && cell.note.empty())
      cell.note = r.message.c_str();
    if (budget_us > 0.0) {
      cell.worst_ratio = std::max(cell.worst_ratio, us / budget_us);
      cell.worst_cpu_ratio = std::max(cell.worst_cpu_ratio, cpu / budget_us);
      cell.cpu_over_target += cpu > kTargetOverrun * budget_us;
      cell.wall_over_target += us > kTargetOverrun * budget_us;
      cell.exhausted += r.budget_exhausted;
    }
  }
  return cell;
}

// KDL on the same goals; with restarts > 0, re-run from seeded random in-limit starts while KDL
// reports failure or returns joints outside the limits.
Cell run_kdl(Arm& arm, const SolverSpec& spec, bool full_pose, int restarts, const std::vector<Target>& targets) {
  Cell cell;
  cell.arm = arm.robot.name;
  cell.goal = full_pose ? "full_pose" : "position";
  cell.solver = spec.name;
  cell.restarts_allowed = restarts;
  const int n = arm.chain.dof_count();
  const double position_tolerance = kRelPositionTolerance * arm.length;
  std::unique_ptr<KDL::ChainIkSolverPos_LMA> lma;
  std::unique_ptr<KDL::ChainFkSolverPos_recursive> fk;
  std::unique_ptr<KDL::ChainIkSolverVel_pinv> vel;
  std::unique_ptr<KDL::ChainIkSolverPos_NR_JL> nr_jl;
  if (spec.nr_jl) {
    if (!full_pose) {
      cell.skipped = true;
      cell.note = "6-D goals only (no position-only mode)";
      return cell;
    }
    fk.reset(new KDL::ChainFkSolverPos_recursive(arm.kdl));
    vel.reset(new KDL::ChainIkSolverVel_pinv(arm.kdl));
    // Its stop test is per twist component (|dx_i| < eps): eps = tolerance / sqrt(3) bounds the
    // position error's norm by the tolerance (and the rotation's by far less than 1e-4 rad).
    nr_jl.reset(new KDL::ChainIkSolverPos_NR_JL(arm.kdl, arm.q_min, arm.q_max, *fk, *vel, spec.max_iterations,
                                                 position_tolerance / std::sqrt(3.0)));
  } else {
    // LMA's stop test is |L .* dx| < eps on (position, rotation): L = (1, 1, 1, r, r, r) with
    // r = position_tolerance / orientation_tolerance and eps = position_tolerance makes it stop
    // only within both tolerances. Position only: the rotation rows weigh 0.
    Eigen::Matrix<double, 6, 1> weights;
    const double r = full_pose ? position_tolerance / kOrientationTolerance : 0.0;
    weights << 1, 1, 1, r, r, r;
    lma.reset(new KDL::ChainIkSolverPos_LMA(arm.kdl, weights, position_tolerance, spec.max_iterations));
  }
  const Eigen::VectorXd middle = robots::middle_of_limits(arm.robot);
  KDL::JntArray q_init(n), q_out(n);
  Eigen::VectorXd q(n), start(n);
  for (size_t t = 0; t < targets.size(); ++t) {
    KDL::Frame goal;
    goal.p = KDL::Vector(targets[t].position.x, targets[t].position.y, targets[t].position.z);
    const glm::dquat& g = targets[t].orientation;
    goal.M = KDL::Rotation::Quaternion(g.x, g.y, g.z, g.w);
    std::mt19937 rng(static_cast<unsigned>(t + 1));
    start = middle;
    int rc = 0, used = 0, iterations = 0;
    const double c0 = Deadline::thread_cpu_now_us();
    const Clock::time_point t0 = Clock::now();
    for (;;) {
      for (int i = 0; i < n; ++i) q_init(i) = start[i];
      rc = spec.nr_jl ? nr_jl->CartToJnt(q_init, goal, q_out) : lma->CartToJnt(q_init, goal, q_out);
      if (!spec.nr_jl) iterations += lma->lastNrOfIter;
      for (int i = 0; i < n; ++i) q[i] = q_out(i);
      if ((rc >= 0 && robots::within_urdf_limits(arm.robot, q, kLimitSlack)) || used >= restarts) break;
      ++used;
      robots::random_in_limits(arm.robot, rng, start);
    }
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    const double cpu = Deadline::thread_cpu_now_us() - c0;
    const Judge j = judge(arm, full_pose, targets[t], q);
    cell.add(us, cpu, spec.nr_jl ? NAN : iterations, used, kdl_reason(rc),
             j.ok ? nullptr : rc >= 0 ? j.why : kdl_reason(rc));
  }
  if (spec.nr_jl) cell.iterations.clear();  // NR_JL does not report its iterations
  return cell;
}

std::string cell_json(const Cell& c) {
  std::string s = "{";
  s += "\"arm\": " + json_string(c.arm);
  s += ", \"goal\": " + json_string(c.goal);
  s += ", \"solver\": " + json_string(c.solver);
  s += ", \"max_restarts\": " + std::to_string(c.restarts_allowed);
  s += ", \"time_budget_us\": " + json_number(c.budget_us);
  if (c.skipped) return s + ", \"skipped\": true, \"note\": " + json_string(c.note) + "}";
  s += ", \"trials\": " + std::to_string(c.trials);
  s += ", \"success_rate\": " + json_number(c.rate(), "%.5f");
  s += ", \"first_run_success_rate\": " + json_number(static_cast<double>(c.first_run_successes) / c.trials, "%.5f");
  s += ", \"cpu_median_us\": " + json_number(quantile(c.cpu_us, 0.5), "%.4g");
  s += ", \"cpu_p90_us\": " + json_number(quantile(c.cpu_us, 0.9), "%.4g");
  s += ", \"cpu_p99_us\": " + json_number(quantile(c.cpu_us, 0.99), "%.4g");
  s += ", \"cpu_max_us\": " + json_number(c.cpu_us.empty() ? NAN : *std::max_element(c.cpu_us.begin(), c.cpu_us.end()), "%.4g");
  s += ", \"median_us\": " + json_number(quantile(c.us, 0.5), "%.4g");
  s += ", \"p90_us\": " + json_number(quantile(c.us, 0.9), "%.4g");
  s += ", \"p99_us\": " + json_number(quantile(c.us, 0.99), "%.4g");
  s += ", \"max_us\": " + json_number(c.us.empty() ? NAN : *std::max_element(c.us.begin(), c.us.end()), "%.4g");
  s += ", \"mean_us\": " + json_number(mean(c.us), "%.4g");
  s += ", \"solved_median_us\": " + json_number(quantile(c.solved_us, 0.5), "%.4g");
  s += ", \"median_iterations\": " + json_number(quantile(c.iterations, 0.5), "%.4g");
  s += ", \"mean_iterations\": " + json_number(mean(c.iterations), "%.4g");
  // Where the time goes: CPU time per iteration (all solves), and the solves that needed no restart
  // against those that did (how many, their median and their share of all CPU time).
  double cpu_total = 0.0, iterations_total = 0.0, cpu_restarted = 0.0;
  for (double v : c.cpu_us) cpu_total += v;
  for (double v : c.cpu_us_restarted) cpu_restarted += v;
  for (double v : c.iterations) iterations_total += std::isfinite(v) ? v : 0.0;
  s += ", \"cpu_us_per_iteration\": " + json_number(iterations_total > 0 ? cpu_total / iterations_total : NAN, "%.4g");
  s += ", \"solves_restarted\": " + std::to_string(c.cpu_us_restarted.size());
  s += ", \"cpu_median_us_first_run\": " + json_number(quantile(c.cpu_us_first_run, 0.5), "%.4g");
  s += ", \"cpu_median_us_restarted\": " + json_number(quantile(c.cpu_us_restarted, 0.5), "%.4g");
  s += ", \"cpu_share_restarted\": " + json_number(cpu_total > 0 ? cpu_restarted / cpu_total : NAN, "%.4f");
  s += ", \"median_restarts\": " + json_number(quantile(c.restarts, 0.5), "%.4g");
  s += ", \"mean_restarts\": " + json_number(mean(c.restarts), "%.4g");
  s += ", \"p99_restarts\": " + json_number(quantile(c.restarts, 0.99), "%.4g");
  if (c.budget_us > 0.0) {
    s += ", \"budget_exhausted\": " + std::to_string(c.exhausted);
    s += ", \"worst_elapsed_over_budget\": " + json_number(c.worst_ratio, "%.4f");
    s += ", \"worst_cpu_over_budget\": " + json_number(c.worst_cpu_ratio, "%.4f");
    s += ", \"solves_over_1_10_budget_cpu\": " + std::to_string(c.cpu_over_target);
    s += ", \"solves_over_1_10_budget_wall\": " + std::to_string(c.wall_over_target);
  }
  s += ", \"reasons\": " + json_counts(c.reasons);
  s += ", \"failures\": " + json_counts(c.failures);
  if (!c.note.empty()) s += ", \"note\": " + json_string(c.note);
  return s + "}";
}

std::string top_failure(const Cell& c) {
  std::string best;
  int count = 0;
  for (const auto& kv : c.failures)
    if (kv.second > count) {
      best = kv.first;
      count = kv.second;
    }
  return best.empty() ? "-" : best + " " + std::to_string(count);
}

void print_row(const Cell& c) {
  const std::string name = c.solver + (c.restarts_allowed ? "+restarts" : "") + (c.budget_us > 0 ? "+budget" : "");
  if (c.skipped) {
    std::printf("  %-11s %-9s %-24s skipped: %s\n", c.arm.c_str(), c.goal.c_str(), name.c_str(), c.note.c_str());
    return;
  }
  std::printf("  %-11s %-9s %-28s %5d %7.2f %%  cpu median %7.1f p99 %8.1f us (wall p99 %8.1f)  it %4.0f  restarts %4.2f",
              c.arm.c_str(), c.goal.c_str(), name.c_str(), c.trials, 100.0 * c.rate(), quantile(c.cpu_us, 0.5),
              quantile(c.cpu_us, 0.99), quantile(c.us, 0.99), quantile(c.iterations, 0.5), mean(c.restarts));
  if (c.budget_us > 0.0)
    std::printf("  worst x budget: cpu %.3f wall %.3f (over 1.10: cpu %d, wall %d)", c.worst_cpu_ratio, c.worst_ratio,
                c.cpu_over_target, c.wall_over_target);
  std::printf("  fail: %s\n", top_failure(c).c_str());
  std::fflush(stdout);
}

std::string meta_json(bool quick, int trials) {
  std::string s = bench::meta_json_head(quick);
  s += ", \"goals_per_arm\": " + std::to_string(trials);
  s += ", \"goals\": \"KDL FK of seeded uniform random joint vectors within the URDF limits\"";
  s += ", \"start\": \"middle of the limits (warm_start = true); KDL: q_init = the same\"";
  s += ", \"success\": \"KDL FK of the returned joints: position error <= 1e-5 * L, full pose also rotation <= 1e-4 rad; "
       "every joint within its URDF limits (1e-9 slack)\"";
  s += ", \"restarts\": " + std::to_string(kRestarts);
  s += ", \"geometric_restart_goals\": " + std::to_string(kGeometricRestartGoals);
  s += ", \"times\": \"cpu_*: this thread's CPU time (CLOCK_THREAD_CPUTIME_ID) around the call, the targets' measure; "
       "*_us: wall clock (steady_clock), which on a shared machine includes preemption by other processes\"";
  s += ", \"time_budget_us\": " + json_number(kBudgetUs);
  s += ", \"max_iterations\": {";
  bool first = true;
  for (const SolverSpec& sp : solver_specs()) {
    s += (first ? "" : ", ") + json_string(sp.name) + ": " + std::to_string(sp.max_iterations);
    first = false;
  }
  s += "}, \"two_bone\": \"skipped: takes exactly 2 joints (these arms have 6 and 7)\"";
  s += ", \"targets\": {\"full_pose_success\": 0.999, \"full_pose_median_us\": 30, \"full_pose_p99_us\": 1000, "
       "\"position_success\": 0.999, \"worst_elapsed_over_budget\": 1.10}}";
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir = "build/bench";
  bool quick = false;
  std::vector<std::string> chain_files;
  std::string only;  // --solvers: comma-separated names, empty = all
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
    } else if (!std::strcmp(argv[i], "--iterations") && i + 1 < argc && std::atoi(argv[i + 1]) > 0) {
      newton_iterations = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--solvers") && i + 1 < argc) {
      only = std::string(",") + argv[++i] + ",";
    } else if (argv[i][0] == '-') {
      std::fprintf(stderr, "usage: %s [--out DIR] [--quick] [--solvers a,b] [--iterations N] CHAIN_FILE...\n", argv[0]);
      return 2;
    } else {
      chain_files.push_back(argv[i]);
    }
  }
  if (chain_files.empty()) {
    std::fprintf(stderr, "usage: %s [--out DIR] [--quick] CHAIN_FILE... (tools/urdf_chain.py makes them)\n", argv[0]);
    return 2;
  }
  const Clock::time_point run_start = Clock::now();
  bench::start_loadavg();
  const int trials = quick ? 100 : 2000;
  auto selected = [&](const SolverSpec& sp) {
    return only.empty() || only.find(std::string(",") + sp.name + ",") != std::string::npos;
  };
  std::string arms_json, records;
  std::vector<Cell> all;
  for (const std::string& path : chain_files) {
    Arm arm;
    if (!load_arm(path, arm)) return 1;
    double worst_position, worst_rotation;
    const bool fk_ok = check_fk(arm, 1000, worst_position, worst_rotation);
    std::printf("%s: %d joints, L = %.4f m; our FK vs KDL's on 1000 poses: %.2e m, %.2e rad%s\n",
                arm.robot.name.c_str(), arm.chain.dof_count(), arm.length, worst_position, worst_rotation,
                fk_ok ? "" : "  MISMATCH");
    if (!fk_ok) {
      std::fprintf(stderr, "ABORT: %s: our forward kinematics differ from KDL's by more than %g: the URDF mapping "
                           "is wrong, every figure would be meaningless\n", path.c_str(), kFkTolerance);
      return 1;
    }
    arms_json += std::string(arms_json.empty() ? "\n  " : ",\n  ") + "{\"arm\": " + json_string(arm.robot.name) +
                 ", \"base\": " + json_string(arm.robot.base) + ", \"tip\": " + json_string(arm.robot.tip) +
                 ", \"joints\": " + std::to_string(arm.chain.dof_count()) +
                 ", \"length_m\": " + json_number(arm.length, "%.6g") +
                 ", \"fk_vs_kdl_position_m\": " + json_number(worst_position, "%.3e") +
                 ", \"fk_vs_kdl_rotation_rad\": " + json_number(worst_rotation, "%.3e") + "}";

    std::mt19937 rng(1000u + static_cast<unsigned>(arm.chain.dof_count()) * 7u + static_cast<unsigned>(arm.robot.name.size()));
    std::vector<Target> targets;
    Eigen::VectorXd truth(arm.chain.dof_count());
    for (int t = 0; t < trials; ++t) {
      robots::random_in_limits(arm.robot, rng, truth);
      targets.push_back(arm.kdl_fk(truth));
    }
    // CCD and FABRIK with restarts fail most full poses, and each failure costs 20 x 500 sweeps:
    // the first kGeometricRestartGoals goals keep the run short.
    const std::vector<Target> few_targets(targets.begin(), targets.begin() + std::min<int>(trials, kGeometricRestartGoals));
    auto geometric = [](const SolverSpec& sp) { return sp.kind == SolverKind::kCCD || sp.kind == SolverKind::kFABRIK; };
    auto add = [&](const Cell& c) {
      print_row(c);
      records += (records.empty() ? "\n  " : ",\n  ") + cell_json(c);
      all.push_back(c);
    };
    for (bool full_pose : {false, true}) {
      for (const SolverSpec& spec : solver_specs()) {
        if (!selected(spec)) continue;
        if (spec.is_kdl) {
          add(run_kdl(arm, spec, full_pose, 0, targets));
          if (full_pose) add(run_kdl(arm, spec, full_pose, kRestarts, targets));
        } else {
          add(run_ours(arm, spec, full_pose, 0, 0.0, targets));
          if (full_pose) add(run_ours(arm, spec, full_pose, kRestarts, 0.0, geometric(spec) ? few_targets : targets));
        }
      }
    }
    for (const SolverSpec& spec : solver_specs())
      if (!spec.is_kdl && selected(spec)) add(run_ours(arm, spec, true, kRestarts, kBudgetUs, geometric(spec) ? few_targets : targets));
  }

  // The targets, per solver over every arm (a target is met when it is met on each arm).
  std::printf("\ntargets (every arm; times are CPU times): full pose + restarts >= 99.9 %% at median <= 30 us and "
              "p99 <= 1 ms; position >= 99.9 %% without restarts; elapsed <= 1.10 x budget\n");
  std::string targets_json;
  for (const SolverSpec& spec : solver_specs()) {
    if (!selected(spec)) continue;
    bool full_rate = true, full_median = true, full_p99 = true, position_rate = true, budget = true, any_budget = false;
    for (const Cell& c : all) {
      if (c.solver != spec.name || c.skipped) continue;
      if (c.goal == "full_pose" && c.restarts_allowed > 0 && c.budget_us == 0.0) {
        full_rate = full_rate && c.rate() >= kTargetSuccess;
        full_median = full_median && quantile(c.cpu_us, 0.5) <= kTargetMedianUs;
        full_p99 = full_p99 && quantile(c.cpu_us, 0.99) <= kTargetP99Us;
      }
      if (c.goal == "position" && c.restarts_allowed == 0) position_rate = position_rate && c.rate() >= kTargetSuccess;
      if (c.budget_us > 0.0) {
        any_budget = true;
        budget = budget && c.worst_cpu_ratio <= kTargetOverrun;
      }
    }
    const bool has_position = !(spec.is_kdl && spec.nr_jl);
    auto mark = [](bool met) { return met ? "met" : "MISSED"; };
    std::printf("  %-14s full-pose success %-6s  median %-6s  p99 %-6s  position success %-6s  budget %s\n", spec.name,
                mark(full_rate), mark(full_median), mark(full_p99), has_position ? mark(position_rate) : "n/a",
                any_budget ? mark(budget) : "n/a");
    targets_json += std::string(targets_json.empty() ? "\n  " : ",\n  ") + "{\"solver\": " + json_string(spec.name) +
                    ", \"full_pose_success\": " + (full_rate ? "true" : "false") +
                    ", \"full_pose_median_us\": " + (full_median ? "true" : "false") +
                    ", \"full_pose_p99_us\": " + (full_p99 ? "true" : "false") +
                    ", \"position_success\": " + (has_position ? (position_rate ? "true" : "false") : "null") +
                    ", \"budget\": " + (any_budget ? (budget ? "true" : "false") : "null") + "}";
  }

  const std::string path = out_dir + "/robots.json";
  if (!bench::write_file(path, "{\"meta\": " + meta_json(quick, trials) + ",\n\"arms\": [" + arms_json +
                                    "\n],\n\"records\": [" + records + "\n],\n\"targets_met\": [" + targets_json +
                                    "\n]}\n"))
    return 1;
  std::fprintf(stderr, "robots.json written (%s) in %.1f s\n", path.c_str(),
               std::chrono::duration<double>(Clock::now() - run_start).count());
  return 0;
}
