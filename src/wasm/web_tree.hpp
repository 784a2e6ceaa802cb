// The flat API for whole bodies (ikchain/tree.hpp, ikchain/tree_solve.hpp): one object owning a tree, its
// goals at priority levels, a posture, options, workspace and pose, with plain-number arguments as
// WebChain has (web_chain.hpp). No embind types here. Errors come back as messages naming the
// field; a failed call leaves the previous state in place. After build(), updating goals, options
// and the posture's values and solving allocate nothing (the workspace is sized for kMaxTreeGoals).
#pragma once
#include <string>
#include <vector>

#include "ikchain/ikchain.hpp"
#include "ikchain/tree.hpp"
#include "ikchain/tree_solve.hpp"
#include "wasm/web_common.hpp"

namespace ikchain {
namespace web {

constexpr int kMaxWebTreeGoals = 16;

class WebTree : public WebOptions, public WebGoalUpdates<WebTree> {
 public:
  // --- describing a tree (joint i's offset is from its parent's frame, rest rotation identity;
  // parents precede children; see ikchain/tree.hpp). Each returns the new joint's index.
  void clear();
  // Ball joint; when `limited`, a cone about `twist axis` (the bone's direction in joint space) and
  // a twist range about it (rad).
  int add_ball(int parent, double ox, double oy, double oz, bool limited, double cone_angle, double twist_min,
               double twist_max, double tx, double ty, double tz, double motion_cost);
  int add_hinge(int parent, double ox, double oy, double oz, double ax, double ay, double az, bool limited,
                double min_angle, double max_angle, double motion_cost);
  // An effector on `joint` at `offset` in its frame (orientation: the joint's); returns its index.
  int add_effector(int joint, double ox, double oy, double oz);
  void set_floating_root(bool on, double translation_motion_cost) {
    builder_.set_floating_root(on, translation_motion_cost);
  }
  // Builds the described tree; "" on success, else the builder's message. Goals are cleared, the
  // pose goes to rest, the posture is dropped.
  std::string build();

  int joint_count() const { return tree_.joint_count(); }
  int dof_count() const { return tree_.dof_count(); }
  int effector_count() const { return tree_.effector_count(); }

  // --- goals (at most kMaxWebTreeGoals), each on an effector at a level 1..kMaxPriorityLevels
  void clear_goals() { goal_count_ = 0; }
  int goal_count() const { return goal_count_; }
  std::string add_position_goal(double x, double y, double z, int effector, double weight, int level);
  std::string add_orientation_goal(double qx, double qy, double qz, double qw, int effector, double weight,
                                   int level);
  std::string add_aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y, double dir_z,
                           int effector, double weight, int level);
  // Per-frame updates of an existing goal: WebGoalUpdates (web_common.hpp).
  Goal* goal_at(int index) { return index >= 0 && index < goal_count_ ? &goals_[index].goal : nullptr; }

  // --- posture (below every level): preferred params and one stiffness for every DOF (a share in
  // [0, 1] closed per iteration); "" or a message naming the problem. clear_posture() drops it.
  std::string set_posture(const double* values, int count, double stiffness);
  void clear_posture() { posture_on_ = false; }
  void set_posture_iterations(int n) { posture_iterations_ = n; }

  // --- options: WebOptions (web_common.hpp)

  // --- solving; the result stays readable until the next solve. Returns the termination reason's
  // code (ikchain/result.hpp).
  int solve(int solver_kind);
  const TreeSolveResult& last_result() const { return result_; }
  void reset_pose() { params_.setZero(); }
  const Eigen::VectorXd& params() const { return params_; }
  std::string set_params(const double* values, int count);

  // Frames of the current pose in base space: per joint origin (x, y, z) and orientation
  // (x, y, z, w), then per effector its position (x, y, z): 7 joints + 3 effectors numbers.
  const std::vector<double>& frames();

 private:
  std::string add_goal(const Goal& goal, int level);

  TreeBuilder builder_;
  Tree tree_;
  TreeGoal goals_[kMaxWebTreeGoals];
  int goal_count_ = 0;
  std::vector<double> posture_, posture_stiffness_;
  bool posture_on_ = false;
  int posture_iterations_ = 0;
  TreeWorkspace workspace_;
  Eigen::VectorXd params_;
  TreeSolveResult result_;
  std::vector<double> frames_;
};

}  // namespace web
}  // namespace ikchain
