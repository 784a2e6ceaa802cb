// IKChain: a SkeletonModifier3D that moves a chain of bones of its parent Skeleton3D toward goals
// (the target's position, its rotation, an aim, extra goals on inner bones), with one of the
// core's solvers (src/core). The skeleton <-> chain mapping lives in skeleton_chain.*, what it shares
// with IKBody in ik_modifier.*; this class is ik_chain.cpp (properties, script API),
// ik_chain_config.cpp (the configuration pass, rebuild, warnings) and ik_chain_frame.cpp (per frame).
//
// Chain convention (like Godot's TwoBoneIK3D): the joints are the bones from root_bone down to
// the PARENT of tip_bone and the effector is tip_bone's origin; with extend_tip_bone, tip_bone is
// a joint too and the effector sits tip_extension_length along tip_extension_axis from it.
// The chain's base space is root_bone's parent bone (skeleton space when root_bone has none).
#pragma once

#include <gdextension_interface.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "ikchain/ikchain.hpp"
#include "ik_modifier.hpp"
#include "skeleton_chain.hpp"

namespace ikchain::godot {

class IKChain : public IKModifier {
 public:
  enum GoalMode : int64_t { GOAL_MODE_REACH = 0, GOAL_MODE_AIM = 1 };
  enum Axis : int64_t {
    AXIS_PLUS_X = 0,
    AXIS_MINUS_X = 1,
    AXIS_PLUS_Y = 2,
    AXIS_MINUS_Y = 3,
    AXIS_PLUS_Z = 4,
    AXIS_MINUS_Z = 5,
  };
  // The Solver values are the table in solver_choice.hpp (saved in scenes: never renumbered).
  static constexpr int64_t kDefaultMaxIterations = 64;

  // Class-wide StringNames: created at SCENE init, destroyed at SCENE deinit.
  static void register_class(gdx::ClassRecord& record);
  static void unregister_class();

  explicit IKChain(gdx::ObjectPtr owner);

  // ---- properties
  void set_tip_bone(const gdx::String& name);
  gdx::String get_tip_bone() const;
  void set_extend_tip_bone(bool on);
  bool is_extend_tip_bone() const { return extend_tip_bone_; }
  void set_tip_extension_axis(int64_t axis);
  int64_t get_tip_extension_axis() const { return tip_extension_axis_; }
  void set_tip_extension_length(double length);
  double get_tip_extension_length() const { return tip_extension_length_; }
  void set_target(const gdx::NodePath& path);
  gdx::NodePath get_target() const { return target_; }
  void set_use_target_transform(bool on);
  bool is_using_target_transform() const { return use_target_transform_; }
  void set_target_transform(const gdx::Transform3D& transform);
  gdx::Transform3D get_target_transform() const { return target_transform_; }
  void set_goal_mode(int64_t mode);
  int64_t get_goal_mode() const { return goal_mode_; }
  void set_aim_axis(const gdx::Vector3& axis);
  gdx::Vector3 get_aim_axis() const { return aim_axis_; }
  void set_use_target_rotation(bool on);
  bool is_using_target_rotation() const { return use_target_rotation_; }
  void set_rotation_weight(double weight);
  double get_rotation_weight() const { return rotation_weight_; }
  void set_pole_target(const gdx::NodePath& path);
  gdx::NodePath get_pole_target() const { return pole_target_; }
  void set_joints(const gdx::Array& joints);
  gdx::Array get_joints() const { return joints_; }
  void set_goals(const gdx::Array& goals);
  gdx::Array get_goals() const { return goals_; }
  void set_soft_reach(double units);
  double get_soft_reach() const { return soft_reach_; }
  void set_max_restarts(int64_t n);
  int64_t get_max_restarts() const { return max_restarts_; }
  void set_restart_seed(int64_t seed);
  int64_t get_restart_seed() const { return restart_seed_; }

  // ---- script API
  // The last solve: see get_last_result() in the class reference for the keys.
  gdx::Dictionary get_last_result() const;
  // The same values without building a Dictionary (per-frame readers): each equals the key of
  // get_last_result() it is named after.
  gdx::String get_last_reason() const;
  bool is_last_usable() const;
  bool is_last_reached() const;
  int64_t get_last_iterations() const { return int64_t(last_.iterations); }
  int64_t get_last_joints_at_limit() const { return int64_t(last_.joints_at_limit); }
  double get_last_initial_error() const { return last_.initial_error; }
  double get_last_final_error() const;
  double get_last_position_error() const;
  double get_last_orientation_error() const;
  double get_last_microseconds() const { return last_.elapsed_us; }
  // Solves and writes the pose now (tools, tests); returns get_last_result().
  gdx::Dictionary solve_now();
  // Skeleton bone indices of the joints, root first (empty while the chain is not valid).
  gdx::PackedInt32Array get_chain_bones();

  // ---- engine callbacks
  bool validate_property(GDExtensionPropertyInfo& property);
  gdx::PackedStringArray get_configuration_warnings();

 private:
  struct Problem {
    std::string property;  // the property to fix
    std::string message;
  };
  // An IKChainGoal resolved against the chain: its effector index and kind.
  struct ExtraGoal {
    int effector = 0;
    GoalKind kind = GoalKind::kPosition;
    double weight = 1.0;
    glm::dvec3 axis_in_effector{0.0, 1.0, 0.0};
    gdx::NodePath target;
  };

