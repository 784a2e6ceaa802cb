// The coupled tree solvers in the body benchmark: the body as one ikchain::Tree (every BVH joint a
// ball, the root floating, the rig's motion costs and posture: body_model.hpp), six 6-D effector
// goals in one solve_tree() call. Compiled with
// IKCHAIN_BENCH_HAS_TREE only when the core has the tree solver (bench/SConscript checks for
// src/core/tree.cpp); without it make_tree_solvers() returns no solver and body.json holds the
// chain stack's rows alone.
#include "body_solvers.hpp"

#ifdef IKCHAIN_BENCH_HAS_TREE
#include <cmath>

#include <Eigen/Dense>

#include "ikchain/so3.hpp"
#include "ikchain/solve.hpp"
#include "ikchain/tree.hpp"
#include "ikchain/tree_solve.hpp"
#endif

namespace body {

#ifdef IKCHAIN_BENCH_HAS_TREE
namespace {

// Priority levels: the contacts (hips, feet) first, hands and head in their null space, as issue
// 14 suggests (1: feet and hips, 2: hands and head).
int level_of(int e) { return (e == kHips || e == kLeftFoot || e == kRightFoot) ? 1 : 2; }

// The orientation goal's characteristic length (Goal::pose): the stack's chain for that effector
// (so both weigh a radian alike), for the hips the spine chain's.
double characteristic_length(const Model& m, int e) {
  for (const ChainSpec& c : m.chains)
    if (c.effector == e || (e == kHips && c.effector == kHead)) {
      double len = glm::length(m.effectors[c.effector].offset_m);
      for (size_t k = 1; k < c.joints.size(); ++k) len += glm::length(m.offset_m[c.joints[k]]);
      return len;
    }
  return 1.0;
}

class TreeBody : public BodySolver {
 public:
  // with_posture: the problem holds the rig's posture task (body_model.hpp: the neutral pose at
  // each class's stiffness; the root's 6 params, which the hips goal fixes anyway, have none),
  // given one step a solve (posture_iterations 1), as a tracking game character runs it (IKBody
  // does the same): every frame's first step both follows the targets and pulls toward the
  // posture, and a cold frame's posture step comes once its steps have arrived near the goals.
  // Without it the row is named "<solver>_no_posture".
  TreeBody(const Model& m, std::shared_ptr<const ikchain::Tree> tree, ikchain::SolverKind kind,
           const ikchain::SolverOptions& o, bool with_posture)
      : tree_holder_(std::move(tree)), tree_(*tree_holder_), kind_(kind), options_(o),
        ws_(tree_, 2 * kEffectorCount), params_(Eigen::VectorXd::Zero(tree_.dof_count())) {
    for (int e = 0; e < kEffectorCount; ++e) length_[e] = characteristic_length(m, e);
    if (with_posture) {
      posture_.assign(tree_.dof_count(), 0.0);
      neutral_params(m, posture_.data());
      posture_stiffness_.assign(tree_.dof_count(), 0.0);
      for (int j = 1; j < m.joint_count; ++j)
        for (int d = 0; d < 3; ++d) posture_stiffness_[m.dof_offset(j) + d] = posture_stiffness_of(m.joint_class[j]);
    }
  }
  std::string id() const override {
    return std::string(ikchain::to_string(kind_)) + (posture_.empty() ? "_no_posture" : "");
  }

  void set_goals(const Targets& t) {
    for (int e = 0; e < kEffectorCount; ++e) {
      const auto pose = ikchain::Goal::pose(t.position[e], t.orientation[e], length_[e], e);
      goals_[2 * e] = {pose[0], level_of(e)};
      goals_[2 * e + 1] = {pose[1], level_of(e)};
    }
  }

  ikchain::TreeProblem problem() const {
    ikchain::TreeProblem p;
    p.goals = ikchain::Span<const ikchain::TreeGoal>(goals_, 2 * kEffectorCount);
    p.posture = ikchain::Span<const double>(posture_.data(), static_cast<int>(posture_.size()));
    p.posture_stiffness =
        ikchain::Span<const double>(posture_stiffness_.data(), static_cast<int>(posture_stiffness_.size()));
    p.posture_iterations = 1;
    return p;
  }

  ikchain::Message validate(const Targets& t) {
    set_goals(t);
    const ikchain::TreeProblem problem = this->problem();
    return ikchain::validate_tree_inputs(kind_, tree_, problem, options_, ws_, params_);
  }

