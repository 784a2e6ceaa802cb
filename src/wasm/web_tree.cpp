#include "wasm/web_tree.hpp"

#include <cmath>

namespace ikchain {
namespace web {

namespace {
bool finite(double v) { return std::isfinite(v); }
}  // namespace

void WebTree::clear() { builder_.clear(); }

int WebTree::add_ball(int parent, double ox, double oy, double oz, bool limited, double cone_angle,
                      double twist_min, double twist_max, double tx, double ty, double tz, double motion_cost) {
  TreeJointDesc j;
  j.parent = parent;
  j.type = JointType::kBall;
  j.offset_in_parent = glm::dvec3(ox, oy, oz);
  j.motion_cost = motion_cost;
  j.limits.twist_axis = glm::dvec3(tx, ty, tz);
  j.limits.has_cone_limit = limited;
  j.limits.has_twist_limit = limited;
  if (limited) {
    j.limits.cone_angle = cone_angle;
    j.limits.twist_min = twist_min;
    j.limits.twist_max = twist_max;
  }
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
  j.limits.has_hinge_limit = limited;
  if (limited) {
    j.limits.hinge_min = min_angle;
    j.limits.hinge_max = max_angle;
  }
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
  return add_goal(Goal::orientation(glm::dquat(qw, qx, qy, qz), effector, weight), level);
}

std::string WebTree::add_aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y,
                                  double dir_z, int effector, double weight, int level) {
  return add_goal(Goal::aim(glm::dvec3(axis_x, axis_y, axis_z), glm::dvec3(dir_x, dir_y, dir_z), effector, weight),
                  level);
}

Goal* WebTree::goal_of_kind(int index, GoalKind kind) {
  if (index < 0 || index >= goal_count_ || goals_[index].goal.kind != kind) return nullptr;
  return &goals_[index].goal;
}

bool WebTree::set_goal_position(int index, double x, double y, double z) {
  Goal* g = goal_of_kind(index, GoalKind::kPosition);
  if (g) g->target_position = glm::dvec3(x, y, z);
  return g != nullptr;
}

bool WebTree::set_goal_orientation(int index, double qx, double qy, double qz, double qw) {
  Goal* g = goal_of_kind(index, GoalKind::kOrientation);
  if (g) g->target_orientation = glm::dquat(qw, qx, qy, qz);
  return g != nullptr;
}

bool WebTree::set_goal_aim_direction(int index, double x, double y, double z) {
  Goal* g = goal_of_kind(index, GoalKind::kAim);
  if (g) g->aim_direction = glm::dvec3(x, y, z);
  return g != nullptr;
}

std::string WebTree::set_posture(const double* values, int count, double stiffness) {
  if (count != tree_.dof_count())
    return "posture: expected " + std::to_string(tree_.dof_count()) + " values (one per DOF), got " +
           std::to_string(count);
  for (int i = 0; i < count; ++i)
    if (!finite(values[i])) return "posture: value " + std::to_string(i) + " is not finite";
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
  if (count != tree_.dof_count())
    return "params: expected " + std::to_string(tree_.dof_count()) + " values (one per DOF), got " +
           std::to_string(count);
  for (int i = 0; i < count; ++i)
    if (!finite(values[i])) return "params: value " + std::to_string(i) + " is not finite";
  for (int i = 0; i < count; ++i) params_[i] = values[i];
  return "";
}

const std::vector<double>& WebTree::frames() {
  if (!tree_.valid()) {
    frames_.clear();
    return frames_;
  }
  tree_forward_kinematics(tree_, params_.data(), workspace_);
  const int n = tree_.joint_count();
  for (int i = 0; i < n; ++i) {
    const glm::dvec3& o = workspace_.joint_origins[i];
    const glm::dquat& q = workspace_.joint_orientations[i];
    double* f = frames_.data() + 7 * i;
    f[0] = o.x, f[1] = o.y, f[2] = o.z;
    f[3] = q.x, f[4] = q.y, f[5] = q.z, f[6] = q.w;
  }
  for (int e = 0; e < tree_.effector_count(); ++e) {
    const glm::dvec3 p = tree_effector_position(tree_, workspace_, e);
    double* f = frames_.data() + 7 * n + 3 * e;
    f[0] = p.x, f[1] = p.y, f[2] = p.z;
  }
  return frames_;
}

}  // namespace web
}  // namespace ikchain