  // Bones, joint settings and the solver's fit to the goals; one entry per problem, with its fix.
  void collect_chain_problems(const gdx::Skeleton3D& skeleton, std::vector<Problem>& problems,
                              SkeletonChainDesc* desc) const;
  // The main goal (target, pole, aim axis) and what the solver can pursue of it.
  void collect_goal_problems(std::vector<Problem>& problems) const;
  // The goals array, for the warnings and the rebuild alike: each IKChainGoal whose bone `chain`
  // can move goes into `goals` (when given), each element that is not usable gets a problem with
  // its fix. A goal on a bone the chain cannot move goes to `unmovable` (the chain must not run
  // without it; checked only when `chain` is valid); any other problem to `problems` (the element
  // is left out, or a goal without a target node is skipped per frame).
  void resolve_goals(const SkeletonChain& chain, std::vector<ExtraGoal>* goals, std::vector<Problem>& problems,
                     std::vector<Problem>& unmovable) const;
  // What the one configuration pass (configure()) makes of the settings; the rebuild builds from
  // it, the warnings list it.
  struct Config {
    std::vector<Problem> fatal;  // the chain cannot run (the rebuild stops on the first)
    std::vector<Problem> notes;  // shown; the chain runs without what they spoil
    SkeletonChainDesc desc;
    std::vector<ExtraGoal> goals;
  };
  // The one configuration pass, for the rebuild (build: the chain is built from it) and the
  // warnings (the chain as built: they rebuild it first when stale, never build one of their own).
  void configure(const gdx::Skeleton3D& skeleton, bool build, Config& config);
  void rebuild(const gdx::Skeleton3D& skeleton);
  bool needs_rebuild(const gdx::Skeleton3D& skeleton) const;
  bool ancestry_changed(const gdx::Skeleton3D& skeleton) const;
  void record_ancestry(const gdx::Skeleton3D& skeleton);
  // The solve of one frame; false when nothing was written.
  bool run(const gdx::Skeleton3D& skeleton) override;
  bool assemble_goals(const gdx::Skeleton3D& skeleton);
  SolverKind resolved_solver() const;

  // Runtime problems (a non-finite target, the solver refusing the input): printed once per
  // spell, forgotten as soon as a frame goes well again.
  void report_runtime(const char* message);
  void clear_runtime_reports() { runtime_reported_.clear(); }
  void set_invalid_result(const char* message) override;

  // Settings.
  std::string tip_bone_;
  bool extend_tip_bone_ = false;
  int64_t tip_extension_axis_ = AXIS_PLUS_Y;
  double tip_extension_length_ = 0.0;
  gdx::NodePath target_;
  bool use_target_transform_ = false;
  gdx::Transform3D target_transform_;
  int64_t goal_mode_ = GOAL_MODE_REACH;
  gdx::Vector3 aim_axis_{0, 1, 0};
  bool use_target_rotation_ = false;
  double rotation_weight_ = 1.0;
  gdx::NodePath pole_target_;
  gdx::Array joints_;
  gdx::Array goals_;
  double soft_reach_ = 0.0;  // skeleton units; 0 = off
  int64_t max_restarts_ = 0;
  int64_t restart_seed_ = 1;

  // Built lazily from the skeleton (rebuild()); the per-frame path only reads these.
  bool chain_ok_ = false;
  bool mapping_built_ = false;  // mapping_ holds the chain of the last rebuild's settings
  uint64_t built_skeleton_id_ = 0;
  int64_t built_skeleton_version_ = -1;
  // The arrays' sizes as built: an element appended in place (ik.joints.append(j)) calls no setter.
  int64_t built_joints_size_ = 0, built_goals_size_ = 0;
  std::vector<Problem> chain_problems_;
  SkeletonChain mapping_;  // skeleton <-> chain
  int base_bone_ = -1;     // root_bone's parent, -1 = skeleton space
  gdx::String root_bone_name_, tip_bone_name_;  // for the per-frame rename check (no allocation)
  int root_bone_index_ = -1, tip_bone_index_ = -1;
  // tip_bone's ancestry as built: (bone, its parent) from tip_bone up to root_bone (or the top of
  // the skeleton when root_bone is not an ancestor). set_bone_parent() can reshape the chain
  // without touching the bone count or the skeleton's version, so the per-frame check compares
  // these parents (a few ptrcalls, no allocation).
  std::vector<std::pair<int, int>> built_ancestry_;
  // Per-frame buffers, sized at rebuild.
  std::vector<BonePose> bone_poses_;
  std::vector<glm::dquat> old_rotations_, new_rotations_, blended_rotations_;
  Workspace workspace_;
  Eigen::VectorXd params_;
  // Skeleton3D restores the animated pose before modifiers run, so the pose read each frame is the
  // animation's: a warm start continues from our own last solution instead (frame continuity).
  bool params_from_last_solve_ = false;
  // new_rotations_ hold the last pose written: a skipped frame writes them again, since the
  // skeleton would otherwise show the animated pose instead of the last good one.
  bool have_good_pose_ = false;
  std::vector<Goal> goal_buffer_;  // sized at rebuild; the per-frame path fills it in place
  int goal_count_ = 0;
  std::vector<ExtraGoal> extra_goals_;  // resolved at rebuild

  std::vector<std::string> runtime_reported_;
  // A problem that does not stop the frame (the solve goes on without the part it spoils): one
  // message when it starts, none while it lasts, again after a frame without it.
  struct Spell {
    bool reported = false;
    void report(const char* message);
    void clear() { reported = false; }
  };
  Spell pole_spell_, target_basis_spell_, goal_basis_spell_;

  // Last solve.
  bool has_result_ = false;
  SolveResult last_;
  SolverKind last_solver_ = SolverKind::kDLS;
  GoalErrors written_;  // of the pose the skeleton ends with (after its influence blend)
  bool solver_refused_ = false;  // the last solve was kInvalidInput from the solver itself
};

}  // namespace ikchain::godot
