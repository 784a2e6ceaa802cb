// IKChain: a SkeletonModifier3D that moves a chain of bones so that tip_bone's origin reaches a
// target Node3D, using one of the core's solvers (src/core).
//
// Chain convention (like Godot's TwoBoneIK3D): the moving joints are the bones from root_bone
// down to the PARENT of tip_bone; the effector is tip_bone's origin. Joints are ball joints.
// The chain's base space is root_bone's parent bone (skeleton space when root_bone has none).
#pragma once

#include <gdextension_interface.h>

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "core/ikchain.hpp"

namespace ikchain::godot {

class IKChain {
 public:
  enum Solver : int64_t {
    SOLVER_TWO_BONE = 0,
    SOLVER_CCD = 1,
    SOLVER_JACOBIAN = 2,
    SOLVER_DLS = 3,
    SOLVER_BFGS = 4,
    SOLVER_FABRIK = 5,
  };
  static constexpr int64_t kDefaultMaxIterations = 64;
  static constexpr double kDefaultTolerance = 1e-4;  // m

  // Class-wide StringNames: created at SCENE init, destroyed at SCENE deinit.
  static void register_class(gdx::ClassRecord& record);
  static void unregister_class();

  explicit IKChain(gdx::ObjectPtr owner);

  // Properties.
  void set_root_bone(const gdx::String& name);
  gdx::String get_root_bone() const;
  void set_tip_bone(const gdx::String& name);
  gdx::String get_tip_bone() const;
  void set_target(const gdx::NodePath& path);
  gdx::NodePath get_target() const;
  void set_solver(int64_t solver);
  int64_t get_solver() const { return solver_; }
  void set_max_iterations(int64_t n);
  int64_t get_max_iterations() const { return max_iterations_; }
  void set_tolerance(double meters);
  double get_tolerance() const { return tolerance_; }
  void set_deterministic(bool on);
  bool is_deterministic() const { return deterministic_; }

  // The last solve: reason, iterations, initial_error, final_error, microseconds, usable.
  gdx::Dictionary get_last_result() const;

  // Engine callbacks.
  bool validate_property(GDExtensionPropertyInfo& property);
  void process_modification(double delta);
  // Godot never runs the modification without a Skeleton3D parent, so that problem is reported
  // when the node enters the tree.
  void notification(int32_t what);
  gdx::PackedStringArray get_configuration_warnings() const;
  void skeleton_changed();  // marks the chain dirty (virtual _skeleton_changed and skeleton signals)

 private:
  struct Problem {
    std::string key;  // property it concerns
    std::string message;
  };

  void mark_dirty();
  // Checks bones, solver and target; `problems` gets one entry per problem, with a fix.
  void collect_chain_problems(gdx::ObjectPtr skeleton, std::vector<Problem>& problems,
                              std::vector<int>* joint_bones, int* tip_bone) const;
  void collect_target_problems(std::vector<Problem>& problems) const;
  void rebuild(gdx::ObjectPtr skeleton);
  // Connects the skeleton's bone_list_changed and rest_updated to skeleton_changed().
  void watch_skeleton(gdx::ObjectPtr skeleton);
  void report_once(const char* message);
  void forget_reports_except(const std::vector<Problem>& still_active);
  void set_invalid_result();

  gdx::ObjectPtr owner_;

  // Settings.
  std::string root_bone_;
  std::string tip_bone_;
  gdx::NodePath target_;
  int64_t solver_ = SOLVER_DLS;
  int64_t max_iterations_ = kDefaultMaxIterations;
  double tolerance_ = kDefaultTolerance;
  bool deterministic_ = false;

  // Built lazily from the skeleton (rebuild()); the per-frame path only reads these.
  bool dirty_ = true;
  bool chain_ok_ = false;
  uint64_t built_skeleton_id_ = 0;
  int64_t built_bone_count_ = -1;
  std::vector<Problem> chain_problems_;
  std::vector<int> joint_bones_;  // skeleton bone index of joint i (root first)
  int base_bone_ = -1;            // root_bone's parent, -1 = skeleton space
  Chain chain_;
  Workspace workspace_;
  SolverOptions options_;
  Eigen::VectorXd params_;
  std::vector<gdx::Quaternion> new_rotations_;
  Goal goal_;

  // Problems already printed (each distinct one once, until it goes away).
  std::vector<std::string> reported_;

  // Last solve.
  bool has_result_ = false;
  SolveResult last_;
};

}  // namespace ikchain::godot
