// The flat API the web page uses: one object owning a chain, its goals, options, workspace and
// pose, with plain-number arguments (embind maps them 1:1; see bindings.cpp). No embind types
// here, so this compiles natively too. Errors come back as messages naming the field; a failed
// call leaves the previous state in place.
#pragma once
#include <string>
#include <vector>

#include "ikchain/ikchain.hpp"
#include "wasm/web_common.hpp"

namespace ikchain {
namespace web {

constexpr int kMaxGoals = 4;

class WebChain : public WebOptions, public WebGoalUpdates<WebChain> {
 public:
  // --- describing a chain (joint i's offset is from joint i-1's frame; see ikchain/chain.hpp)
  void clear_joints();
  void add_hinge(double ox, double oy, double oz, double ax, double ay, double az, bool limited,
                 double min_angle, double max_angle);
  void add_ball(double ox, double oy, double oz, bool limited, double cone_angle, double twist_min,
                double twist_max);
  void set_tip(double x, double y, double z);
  // Builds the described chain; "" on success, else the builder's message. The pose goes to rest.
  std::string build();
  // The benchmark chain (bench_cases.hpp): n hinges alternating z/y (planar: all z), unit links.
  std::string build_bench_chain(int joints, bool planar);

  int joint_count() const { return chain_.joint_count(); }
  int dof_count() const { return chain_.dof_count(); }
  double total_length() const { return chain_.valid() ? chain_.total_length() : 0.0; }

  // --- goals (at most kMaxGoals); effector 0 = the tip, k in 1..n = joint k's origin
  void clear_goals() { goals_.clear(); }
  int goal_count() const { return static_cast<int>(goals_.size()); }
  std::string add_position_goal(double x, double y, double z, int effector, double weight);
  std::string add_orientation_goal(double qx, double qy, double qz, double qw, int effector, double weight);
  std::string add_aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y,
                           double dir_z, int effector, double weight);
  // Per-frame updates of an existing goal: WebGoalUpdates (web_common.hpp).
  Goal* goal_at(int index) { return index >= 0 && index < goal_count() ? &goals_[index] : nullptr; }

  // --- options beyond the shared ones (WebOptions, web_common.hpp)
  void set_max_step_angle(double radians) { options_.max_step_angle = radians; }
  void set_max_restarts(int n) { options_.max_restarts = n; }
  void set_restart_seed(unsigned seed) { options_.restart_seed = seed; }

  // --- solving; the result stays readable until the next solve
  // Returns the termination reason's code (ikchain/result.hpp).
  int solve(int solver_kind);
  const SolveResult& last_result() const { return result_; }
  void reset_pose();
  const Eigen::VectorXd& params() const { return params_; }
  // "" on success; else names the problem and leaves the pose alone.
  std::string set_params(const double* values, int count);

  // Frames of the current pose in base space: per joint origin (x, y, z) and orientation
  // (x, y, z, w), then the tip (x, y, z): 7 n + 3 numbers. Points into this object.
  const std::vector<double>& frames();

 private:
  std::string add_goal(const Goal& goal);

  ChainBuilder builder_;
  Chain chain_;
  std::vector<Goal> goals_;
  Workspace workspace_;
  Workspace fk_workspace_;
  Eigen::VectorXd params_;
  SolveResult result_;
  std::vector<double> frames_;
};

// --- the benchmark's cases, for the page's charts (bench_cases.hpp)

int bench_max_iterations(int solver_kind);
// count reachable targets of the n-joint benchmark chain, seed as given (the bench: 1000 + n);
// x, y, z per target.
std::vector<double> bench_targets(int joints, int count, unsigned seed);

struct ConvergenceTrace {
  std::vector<double> errors;  // errors[k] = tip distance after a budget of k iterations (k = 0: rest)
  std::string stopped;         // "budget", or the reason the solver stopped on its own
  double tolerance = 0.0;
};
// The 10-joint chain, one seeded target, budgets k = 1..min(bench budget, 200), each run afresh.
ConvergenceTrace convergence_trace(int solver_kind);

struct PrecisionRun {
  double distance = 0.0;  // tip to target after the solve (best possible: 2)
  std::string reason;
  int iterations = 0;
};
PrecisionRun precision_run(int solver_kind, bool planar);

}  // namespace web
}  // namespace ikchain
