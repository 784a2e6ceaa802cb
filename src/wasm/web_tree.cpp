#include "wasm/web_tree.hpp"

namespace ikchain {
namespace web {

void WebTree::clear() { builder_.clear(); }

int WebTree::add_ball(int parent, double ox, double oy, double oz, bool limited, double cone_angle,
                      double twist_min, double twist_max, double tx, double ty, double tz, double motion_cost) {
  TreeJointDesc j;
  j.parent = parent;
  j.type = JointType::kBall;
  j.offset_in_parent = glm::dvec3(ox, oy, oz);
  j.motion_cost = motion_cost;
  j.limits.twist_axis = glm::dvec3(tx, ty, tz);
  set_ball_limits(j.limits, limited, cone_angle, twist_min, twist_max);
  return builder_.add_joint(j);
}

int WebTree::add_hinge(int parent, double ox, double oy, double oz, double ax, double ay, double az, bool limited,
                       double min_angle, double max_angle, double motion_cost) {
  TreeJointDesc j;
  j.parent = parent;
  j.type = JointType::kHinge;
  j.offset_in_parent = glm::dvec3(ox, oy, oz);
  j.axis = glm::dvec3(ax, ay, az);
  j.motion_cost = motion_cost;
  set_hinge_limits(j.limits, limited, min_angle, max_angle);
  return builder_.add_joint(j);
}

int WebTree::add_effector(int joint, double ox, double oy, double oz) {
  TreeEffectorDesc e;
  e.joint = joint;
  e.offset = glm::dvec3(ox, oy, oz);
  return builder_.add_effector(e);
}

std::string WebTree::build() {
  Tree built;
  const TreeBuildError error = builder_.build(built);
  if (!error.ok()) return error.message.c_str();
  tree_ = built;
  // Sized once here: goal updates and solves then allocate nothing.
  workspace_.reset(tree_, kMaxWebTreeGoals);
  params_ = Eigen::VectorXd::Zero(tree_.dof_count());
  posture_.assign(tree_.dof_count(), 0.0);
  posture_stiffness_.assign(tree_.dof_count(), 0.0);
  posture_on_ = false;
  frames_.assign(7 * tree_.joint_count() + 3 * tree_.effector_count(), 0.0);
  goal_count_ = 0;
  result_ = TreeSolveResult();
  return "";
}

std::string WebTree::add_goal(const Goal& goal, int level) {
  if (goal_count_ >= kMaxWebTreeGoals)
    return "goals: at most " + std::to_string(kMaxWebTreeGoals) + " goals; call clearGoals() first";
  // The effector and level are the core's to check (at the solve, naming the goal).
  goals_[goal_count_++] = TreeGoal{goal, level};
  return "";
}

std::string WebTree::add_position_goal(double x, double y, double z, int effector, double weight, int level) {
  return add_goal(Goal::position(glm::dvec3(x, y, z), effector, weight), level);
}

std::string WebTree::add_orientation_goal(double qx, double qy, double qz, double qw, int effector, double weight,
                                          int level) {
  return add_goal(orientation_goal(qx, qy, qz, qw, effector, weight), level);
}

std::string WebTree::add_aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y,
                                  double dir_z, int effector, double weight, int level) {
  return add_goal(aim_goal(axis_x, axis_y, axis_z, dir_x, dir_y, dir_z, effector, weight), level);
}

std::string WebTree::set_posture(const double* values, int count, double stiffness) {
  std::string error = check_dof_values("posture", values, count, tree_.dof_count());
  if (!error.empty()) return error;
  if (!(stiffness >= 0.0 && stiffness <= 1.0))
    return "posture: stiffness must be in [0, 1], got " + std::to_string(stiffness);
  for (int i = 0; i < count; ++i) {
    posture_[i] = values[i];
    posture_stiffness_[i] = stiffness;
  }
  posture_on_ = true;
  return "";
}

int WebTree::solve(int solver_kind) {
  TreeProblem problem;
  problem.goals = Span<const TreeGoal>(goals_, goal_count_);
  if (posture_on_) {
    problem.posture = Span<const double>(posture_.data(), static_cast<int>(posture_.size()));
    problem.posture_stiffness = Span<const double>(posture_stiffness_.data(), static_cast<int>(posture_stiffness_.size()));
    problem.posture_iterations = posture_iterations_;
  }
  // The core validates everything (tree built, goals, levels, options, kind) and names the bad field.
  result_ = solve_tree(static_cast<SolverKind>(solver_kind), tree_, problem, options_, workspace_, params_);
  return static_cast<int>(result_.summary.reason);
}

std::string WebTree::set_params(const double* values, int count) {
  std::string error = check_dof_values("params", values, count, tree_.dof_count());
  if (!error.empty()) return error;
  for (int i = 0; i < count; ++i) params_[i] = values[i];
  return "";
}

const std::vector<double>& WebTree::frames() {
  if (!tree_.valid()) {
    frames_.clear();
    return frames_;
  }
  tree_forward_kinematics(tree_, params_.data(), workspace_);
  double* effectors = write_joint_frames(workspace_.joint_origins.data(), workspace_.joint_orientations.data(),
                                         tree_.joint_count(), frames_.data());
  for (int e = 0; e < tree_.effector_count(); ++e)
    write_point(tree_effector_position(tree_, workspace_, e), effectors + 3 * e);
  return frames_;
}

}  // namespace web
}  // namespace ikchain
