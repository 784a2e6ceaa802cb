// The baseline of the body benchmark: today's best rig of independent single-chain solves.
#include <Eigen/Dense>

#include "body_solvers.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/solve.hpp"
#include "ikchain/workspace.hpp"

namespace body {
namespace {

class ChainStack : public BodySolver {
 public:
  ChainStack(const Model& m, ikchain::SolverKind kind, const ikchain::SolverOptions& options)
      : m_(m), kind_(kind), options_(options) {
    for (const ChainSpec& spec : m.chains) {
      ikchain::ChainBuilder b;
      for (int j : spec.joints) {
        ikchain::JointDesc d;
        d.type = ikchain::JointType::kBall;
        d.offset_translation = m.offset_m[j];
        d.limits = m.limits[j];
        b.add_joint(d);
      }
      b.set_tip_offset(m.effectors[spec.effector].offset_m);
      chains_.emplace_back();
      build_error_ = b.build(chains_.back()).message.c_str();
      if (!build_error_.empty()) build_error_ = spec.name + ": " + build_error_;
      workspaces_.emplace_back(chains_.back(), 2);
      params_.emplace_back(Eigen::VectorXd::Zero(3 * static_cast<int>(spec.joints.size())));
    }
  }

  std::string id() const override { return std::string("chain_stack_") + ikchain::to_string(kind_); }

  bool solve(const Targets& t, double* params, int& iterations, std::string& note) override {
    iterations = 0;
    if (!build_error_.empty()) {
      note = build_error_;
      return false;
    }
    // The hips where the recording has them.
    const glm::dvec3 root = t.position[kHips] - m_.offset_m[0];
    const glm::dvec3 r = ikchain::so3::log(t.orientation[kHips]);
    params[0] = root.x, params[1] = root.y, params[2] = root.z;
    params[3] = r.x, params[4] = r.y, params[5] = r.z;
    forward_kinematics(m_, params, pose_);
    for (size_t c = 0; c < m_.chains.size(); ++c) {
      const ChainSpec& spec = m_.chains[c];
      // The arms hang from the chest the spine chain just posed.
      if (c == 1) forward_kinematics(m_, params, pose_);
      const glm::dvec3& base_origin = pose_.origins[spec.base_joint];
      const glm::dquat base_inv = glm::conjugate(pose_.orientations[spec.base_joint]);
      const auto goals = ikchain::pose_goals(chains_[c], base_inv * (t.position[spec.effector] - base_origin),
                                             base_inv * t.orientation[spec.effector]);
      Eigen::VectorXd& q = params_[c];
      for (size_t k = 0; k < spec.joints.size(); ++k)
        for (int d = 0; d < 3; ++d) q[3 * k + d] = params[m_.dof_offset(spec.joints[k]) + d];
      const ikchain::SolveResult res =
          ikchain::solve(kind_, chains_[c], ikchain::Span<const ikchain::Goal>(goals.data(), 2), options_,
                         workspaces_[c], q);
      if (!res.usable()) {
        note = spec.name + ": " + res.message.c_str();
        return false;
      }
      iterations += res.iterations;
      for (size_t k = 0; k < spec.joints.size(); ++k)
        for (int d = 0; d < 3; ++d) params[m_.dof_offset(spec.joints[k]) + d] = q[3 * k + d];
    }
    return true;
  }

 private:
  const Model& m_;
  ikchain::SolverKind kind_;
  ikchain::SolverOptions options_;
  std::vector<ikchain::Chain> chains_;
  std::vector<ikchain::Workspace> workspaces_;
  std::vector<Eigen::VectorXd> params_;
  std::string build_error_;
  Pose pose_;
};

}  // namespace

std::unique_ptr<BodySolver> make_chain_stack(const Model& model, ikchain::SolverKind kind,
                                             const ikchain::SolverOptions& options) {
  return std::make_unique<ChainStack>(model, kind, options);
}

}  // namespace body
