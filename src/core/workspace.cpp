#include "ikchain/workspace.hpp"

#include "ikchain/chain.hpp"

namespace ikchain {

void Workspace::reset(const Chain& chain, int goals) {
  max_goals = goals < 1 ? 1 : goals;
  joints = chain.joint_count();
  dofs = chain.dof_count();
  const int rows = 3 * max_goals;
  joint_origins.assign(joints, glm::dvec3(0.0));
  joint_orientations.assign(joints, glm::dquat(1, 0, 0, 0));
  joint_pre_rotations.assign(joints, glm::dquat(1, 0, 0, 0));
  dof_axes.assign(dofs, glm::dvec3(0.0));
  trial_joint_origins.assign(joints, glm::dvec3(0.0));
  trial_dof_axes.assign(dofs, glm::dvec3(0.0));
  jacobian.setZero(rows, dofs);
  residual.setZero(rows);
  residual_trial.setZero(rows);
  goal_square.setZero(rows, rows);
  goal_vec.setZero(rows);
  dof_square.setZero(dofs, dofs);
  for (Eigen::VectorXd* v : {&params_backup, &params_start, &params_trial, &params_best, &params_kept, &params_restart_best, &step, &gradient,
                             &gradient_trial, &dof_vec_a, &dof_vec_b})
    v->setZero(dofs);
  softened_goals.assign(max_goals, Goal());
  points_current.assign(joints + 1, glm::dvec3(0.0));
  points_aim.assign(joints + 1, glm::dvec3(0.0));
}

bool Workspace::fits(const Chain& chain, int goal_count) const {
  return joints == chain.joint_count() && dofs == chain.dof_count() && goal_count <= max_goals;
}

}  // namespace ikchain