  bool solve(const Targets& t, double* params, int& iterations, std::string& note) override {
    set_goals(t);
    const ikchain::TreeProblem problem = this->problem();
    Eigen::Map<Eigen::VectorXd> q(params, tree_.dof_count());
    const ikchain::TreeSolveResult r = ikchain::solve_tree(kind_, tree_, problem, options_, ws_, q);
    iterations = r.summary.iterations;
    if (!r.usable()) {
      note = r.summary.message.c_str();
      return false;
    }
    return true;
  }

 private:
  std::shared_ptr<const ikchain::Tree> tree_holder_;  // shared by every solver of one model
  const ikchain::Tree& tree_;
  ikchain::SolverKind kind_;
  ikchain::SolverOptions options_;
  ikchain::TreeWorkspace ws_;
  Eigen::VectorXd params_;
  ikchain::TreeGoal goals_[2 * kEffectorCount];
  std::vector<double> posture_, posture_stiffness_;  // empty: no posture task
  double length_[kEffectorCount];
};

}  // namespace

bool tree_solvers_available() { return true; }

std::vector<std::unique_ptr<BodySolver>> make_tree_solvers(const Model& m, const ikchain::SolverOptions& options,
                                                           std::string& note) {
  std::vector<std::unique_ptr<BodySolver>> out;
  auto tree = std::make_shared<ikchain::Tree>();
  ikchain::TreeBuilder b;
  for (int j = 0; j < m.joint_count; ++j) {
    ikchain::TreeJointDesc d;
    d.parent = m.parent[j];
    d.type = ikchain::JointType::kBall;
    d.offset_in_parent = m.offset_m[j];
    d.limits = m.limits[j];
    d.motion_cost = motion_cost_of(m.joint_class[j]);
    b.add_joint(d);
  }
  for (int e = 0; e < kEffectorCount; ++e) {
    ikchain::TreeEffectorDesc d;
    d.joint = m.effectors[e].joint;
    d.offset = m.effectors[e].offset_m;
    b.add_effector(d);
  }
  b.set_floating_root(true);
  const ikchain::TreeBuildError err = b.build(*tree);
  if (!err.ok()) {
    note = std::string("tree build: ") + err.message.c_str();
    return out;
  }
  for (int j = 0; j < m.joint_count; ++j)
    if (tree->dof_offset(j) != m.dof_offset(j) || tree->dof_count() != m.dof_count()) {
      note = "tree params layout differs from the model's (dof_offset)";
      return out;
    }
  // The tree's forward kinematics must be the model's (the recording's): same params, same
  // effector poses, on a pose with every joint turned.
  {
    std::vector<double> q(m.dof_count());
    for (int i = 0; i < m.dof_count(); ++i) q[i] = 0.3 * std::sin(1.0 + i);
    Pose p;
    forward_kinematics(m, q.data(), p);
    ikchain::TreeWorkspace ws(*tree, 2 * kEffectorCount);
    ikchain::tree_forward_kinematics(*tree, q.data(), ws);
    for (int e = 0; e < kEffectorCount; ++e) {
      const double dp = glm::length(ikchain::tree_effector_position(*tree, ws, e) - effector_position(m, p, e));
      const double dq = 1.0 - std::abs(glm::dot(ikchain::tree_effector_orientation(*tree, ws, e),
                                                effector_orientation(m, p, e)));
      if (!(dp < 1e-9 && dq < 1e-12)) {
        note = std::string("tree FK differs from the model's at effector ") + to_string(static_cast<Effector>(e));
        return out;
      }
    }
  }
  Pose pose;
  std::vector<double> zero(m.dof_count(), 0.0);
  forward_kinematics(m, zero.data(), pose);
  const Targets rest = targets_at(m, pose);
  for (const ikchain::SolverInfo& info : ikchain::solver_table()) {
    auto s = std::make_unique<TreeBody>(m, tree, info.kind, options, /*with_posture=*/true);
    const ikchain::Message msg = s->validate(rest);
    if (!msg.empty()) {
      note += std::string(note.empty() ? "" : "; ") + info.id + ": " + msg.c_str();
      continue;
    }
    out.push_back(std::move(s));
    // DLS again without the posture: what the posture task does for the redundancy (MPJPE).
    if (info.kind == ikchain::SolverKind::kDLS)
      out.push_back(std::make_unique<TreeBody>(m, tree, info.kind, options, /*with_posture=*/false));
  }
  return out;
}

#else

bool tree_solvers_available() { return false; }

std::vector<std::unique_ptr<BodySolver>> make_tree_solvers(const Model&, const ikchain::SolverOptions&,
                                                           std::string& note) {
  note = "the core has no tree solver yet (src/core/tree.cpp missing when this bench was built)";
  return {};
}

#endif

}  // namespace body
