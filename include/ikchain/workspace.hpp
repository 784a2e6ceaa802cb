// Caller-owned scratch memory for solves. Sized once for a chain (reset() allocates); a solve on a
// chain and goal count that fit() only reads and writes these buffers, so it allocates nothing.
#pragma once
#include <vector>

#include <Eigen/Dense>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "ikchain/deadline.hpp"
#include "ikchain/goal.hpp"

namespace ikchain {

class Chain;

struct Workspace {
  Workspace() = default;
  explicit Workspace(const Chain& chain, int max_goals = 4) { reset(chain, max_goals); }

  // Allocates every buffer for `chain` and up to `max_goals` goals. Not for the per-frame path.
  void reset(const Chain& chain, int max_goals = 4);
  bool fits(const Chain& chain, int goal_count) const;

  int max_goals = 0;
  int joints = 0;
  int dofs = 0;

  // The running solve's time budget (solve() arms it from SolverOptions::time_budget_usec).
  Deadline deadline;

  // Forward kinematics (forward_kinematics() fills these), base space.
  std::vector<glm::dvec3> joint_origins;        // o_i
  std::vector<glm::dquat> joint_orientations;   // Q_i
  std::vector<glm::dquat> joint_pre_rotations;  // Q_{i-1} * rest_rotation_i: the frame a joint's motion is in
  glm::dvec3 tip{0.0};
  std::vector<glm::dvec3> dof_axes;             // base-frame rotation axis of each DOF (compute_dof_axes())
  // A trial pose's joint origins and DOF axes (the Jacobian solvers' fused FK writes these, and
  // swaps them with joint_origins / dof_axes when the trial is accepted: the accepted pose's stay
  // intact while trials are evaluated).
  std::vector<glm::dvec3> trial_joint_origins;
  std::vector<glm::dvec3> trial_dof_axes;

  // Linear algebra scratch. Rows: 3 per goal; columns: one per DOF.
  Eigen::MatrixXd jacobian;        // (3*max_goals) x dofs
  Eigen::VectorXd residual;        // 3*max_goals
  Eigen::VectorXd residual_trial;  // 3*max_goals
  Eigen::MatrixXd goal_square;     // (3*max_goals)^2, e.g. J J^T
  Eigen::VectorXd goal_vec;        // 3*max_goals
  Eigen::MatrixXd dof_square;      // dofs x dofs, e.g. BFGS inverse Hessian
  std::vector<Goal> softened_goals;  // max_goals: the goals with SolverOptions::soft_reach applied
  Eigen::VectorXd params_backup;   // the caller's params, restored on failure
  Eigen::VectorXd params_start;    // a budget-bound solve's start pose, as measured (solve.cpp)
  Eigen::VectorXd params_trial;
  Eigen::VectorXd params_best;   // the best pose a solve has seen (solvers/stuck.hpp)
  Eigen::VectorXd params_kept;   // BFGS: the line search's best acceptable point
  Eigen::VectorXd params_restart_best;  // the best pose over the restarts of one solve
  Eigen::VectorXd step;
  Eigen::VectorXd gradient;
  Eigen::VectorXd gradient_trial;
  // Two dofs-long scratch vectors, each solver's own role (so they are not named by one):
  //   dof_vec_a: DLS the second-order correction; pinv t = V^T e (or W^T g); BFGS the gradient at
  //              the line search's point; the escapes' null-space coefficients (stuck.hpp)
  //   dof_vec_b: pinv y = V f t; BFGS the gradient with its frozen entries removed, then the
  //              inverse Hessian update's scratch; the escapes' move (stuck.hpp)
  Eigen::VectorXd dof_vec_a;
  Eigen::VectorXd dof_vec_b;
  // Points along the chain, joints + tip: where forward kinematics of the current params puts them
  // (FABRIK), and the points the chain is aimed at (geometric::aim_chain_at_points: FABRIK's
  // forward-reaching stage, CCD's straight line toward an out-of-reach target).
  std::vector<glm::dvec3> points_current;
  std::vector<glm::dvec3> points_aim;
};

}  // namespace ikchain
