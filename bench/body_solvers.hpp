// The solvers of the body benchmark behind one call: the stack of independent single-chain solves
// (chain_stack.cpp, today's API) and the coupled tree solvers (body_tree.cpp, once the core has
// them). Each poses a whole body (body::Model params) so that its six effectors meet their targets.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "body_model.hpp"
#include "ikchain/options.hpp"

namespace body {

// Per effector: the world (base-space) pose to reach, m.
struct Targets {
  glm::dvec3 position[kEffectorCount];
  glm::dquat orientation[kEffectorCount];
};

// The targets a posed body meets exactly: each effector's pose in `pose` (a recorded frame's, the rest's).
inline Targets targets_at(const Model& m, const Pose& pose) {
  Targets t;
  for (int e = 0; e < kEffectorCount; ++e) {
    t.position[e] = effector_position(m, pose, e);
    t.orientation[e] = effector_orientation(m, pose, e);
  }
  return t;
}

class BodySolver {
 public:
  virtual ~BodySolver() = default;
  // What body.json's `solver` field says: "chain_stack_dls", or the tree solver's id ("dls").
  virtual std::string id() const = 0;
  // Moves `params` (Model::dof_count entries, the start pose) toward the targets. Returns false
  // when the solver refused the input (`note` says why); `iterations` sums every solve it made.
  virtual bool solve(const Targets& targets, double* params, int& iterations, std::string& note) = 0;
};

// The stack: the root placed at the hips target, then spine -> head, both arms from the collar
// (based on the solved chest), both legs; each chain a separate ikchain::solve() with `kind`, its
// base frame the current pose of its first joint's parent, the 6-D goal of its tip as
// pose_goals() makes it (the chain's length as the characteristic length).
std::unique_ptr<BodySolver> make_chain_stack(const Model& model, ikchain::SolverKind kind,
                                             const ikchain::SolverOptions& options);

// One BodySolver per core solver that takes trees (solve_tree), in solver-table order; empty while
// the core has no tree solver (the bench is then built without IKCHAIN_BENCH_HAS_TREE). `note`
// gets why a tree could not be built.
std::vector<std::unique_ptr<BodySolver>> make_tree_solvers(const Model& model,
                                                           const ikchain::SolverOptions& options,
                                                           std::string& note);
bool tree_solvers_available();

}  // namespace body
