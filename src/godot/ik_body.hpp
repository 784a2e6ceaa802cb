// IKBody: a SkeletonModifier3D that solves every bone under root_bone that supports an effector as
// one tree (the core's solve_tree: coupled, with strict priority levels), starting each frame from
// the incoming (animated) pose, so an AnimationPlayer's output is corrected rather than replaced.
// The skeleton <-> tree mapping lives in skeleton_tree.*, what it shares with IKChain in
// ik_modifier.*; this class is ik_body.cpp (properties, script API), ik_body_config.cpp (the
// configuration pass, rebuild, warnings), ik_body_frame.cpp (per frame) and ik_body_humanoid.cpp.
#pragma once

#include <gdextension_interface.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "ikchain/ikchain.hpp"
#include "ikchain/tree_solve.hpp"
#include "ik_modifier.hpp"
#include "skeleton_tree.hpp"

namespace ikchain::godot {

class IKBodyEffector;

class IKBody : public IKModifier {
 public:
  // The Solver values are IKChain.Solver's (solver_choice.hpp): saved in scenes, never renumbered.
  // Only the solvers whose core solver-table row says `trees` are offered.
  static constexpr int64_t kDefaultMaxIterations = 100;
  // The steps of a frame that carry the posture (TreeProblem::posture_iterations): one, riding on
  // the frame's first step near the goals, so a tracking frame often needs one linearisation; the
  // joints' posture_stiffness is then the share of the way back to the incoming pose a frame takes.
  static constexpr int kPostureIterations = 1;

  static void register_class(gdx::ClassRecord& record);
  static void unregister_class();

  explicit IKBody(gdx::ObjectPtr owner);

  // ---- properties
  void set_floating_root(bool on);
  bool is_floating_root() const { return floating_root_; }
  void set_effectors(const gdx::Array& effectors);
  gdx::Array get_effectors() const { return effectors_; }
  void set_joints(const gdx::Array& joints);
  gdx::Array get_joints() const { return joints_; }

  // ---- script API
  gdx::Dictionary get_last_result() const;
  // The same values as get_last_result()'s keys, without building a Dictionary.
  gdx::String get_last_reason() const;
  bool is_last_usable() const;
  int64_t get_last_iterations() const { return int64_t(last_.summary.iterations); }
  double get_last_usec() const { return last_.summary.elapsed_us; }
  double get_last_position_error() const;
  double get_last_orientation_error() const;
  // Per effector (the index in `effectors`): its error in the last solve; NaN when it took no part.
  double get_last_effector_position_error(int64_t index) const;
  double get_last_effector_rotation_error(int64_t index) const;
  // Level 1..4: every goal of that level within tolerance in the last solve.
  bool is_last_level_met(int64_t level) const;
  gdx::Dictionary solve_now();
  // Skeleton bone indices the tree solves, root first (empty while not configured).
  gdx::PackedInt32Array get_body_bones();
  // Creates the humanoid rig for SkeletonProfileHumanoid bone names (see the class reference).
  bool setup_humanoid();

  // ---- engine callbacks
  bool validate_property(GDExtensionPropertyInfo& property);
  gdx::PackedStringArray get_configuration_warnings();

 private:
  struct Problem {
    std::string property;
    std::string message;
    bool fatal = true;  // false: the body still runs (without the part it spoils)
  };
  // An enabled, usable effector resolved against the tree.
  struct Slot {
    IKBodyEffector* effector = nullptr;
    int index = 0;          // in effectors[]
    int core_effector = 0;  // tree effector
    int skeleton_bone = -1;
    int pole_end = -1;      // with a usable pole_target: the mapping bone the limb ends at
    std::string bone;
    bool look = false;  // look mode: an aim goal (kAimAt) at the target's origin
    // With look_shares: the bones that share the turn (mapping indices, root-most first, the
    // effector's bone last) and their shares (same order). Empty: the solver alone spreads it.
    std::vector<double> look_share_list;  // as configured: this bone first (resolved at rebuild)
    std::vector<int> look_bones;
    std::vector<double> look_shares;
  };
  // The one configuration pass the warnings and the rebuild share: problems (each with its fix),
  // and, when asked, the tree description and the effector slots (skeleton bone indices).
  void configure(const gdx::Skeleton3D& skeleton, std::vector<Problem>& problems, SkeletonTreeDesc* desc,
                 std::vector<Slot>* slots, std::vector<gdx::Variant>* held) const;
  bool needs_rebuild(const gdx::Skeleton3D& skeleton) const;
  // An effector's target or weight edit can add or clear a warning (no target, zero weights):
  // refresh the editor's triangle (a no-op outside the editor; target_transform, the per-frame
  // setter, emits no change).
  void on_resource_changed() override {
    resources_touched_ = true;
    settings_changed();
  }
  // The joints' and effectors' identities and revisions in one number.
  uint64_t resource_revision() const;
  void rebuild(const gdx::Skeleton3D& skeleton);
  bool run(const gdx::Skeleton3D& skeleton) override;
  void report_runtime(const std::string& message);
  void set_invalid_result(const char* message) override;
  SolverKind resolved_solver() const;

  // Settings.
  bool floating_root_ = false;
  gdx::Array effectors_;
  gdx::Array joints_;

  // Built lazily (rebuild()); the per-frame path only reads these.
  bool body_ok_ = false;
  uint64_t built_skeleton_id_ = 0;
  int64_t built_skeleton_version_ = -1;
  // The joints' and effectors' revisions as built; checked only after one of them emitted `changed`.
  uint64_t built_revision_ = 0;
  mutable bool resources_touched_ = false;
  int64_t built_joints_size_ = 0;
  std::vector<Problem> body_problems_;
  std::string scale_note_;  // the built body's non-uniform scale warning (empty: none)
  SkeletonTree mapping_;
  int base_bone_ = -1;
  std::vector<Slot> slots_;
  std::vector<gdx::Variant> held_;  // references to the effectors the slots point into
  int effector_array_size_ = 0;
  // Per-frame buffers, sized at rebuild.
  std::vector<BonePose> bone_poses_;
  std::vector<glm::dquat> rotations_;
  Eigen::VectorXd params_, anim_params_, previous_anim_params_, last_params_;
  // anim_params_ are params_from_pose() of the mapping's recorded poses (false after a rebuild).
  bool anim_params_current_ = false;
  // The base frame and the two transforms it was made from (base_current_ false: make it again).
  BaseFrame base_;
  glm::dmat4 base_skeleton_global_{1.0}, base_bone_in_skeleton_{1.0};
  bool base_current_ = false;
  Eigen::VectorXd posture_;  // the start pose, limb planes turned toward their poles
  std::vector<double> posture_stiffness_;
  std::vector<TreeGoal> goals_;
  std::vector<int> goal_slot_;       // per goal: its slot
  std::vector<char> goal_rotation_;  // per goal: the orientation goal (else position)
  std::vector<int> look_goals_;      // per frame: the goals whose look is spread (capacity: slots)
  TreeWorkspace workspace_;
  bool have_last_ = false;
  // The first frame's posture settle has ended (not cut by time_budget_usec: the frames after a
  // cut one settle on from where it stopped, instead of creeping the rest a share a frame).
  bool settled_ = false;

  std::vector<std::string> runtime_reported_;
  int reports_this_frame_ = 0;

  // Last solve.
  bool has_result_ = false;
  TreeSolveResult last_;
  int last_goal_count_ = 0;
  std::vector<double> effector_position_error_, effector_rotation_error_;  // per effectors[] index
};

}  // namespace ikchain::godot
