#include "ik_chain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "ik_chain_goal.hpp"
#include "ik_chain_joint.hpp"
#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;
namespace usage = gdx::gen::PropertyUsageFlags;

namespace {

constexpr const char* kClass = "IKChain";

// The solvers come from the core's one table (solver_table(): names, capabilities); IKChain's
// values 0..5 are the SolverKind values, and Auto (6) resolves per chain (resolved_solver()).
// Only the script-facing constant names are spelled here.
static_assert(int64_t(SolverKind::kTwoBone) == IKChain::SOLVER_TWO_BONE && int64_t(SolverKind::kCCD) == IKChain::SOLVER_CCD &&
                  int64_t(SolverKind::kJacobianPinv) == IKChain::SOLVER_JACOBIAN &&
                  int64_t(SolverKind::kDLS) == IKChain::SOLVER_DLS && int64_t(SolverKind::kBFGS) == IKChain::SOLVER_BFGS &&
                  int64_t(SolverKind::kFABRIK) == IKChain::SOLVER_FABRIK && kSolverKindCount == IKChain::SOLVER_AUTO,
              "IKChain.Solver values are the core's SolverKind values, then Auto");
// TipAxis (the engine-free mapping) takes IKChain.Axis values as they are.
static_assert(int(TipAxis::kPlusX) == IKChain::AXIS_PLUS_X, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusX) == IKChain::AXIS_MINUS_X, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kPlusY) == IKChain::AXIS_PLUS_Y, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusY) == IKChain::AXIS_MINUS_Y, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kPlusZ) == IKChain::AXIS_PLUS_Z, "TipAxis follows IKChain.Axis");
static_assert(int(TipAxis::kMinusZ) == IKChain::AXIS_MINUS_Z, "TipAxis follows IKChain.Axis");

const char* solver_constant(int64_t value) {
  static constexpr const char* kNames[] = {"SOLVER_TWO_BONE", "SOLVER_CCD", "SOLVER_JACOBIAN", "SOLVER_DLS",
                                           "SOLVER_BFGS",     "SOLVER_FABRIK", "SOLVER_AUTO"};
  return kNames[value];
}

// StringNames the instances compare against; allocated at SCENE init, freed at deinit.
struct Names {
  gdx::StringName root_bone{"root_bone"};
  gdx::StringName tip_bone{"tip_bone"};
  gdx::StringName tip_extension_axis{"tip_extension_axis"};
  gdx::StringName tip_extension_length{"tip_extension_length"};
  gdx::StringName aim_axis{"aim_axis"};
  gdx::StringName use_target_rotation{"use_target_rotation"};
  gdx::StringName bone_list_changed{"bone_list_changed"};
  gdx::StringName rest_updated{"rest_updated"};
  gdx::StringName skeleton_changed{"_skeleton_changed"};
};
Names* g_names = nullptr;

// Per-frame runtime problems: constant text, so reporting them allocates nothing.
constexpr const char* kBadTarget =
    "IKChain: the target's transform is not finite; this frame was skipped and the last pose kept.";
constexpr const char* kBadBase =
    "IKChain: the skeleton's global transform (or the base bone's pose) is not invertible: a zero scale? This frame "
    "was skipped and the last pose kept.";
constexpr const char* kNonFinite = "IKChain: the solver produced a non-finite rotation; the pose was left unchanged.";
// Problems that do not stop the frame: reported once per spell (IKChain::Spell).
constexpr const char* kBadPole =
    "IKChain: pole_target's global position is not finite or absurdly far (more than 1e6 chain lengths from the "
    "root bone); the pole is ignored until it is back. Move pole_target near the limb, on the side the knee or "
    "elbow should point to.";
constexpr const char* kBadTargetBasis =
    "IKChain: the target's basis is degenerate (a zero scale?), so it has no rotation: the tip's orientation goal "
    "(use_target_rotation) is skipped, its position still reached, until the basis is valid. Give the target a "
    "non-zero scale, or turn off use_target_rotation.";
constexpr const char* kBadGoalBasis =
    "IKChain: the target of an orientation goal (goals[], kind Orientation) has a degenerate basis (a zero "
    "scale?), so it has no rotation: that goal is skipped until the basis is valid. Give its target a non-zero "
    "scale.";
// A pole farther than this many chain lengths from the root gives no usable direction (its
// perpendicular part drowns in rounding): treated like a non-finite one.
constexpr double kMaxPoleDistanceInChainLengths = 1e6;

const char* reason_name(TerminationReason r) {
  switch (r) {
    case TerminationReason::kConverged: return "converged";
    case TerminationReason::kMaxIterations: return "max_iterations";
    case TerminationReason::kStalled: return "stalled";
    case TerminationReason::kUnreachable: return "unreachable";
    case TerminationReason::kInvalidInput: return "invalid_input";
  }
  return "invalid_input";
}

gdx::String text(const std::string& s) { return gdx::String(std::string_view(s)); }

bool finite(const gdx::Transform3D& t) {
  const glm::dmat4 m = gdx::to_glm(t);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 3; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

}  // namespace

// ---------------------------------------------------------------- registration

void IKChain::register_class(gdx::ClassRecord& record) {
  g_names = new Names();
  gdx::ClassBuilder<IKChain> b(record);
  b.register_class();

  b.method("set_root_bone", &IKChain::set_root_bone, {"bone_name"});
  b.method("get_root_bone", &IKChain::get_root_bone);
  b.method("set_tip_bone", &IKChain::set_tip_bone, {"bone_name"});
  b.method("get_tip_bone", &IKChain::get_tip_bone);
  b.method("set_extend_tip_bone", &IKChain::set_extend_tip_bone, {"enabled"});
  b.method("is_extend_tip_bone", &IKChain::is_extend_tip_bone);
  b.method("set_tip_extension_axis", &IKChain::set_tip_extension_axis, {"axis"});
  b.method("get_tip_extension_axis", &IKChain::get_tip_extension_axis, {}, {"IKChain.Axis"});
  b.method("set_tip_extension_length", &IKChain::set_tip_extension_length, {"length"});
  b.method("get_tip_extension_length", &IKChain::get_tip_extension_length);
  b.method("set_target", &IKChain::set_target, {"path"});
  b.method("get_target", &IKChain::get_target);
  b.method("set_use_target_transform", &IKChain::set_use_target_transform, {"enabled"});
  b.method("is_using_target_transform", &IKChain::is_using_target_transform);
  b.method("set_target_transform", &IKChain::set_target_transform, {"transform"});
  b.method("get_target_transform", &IKChain::get_target_transform);
  b.method("set_solver", &IKChain::set_solver, {"solver"});
  b.method("get_solver", &IKChain::get_solver, {}, {"IKChain.Solver"});
  b.method("set_goal_mode", &IKChain::set_goal_mode, {"mode"});
  b.method("get_goal_mode", &IKChain::get_goal_mode, {}, {"IKChain.GoalMode"});
  b.method("set_aim_axis", &IKChain::set_aim_axis, {"axis"});
  b.method("get_aim_axis", &IKChain::get_aim_axis);
  b.method("set_use_target_rotation", &IKChain::set_use_target_rotation, {"enabled"});
  b.method("is_using_target_rotation", &IKChain::is_using_target_rotation);
  b.method("set_rotation_weight", &IKChain::set_rotation_weight, {"weight"});
  b.method("get_rotation_weight", &IKChain::get_rotation_weight);
  b.method("set_pole_target", &IKChain::set_pole_target, {"path"});
  b.method("get_pole_target", &IKChain::get_pole_target);
  b.method("set_joints", &IKChain::set_joints, {"joints"});
  b.method("get_joints", &IKChain::get_joints, {}, {nullptr, "IKChainJoint"});
  b.method("set_goals", &IKChain::set_goals, {"goals"});
  b.method("get_goals", &IKChain::get_goals, {}, {nullptr, "IKChainGoal"});
  b.method("set_max_iterations", &IKChain::set_max_iterations, {"iterations"});
  b.method("get_max_iterations", &IKChain::get_max_iterations);
  b.method("set_tolerance", &IKChain::set_tolerance, {"tolerance"});
  b.method("get_tolerance", &IKChain::get_tolerance);
  b.method("set_orientation_tolerance", &IKChain::set_orientation_tolerance, {"radians"});
  b.method("get_orientation_tolerance", &IKChain::get_orientation_tolerance);
  b.method("set_soft_reach", &IKChain::set_soft_reach, {"distance"});
  b.method("get_soft_reach", &IKChain::get_soft_reach);
  b.method("set_time_budget_usec", &IKChain::set_time_budget_usec, {"usec"});
  b.method("get_time_budget_usec", &IKChain::get_time_budget_usec);
  b.method("set_max_restarts", &IKChain::set_max_restarts, {"restarts"});
  b.method("get_max_restarts", &IKChain::get_max_restarts);
  b.method("set_restart_seed", &IKChain::set_restart_seed, {"seed"});
  b.method("get_restart_seed", &IKChain::get_restart_seed);
  b.method("set_deterministic", &IKChain::set_deterministic, {"enabled"});
  b.method("is_deterministic", &IKChain::is_deterministic);
  b.method("get_last_result", &IKChain::get_last_result);
  b.method("get_last_reason", &IKChain::get_last_reason);
  b.method("is_last_usable", &IKChain::is_last_usable);
  b.method("is_last_reached", &IKChain::is_last_reached);
  b.method("get_last_iterations", &IKChain::get_last_iterations);
  b.method("get_last_joints_at_limit", &IKChain::get_last_joints_at_limit);
  b.method("get_last_initial_error", &IKChain::get_last_initial_error);
  b.method("get_last_final_error", &IKChain::get_last_final_error);
  b.method("get_last_position_error", &IKChain::get_last_position_error);
  b.method("get_last_orientation_error", &IKChain::get_last_orientation_error);
  b.method("get_last_microseconds", &IKChain::get_last_microseconds);
  b.method("solve_now", &IKChain::solve_now);
  b.method("get_chain_bones", &IKChain::get_chain_bones);
  // Also callable from scripts (as godot-cpp does for bound virtuals): Node has no bound
  // get_configuration_warnings(), and tools and tests want to read them.
  b.method("_get_configuration_warnings", &IKChain::get_configuration_warnings);

  std::string solver_hint;
  for (const SolverInfo& info : solver_table()) {
    const int64_t value = int64_t(info.kind);
    b.constant("Solver", solver_constant(value), value);
    solver_hint += std::string(info.display_name) + ":" + std::to_string(value) + ",";
  }
  b.constant("Solver", solver_constant(SOLVER_AUTO), SOLVER_AUTO);
  solver_hint += "Auto:" + std::to_string(SOLVER_AUTO);
  b.constant("GoalMode", "GOAL_MODE_REACH", GOAL_MODE_REACH);
  b.constant("GoalMode", "GOAL_MODE_AIM", GOAL_MODE_AIM);
  const char* axis_constants[] = {"AXIS_PLUS_X", "AXIS_MINUS_X", "AXIS_PLUS_Y",
                                  "AXIS_MINUS_Y", "AXIS_PLUS_Z", "AXIS_MINUS_Z"};
  for (int i = 0; i < 6; ++i) b.constant("Axis", axis_constants[i], i);
  constexpr const char* kAxisHint = "+X,-X,+Y,-Y,+Z,-Z";

  // root_bone / tip_bone get their bone-name drop-down in validate_property().
  b.property({"root_bone", GDEXTENSION_VARIANT_TYPE_STRING, hint::PROPERTY_HINT_ENUM, ""}, "set_root_bone",
             "get_root_bone");
  b.property({"tip_bone", GDEXTENSION_VARIANT_TYPE_STRING, hint::PROPERTY_HINT_ENUM, ""}, "set_tip_bone",
             "get_tip_bone");
  b.property({"extend_tip_bone", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_extend_tip_bone", "is_extend_tip_bone");
  b.property({"tip_extension_axis", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, kAxisHint},
             "set_tip_extension_axis", "get_tip_extension_axis");
  b.property({"tip_extension_length", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0,10,0.001,or_greater,suffix:m"},
             "set_tip_extension_length", "get_tip_extension_length");
  b.group("Goal", "");
  b.property({"target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_target", "get_target");
  b.property({"use_target_transform", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_use_target_transform",
             "is_using_target_transform");
  b.property({"target_transform", GDEXTENSION_VARIANT_TYPE_TRANSFORM3D}, "set_target_transform",
             "get_target_transform");
  b.property({"goal_mode", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, "Reach,Aim"}, "set_goal_mode",
             "get_goal_mode");
  b.property({"aim_axis", GDEXTENSION_VARIANT_TYPE_VECTOR3}, "set_aim_axis", "get_aim_axis");
  b.property({"use_target_rotation", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_use_target_rotation",
             "is_using_target_rotation");
  b.property({"rotation_weight", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,10,0.01,or_greater"},
             "set_rotation_weight", "get_rotation_weight");
  b.property({"pole_target", GDEXTENSION_VARIANT_TYPE_NODE_PATH, hint::PROPERTY_HINT_NODE_PATH_VALID_TYPES, "Node3D"},
             "set_pole_target", "get_pole_target");
  b.group("Joints and Goals", "");
  b.property({"joints", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING,
              "24/17:IKChainJoint"},  // Array[IKChainJoint]: Variant::OBJECT / PROPERTY_HINT_RESOURCE_TYPE
             "set_joints", "get_joints");
  b.property({"goals", GDEXTENSION_VARIANT_TYPE_ARRAY, hint::PROPERTY_HINT_TYPE_STRING, "24/17:IKChainGoal"},
             "set_goals", "get_goals");
  b.group("Solver", "");
  b.property({"solver", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, solver_hint.c_str()}, "set_solver",
             "get_solver");
  b.property({"max_iterations", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "1,1000,1"},
             "set_max_iterations", "get_max_iterations");
  b.property({"tolerance", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0.000001,1,0.000001,exp,suffix:m"},
             "set_tolerance", "get_tolerance");
  b.property({"orientation_tolerance", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0.000001,1,0.000001,exp,suffix:rad"},
             "set_orientation_tolerance", "get_orientation_tolerance");
  b.property({"soft_reach", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE, "0,1,0.001,or_greater,suffix:m"},
             "set_soft_reach", "get_soft_reach");
  b.property({"time_budget_usec", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0,100000,1,or_greater,suffix:us"},
             "set_time_budget_usec", "get_time_budget_usec");
  b.property({"max_restarts", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "0,100,1"},
             "set_max_restarts", "get_max_restarts");
  b.property({"restart_seed", GDEXTENSION_VARIANT_TYPE_INT}, "set_restart_seed", "get_restart_seed");
  b.property({"deterministic", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_deterministic", "is_deterministic");

  b.virtual_method("_process_modification_with_delta",
                   gdx::gen::kVirtualHash_SkeletonModifier3D__process_modification_with_delta,
                   &IKChain::process_modification);
  b.virtual_method("_get_configuration_warnings", gdx::gen::kVirtualHash_Node__get_configuration_warnings,
                   &IKChain::get_configuration_warnings);
  b.virtual_method("_skeleton_changed", gdx::gen::kVirtualHash_SkeletonModifier3D__skeleton_changed,
                   &IKChain::skeleton_changed);
}

void IKChain::unregister_class() {
  delete g_names;
  g_names = nullptr;
}

IKChain::IKChain(gdx::ObjectPtr owner) : owner_(owner) {
  options_.max_iterations = int(max_iterations_);
  options_.position_tolerance = tolerance_;
  options_.orientation_tolerance = orientation_tolerance_;
  options_.warm_start = !deterministic_;
}

// ---------------------------------------------------------------- properties

void IKChain::mark_dirty() {
  dirty_ = true;
  gdx::Node::unchecked(owner_).update_configuration_warnings();
}

void IKChain::settings_changed() { gdx::Node::unchecked(owner_).update_configuration_warnings(); }

void IKChain::set_root_bone(const gdx::String& name) {
  std::string v = name.utf8();
  if (v == root_bone_) return;  // re-assigning the same value rebuilds nothing
  root_bone_ = std::move(v);
  mark_dirty();
}
gdx::String IKChain::get_root_bone() const { return text(root_bone_); }

void IKChain::set_tip_bone(const gdx::String& name) {
  std::string v = name.utf8();
  if (v == tip_bone_) return;
  tip_bone_ = std::move(v);
  mark_dirty();
}
gdx::String IKChain::get_tip_bone() const { return text(tip_bone_); }

void IKChain::set_extend_tip_bone(bool on) {
  if (on == extend_tip_bone_) return;
  extend_tip_bone_ = on;
  gdx::Object(owner_).notify_property_list_changed();
  mark_dirty();
}

void IKChain::set_tip_extension_axis(int64_t axis) {
  const int64_t used = std::clamp<int64_t>(axis, AXIS_PLUS_X, AXIS_MINUS_Z);
  if (used != axis) report_clamped(kClass, "tip_extension_axis", "0..5 (IKChain.AXIS_*)", double(axis), double(used));
  if (used == tip_extension_axis_) return;
  tip_extension_axis_ = used;
  mark_dirty();
}

void IKChain::set_tip_extension_length(double length) {
  const double used = std::isnan(length) ? tip_extension_length_ : std::clamp(length, 0.0, 1e6);
  if (used != length) report_clamped(kClass, "tip_extension_length", "[0, 1e+06] m", length, used);
  if (used == tip_extension_length_) return;
  tip_extension_length_ = used;
  mark_dirty();
}

void IKChain::set_target(const gdx::NodePath& path) {
  target_ = path;
  settings_changed();
}

void IKChain::set_use_target_transform(bool on) {
  if (on == use_target_transform_) return;
  use_target_transform_ = on;
  settings_changed();
}

void IKChain::set_target_transform(const gdx::Transform3D& transform) { target_transform_ = transform; }

void IKChain::set_solver(int64_t solver) {
  const int64_t used = std::clamp<int64_t>(solver, SOLVER_TWO_BONE, SOLVER_AUTO);
  if (used != solver) report_clamped(kClass, "solver", "0..6 (IKChain.SOLVER_*)", double(solver), double(used));
  if (used == solver_) return;
  solver_ = used;
  settings_changed();
}

void IKChain::set_goal_mode(int64_t mode) {
  const int64_t used = std::clamp<int64_t>(mode, GOAL_MODE_REACH, GOAL_MODE_AIM);
  if (used != mode) report_clamped(kClass, "goal_mode", "0..1 (IKChain.GOAL_MODE_*)", double(mode), double(used));
  if (used == goal_mode_) return;
  goal_mode_ = used;
  gdx::Object(owner_).notify_property_list_changed();
  settings_changed();
}

void IKChain::set_aim_axis(const gdx::Vector3& axis) {
  double x = 0, y = 0, z = 0;
  if (!direction_or_report(kClass, "aim_axis", "Set the tip bone's axis that should point at the target, e.g. (0, 1, 0).",
                           axis.x, axis.y, axis.z, x, y, z))
    return;
  aim_axis_ = gdx::Vector3{gdx::real_t(x), gdx::real_t(y), gdx::real_t(z)};
  settings_changed();
}

void IKChain::set_use_target_rotation(bool on) {
  if (on == use_target_rotation_) return;
  use_target_rotation_ = on;
  settings_changed();
}

void IKChain::set_rotation_weight(double weight) {
  const double used = std::isnan(weight) ? rotation_weight_ : std::clamp(weight, 0.0, 1e6);
  if (used != weight) report_clamped(kClass, "rotation_weight", "[0, 1e+06]", weight, used);
  rotation_weight_ = used;
}

void IKChain::set_pole_target(const gdx::NodePath& path) {
  pole_target_ = path;
  settings_changed();
}

void IKChain::set_joints(const gdx::Array& joints) {
  joints_ = joints;
  mark_dirty();
}

void IKChain::set_goals(const gdx::Array& goals) {
  goals_ = goals;
  mark_dirty();
}

void IKChain::set_max_iterations(int64_t n) {
  max_iterations_ = std::clamp<int64_t>(n, 1, 1000);
  if (max_iterations_ != n) report_clamped(kClass, "max_iterations", "1..1000", double(n), double(max_iterations_));
  options_.max_iterations = int(max_iterations_);
}

void IKChain::set_tolerance(double units) {
  const double used = std::isnan(units) ? tolerance_ : std::clamp(units, 1e-6, 1.0);
  if (used != units) report_clamped(kClass, "tolerance", "[1e-06, 1] (skeleton units)", units, used);
  tolerance_ = used;
  options_.position_tolerance = tolerance_;
}

void IKChain::set_orientation_tolerance(double radians) {
  const double used = std::isnan(radians) ? orientation_tolerance_ : std::clamp(radians, 1e-6, 1.0);
  if (used != radians) report_clamped(kClass, "orientation_tolerance", "[1e-06, 1] rad", radians, used);
  orientation_tolerance_ = used;
  options_.orientation_tolerance = orientation_tolerance_;
}

void IKChain::set_soft_reach(double units) {
  const double used = std::isnan(units) ? soft_reach_ : std::clamp(units, 0.0, 1e6);
  if (used != units) report_clamped(kClass, "soft_reach", "[0, 1e+06] (skeleton units; 0 = off)", units, used);
  soft_reach_ = used;
  options_.soft_reach = soft_reach_;
}

void IKChain::set_time_budget_usec(double usec) {
  const double used = std::isnan(usec) ? time_budget_usec_ : std::clamp(usec, 0.0, 1e9);
  if (used != usec) report_clamped(kClass, "time_budget_usec", "[0, 1e+09] us (0 = none)", usec, used);
  time_budget_usec_ = used;
  options_.time_budget_usec = time_budget_usec_;
}

void IKChain::set_max_restarts(int64_t n) {
  max_restarts_ = std::clamp<int64_t>(n, 0, 100);
  if (max_restarts_ != n) report_clamped(kClass, "max_restarts", "0..100", double(n), double(max_restarts_));
  options_.max_restarts = int(max_restarts_);
}

void IKChain::set_restart_seed(int64_t seed) {
  restart_seed_ = seed;
  // All 64 bits (a negative seed is its two's complement): different seeds give different restarts.
  options_.restart_seed = uint64_t(seed);
}

void IKChain::set_deterministic(bool on) {
  deterministic_ = on;
  options_.warm_start = !on;
}

// ---------------------------------------------------------------- script API

// final_error, position_error, orientation_error and reached describe the pose the skeleton ends
// with (after its influence blend); solver_final_error is the solver's own. The typed getters and
// the Dictionary share these definitions, so they cannot disagree.
gdx::String IKChain::get_last_reason() const {
  return gdx::String(has_result_ ? reason_name(last_.reason) : "not_run");
}
bool IKChain::is_last_usable() const { return has_result_ && last_.usable(); }
double IKChain::get_last_final_error() const { return is_last_usable() ? written_.combined : last_.final_error; }
double IKChain::get_last_position_error() const {
  return is_last_usable() ? written_.max_position : last_.final_position_error;
}
double IKChain::get_last_orientation_error() const {
  return is_last_usable() ? written_.max_orientation : last_.final_orientation_error;
}
bool IKChain::is_last_reached() const {
  return is_last_usable() && written_.max_position <= tolerance_ && written_.max_orientation <= orientation_tolerance_;
}

gdx::Dictionary IKChain::get_last_result() const {
  gdx::Dictionary d;
  auto put = [&d](const char* key, const gdx::Variant& value) { d.set(gdx::Variant(key), value); };
  // The same keys every time (zeros before the first solve), so scripts can read them unguarded.
  const bool usable = is_last_usable();
  put("reason", gdx::Variant(get_last_reason()));
  put("usable", gdx::Variant(usable));
  put("iterations", gdx::Variant(get_last_iterations()));
  put("initial_error", gdx::Variant(get_last_initial_error()));
  put("final_error", gdx::Variant(get_last_final_error()));
  put("solver_final_error", gdx::Variant(last_.final_error));
  put("position_error", gdx::Variant(get_last_position_error()));
  put("orientation_error", gdx::Variant(get_last_orientation_error()));
  put("microseconds", gdx::Variant(get_last_microseconds()));
  put("reached", gdx::Variant(is_last_reached()));
  put("budget_exhausted", gdx::Variant(last_.budget_exhausted));
  put("restarts", gdx::Variant(int64_t(last_.restarts)));
  put("escapes", gdx::Variant(int64_t(last_.escapes)));
  put("joints_at_limit", gdx::Variant(get_last_joints_at_limit()));
  put("soft_pull", gdx::Variant(last_.soft_pull));
  put("solver", gdx::Variant(usable ? solver_info(last_solver_).display_name : ""));
  put("message", gdx::Variant(last_.message.c_str()));
  return d;
}

gdx::Dictionary IKChain::solve_now() {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    set_invalid_result("IKChain: the parent is not a Skeleton3D; make IKChain a child of a Skeleton3D.");
  } else {
    run(skel);
  }
  return get_last_result();
}

gdx::PackedInt32Array IKChain::get_chain_bones() {
  const gdx::Skeleton3D skel = skeleton();
  if (skel && needs_rebuild(skel)) rebuild(skel);
  gdx::PackedInt32Array out;
  if (!chain_ok_) return out;
  for (int i = 0; i < mapping_.joint_count(); ++i) out.push_back(mapping_.skeleton_bone(i));
  return out;
}

// ---------------------------------------------------------------- editor

bool IKChain::validate_property(GDExtensionPropertyInfo& property) {
  if (g_names == nullptr) return false;
  auto hide = [&property]() {
    property.usage = uint32_t(usage::PROPERTY_USAGE_NO_EDITOR);
    return true;
  };
  if (g_names->tip_extension_axis.equals(property.name) || g_names->tip_extension_length.equals(property.name))
    return extend_tip_bone_ ? false : hide();
  if (g_names->aim_axis.equals(property.name)) return goal_mode_ == GOAL_MODE_AIM ? false : hide();
  if (g_names->use_target_rotation.equals(property.name)) return goal_mode_ == GOAL_MODE_REACH ? false : hide();
  const bool is_bone = g_names->root_bone.equals(property.name) || g_names->tip_bone.equals(property.name);
  if (!is_bone) return false;
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    property.hint = uint32_t(hint::PROPERTY_HINT_NONE);  // free text until there is a skeleton
    return true;
  }
  // The same drop-down Godot's own modifiers use: "bone0,bone1,...".
  const gdx::String names(skel.get_concatenated_bone_names());
  property.hint = uint32_t(hint::PROPERTY_HINT_ENUM);
  gdx::String::assign_to(property.hint_string, names);
  return true;
}

gdx::Skeleton3D IKChain::skeleton() const {
  // Before the node enters the tree get_skeleton() has not cached it yet, so fall back to the
  // parent (the editor asks for warnings at any time).
  const gdx::SkeletonModifier3D self = gdx::SkeletonModifier3D::unchecked(owner_);
  gdx::Skeleton3D skel = self.get_skeleton();
  if (!skel) skel = gdx::Skeleton3D::cast(self.get_parent());
  return skel;
}

void IKChain::watch_skeleton(const gdx::Skeleton3D& skel) {
  if (!skel || g_names == nullptr) return;
  const gdx::Callable callback(owner_, g_names->skeleton_changed);
  for (const gdx::StringName* signal : {&g_names->bone_list_changed, &g_names->rest_updated}) {
    if (!skel.is_connected(*signal, callback)) skel.connect(*signal, callback);
  }
}

void IKChain::skeleton_changed() {
  dirty_ = true;
  gdx::Object(owner_).notify_property_list_changed();
}

void IKChain::collect_chain_problems(const gdx::Skeleton3D& skel, std::vector<Problem>& problems,
                                     SkeletonChainDesc* desc) const {
  if (!skel) {
    problems.push_back({"parent", "IKChain: the parent is not a Skeleton3D; make IKChain a child of a Skeleton3D."});
    return;
  }
  auto bone_index = [&](const char* prop, const std::string& name) -> int {
    if (name.empty()) {
      problems.push_back({prop, std::string("IKChain: ") + prop + " is empty; pick a bone of the parent Skeleton3D "
                                "in the " + prop + " property."});
      return -1;
    }
    const int idx = int(skel.find_bone(text(name)));
    if (idx < 0)
      problems.push_back({prop, std::string("IKChain: ") + prop + " '" + name +
                                    "' is not a bone of the parent Skeleton3D; pick one from the " + prop +
                                    " drop-down."});
    return idx;
  };
  const int root = bone_index("root_bone", root_bone_);
  const int tip = bone_index("tip_bone", tip_bone_);
  if (root < 0 || tip < 0) return;

  // Bones: tip up to root (then reversed, root first).
  std::vector<int> bones{tip};
  const int64_t bone_count = skel.get_bone_count();
  int b = tip;
  while (b != root && b >= 0 && int64_t(bones.size()) <= bone_count) {
    b = int(skel.get_bone_parent(b));
    if (b >= 0) bones.push_back(b);
  }
  if (b != root || tip == root) {
    problems.push_back({"tip_bone", "IKChain: tip_bone '" + tip_bone_ + "' is not a descendant of root_bone '" +
                                        root_bone_ + "'; pick a tip_bone below root_bone (the joints are root_bone "
                                        "down to tip_bone's parent, the effector is tip_bone's origin)."});
    return;
  }
  std::reverse(bones.begin(), bones.end());
  const size_t joint_count = extend_tip_bone_ ? bones.size() : bones.size() - 1;

  // Joint settings by bone name; each resource must name a chain bone, once.
  std::vector<const IKChainJoint*> settings(bones.size(), nullptr);
  for (int64_t i = 0; i < joints_.size(); ++i) {
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(joints_.at(i), object);
    const IKChainJoint* joint = IKChainJoint::from_object(object);
    const std::string where = "IKChain: joints[" + std::to_string(i) + "]";
    if (joint == nullptr) {
      problems.push_back({"joints", where + " is not an IKChainJoint; create one with New IKChainJoint or remove "
                                    "the element."});
      continue;
    }
    const int bone = int(skel.find_bone(joint->get_bone_name()));
    size_t k = 0;
    while (k < joint_count && bones[k] != bone) ++k;
    if (k == joint_count) {
      problems.push_back({"joints", where + " names bone '" + joint->bone_name() +
                                        "', which is not a joint of this chain; set its bone_name to one of the "
                                        "bones from root_bone to tip_bone's parent" +
                                        (extend_tip_bone_ ? " (or tip_bone)." : ".")});
      continue;
    }
    if (settings[k] != nullptr) {
      problems.push_back({"joints", where + " sets bone '" + joint->bone_name() +
                                        "' a second time; remove one of the two."});
      continue;
    }
    settings[k] = joint;
  }

  if (solver_ != SOLVER_AUTO) {
    const SolverInfo& info = solver_info(SolverKind(solver_));
    if (info.joint_count != 0 && size_t(info.joint_count) != joint_count)
      problems.push_back({"solver", std::string("IKChain: solver ") + info.display_name + " needs exactly " +
                                        std::to_string(info.joint_count) + " joints (root_bone, its child, then "
                                        "tip_bone), this chain has " + std::to_string(joint_count) +
                                        "; change root_bone/tip_bone or pick another solver."});
  }
  if (desc == nullptr) return;
  desc->bones.clear();
  desc->extend_tip_bone = extend_tip_bone_;
  desc->tip_extension_axis = TipAxis(tip_extension_axis_);
  desc->tip_extension_length = tip_extension_length_;
  for (size_t i = 0; i < bones.size(); ++i) {
    ChainBoneDesc bone;
    bone.name = skel.get_bone_name(bones[i]).utf8();
    bone.skeleton_bone = bones[i];
    bone.rest_basis_in_parent = gdx::to_glm(skel.get_bone_rest(bones[i]).basis);
    bone.pose.position = gdx::to_glm(skel.get_bone_pose_position(bones[i]));
    bone.pose.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bones[i]));
    bone.pose.scale = gdx::to_glm(skel.get_bone_pose_scale(bones[i]));
    if (const IKChainJoint* j = settings[i]) bone.joint = j->settings();
    desc->bones.push_back(std::move(bone));
  }
}

void IKChain::collect_goal_problems(std::vector<Problem>& problems) const {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  if (use_target_transform_) {
    // target_transform (global space, set by a script) drives the chain; target is ignored.
    if (!finite(target_transform_))
      problems.push_back({"target_transform", "IKChain: target_transform is not finite; set it to a finite "
                                              "transform (global space)."});
  } else if (target_.is_empty()) {
    problems.push_back({"target", "IKChain: target is empty; set it to the Node3D the tip should reach, or turn on "
                                  "use_target_transform and set target_transform from a script."});
  } else if (!gdx::Node3D::cast(self.get_node_or_null(target_))) {
    problems.push_back({"target", "IKChain: target '" + target_.to_string().utf8() +
                                      "' does not point to a Node3D; set it to the Node3D the tip should reach, or "
                                      "clear it and drive target_transform from a script."});
  }
  if (!pole_target_.is_empty() && !gdx::Node3D::cast(self.get_node_or_null(pole_target_)))
    problems.push_back({"pole_target", "IKChain: pole_target '" + pole_target_.to_string().utf8() +
                                           "' does not point to a Node3D; set it to a Node3D or clear it."});
  if (goal_mode_ == GOAL_MODE_AIM && !(glm::length(gdx::to_glm(aim_axis_)) > 1e-9))
    problems.push_back({"aim_axis", "IKChain: aim_axis is zero; set the tip bone's axis that should point at the "
                                    "target, e.g. (0, 1, 0)."});
  // What the chosen solver can pursue (the core's solver table); Auto always picks one that can.
  const SolverInfo* info = solver_ == SOLVER_AUTO ? nullptr : &solver_info(SolverKind(solver_));
  const bool orientation = (goal_mode_ == GOAL_MODE_AIM) || (use_target_rotation_ && rotation_weight_ > 0.0);
  if (info != nullptr && orientation && !info->orientation_goals)
    problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                      " only reaches a position; turn off use_target_rotation (or goal_mode Aim), or "
                                      "pick another solver (Auto picks one that can)."});
}

void IKChain::resolve_goals(const SkeletonChain& chain, std::vector<ExtraGoal>* goals, std::vector<Problem>& problems,
                            std::vector<Problem>& unmovable) const {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  const SolverInfo* info = solver_ == SOLVER_AUTO ? nullptr : &solver_info(SolverKind(solver_));
  for (int64_t i = 0; i < goals_.size(); ++i) {
    gdx::ObjectPtr object = nullptr;
    gdx::variant_to(goals_.at(i), object);
    const IKChainGoal* goal = IKChainGoal::from_object(object);
    const std::string where = "IKChain: goals[" + std::to_string(i) + "]";
    if (goal == nullptr) {
      problems.push_back({"goals", where + " is not an IKChainGoal; create one with New IKChainGoal or remove the "
                                   "element."});
      continue;
    }
    // A missing target only skips the goal per frame (the node may appear later).
    if (!gdx::Node3D::cast(self.get_node_or_null(goal->get_target())))
      problems.push_back({"goals", where + " (bone '" + goal->bone_name() +
                                       "'): target does not point to a Node3D; set its target (a path relative to "
                                       "this IKChain)."});
    if (info != nullptr && !info->several_goals)
      problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                        " takes no extra goals; remove goals[" + std::to_string(i) +
                                        "] or pick another solver."});
    else if (info != nullptr && goal->get_kind() != IKChainGoal::KIND_POSITION &&
             !info->intermediate_orientation_goals)
      problems.push_back({"solver", std::string("IKChain: solver ") + info->display_name +
                                        " pursues orientation and aim goals on the tip only; make goals[" +
                                        std::to_string(i) + "] a position goal or pick another solver."});
    if (!chain.valid()) continue;
    int chain_bone = -1;
    for (int k = 0; k < chain.bone_count(); ++k)
      if (chain.bone_name(k) == goal->bone_name()) chain_bone = k;
    ExtraGoal e;
    e.kind = goal->goal_kind();
    e.weight = goal->get_weight();
    e.target = goal->get_target();
    // A position goal pulls the bone's origin (effector k); an orientation or aim goal turns the
    // bone's own frame, which the core exposes as the orientation of effector k + 1.
    e.effector = e.kind == GoalKind::kPosition
                     ? chain.effector_of_bone(chain_bone)
                     : (chain_bone >= 0 && chain_bone < chain.joint_count() ? chain_bone + 1 : -1);
    if (e.effector <= 0) {
      unmovable.push_back({"goals", where + " names bone '" + goal->bone_name() +
                                        "', which this goal cannot move (not in the chain" +
                                        (e.kind == GoalKind::kPosition ? ", or the root bone whose origin is fixed"
                                                                       : "") +
                                        "); set its bone_name to a bone of the chain."});
      continue;
    }
    e.axis_in_effector = gdx::to_glm(goal->get_aim_axis());
    if (goals != nullptr) goals->push_back(e);
  }
}

gdx::PackedStringArray IKChain::get_configuration_warnings() const {
  std::vector<Problem> problems;
  SkeletonChainDesc desc;
  collect_chain_problems(skeleton(), problems, &desc);
  // What the builder rejects (limits, lengths), checked on the settings as they are now.
  SkeletonChain check;
  if (!desc.bones.empty()) {
    const Message built = check.build(desc);
    if (!built.empty()) problems.push_back({"joints", std::string("IKChain: cannot build the chain: ") + built.c_str()});
  }
  collect_goal_problems(problems);
  resolve_goals(check, nullptr, problems, problems);
  if (chain_ok_ && mapping_.has_non_uniform_scale()) problems.push_back({"root_bone", mapping_.scale_warning().c_str()});
  // The chain as last built: what the builder rejected (limits, lengths) and what the solver refused.
  for (const Problem& p : chain_problems_) {
    bool seen = false;
    for (const Problem& q : problems) seen = seen || q.message == p.message;
    if (!seen) problems.push_back(p);
  }
  if (solver_refused_)
    problems.push_back({"solver", std::string("IKChain: the solver refused the last frame: ") + last_.message.c_str()});
  gdx::PackedStringArray out;
  for (const Problem& p : problems) out.push_back(text(p.message));
  return out;
}

// ---------------------------------------------------------------- building

bool IKChain::needs_rebuild(const gdx::Skeleton3D& skel) const {
  return dirty_ || skel.instance_id() != built_skeleton_id_ || skel.get_version() != built_skeleton_version_ ||
         IKChainJoint::generation() != built_settings_generation_ ||
         // A bone renamed under our chain (the version does not count renames in every engine).
         (chain_ok_ && (skel.find_bone(root_bone_name_) != root_bone_index_ ||
                        skel.find_bone(tip_bone_name_) != tip_bone_index_)) ||
         ancestry_changed(skel);
}

bool IKChain::ancestry_changed(const gdx::Skeleton3D& skel) const {
  const int64_t count = skel.get_bone_count();
  for (const auto& [bone, parent] : built_ancestry_)
    if (bone >= count || skel.get_bone_parent(bone) != parent) return true;
  return false;
}

void IKChain::record_ancestry(const gdx::Skeleton3D& skel) {
  built_ancestry_.clear();
  if (!skel || tip_bone_.empty()) return;
  const int64_t count = skel.get_bone_count();
  const int root = root_bone_.empty() ? -1 : int(skel.find_bone(text(root_bone_)));
  int bone = int(skel.find_bone(text(tip_bone_)));
  // Bounded by the bone count: a parent cycle cannot hang the walk.
  for (int64_t steps = 0; bone >= 0 && bone < count && steps <= count; ++steps) {
    const int parent = int(skel.get_bone_parent(bone));
    built_ancestry_.emplace_back(bone, parent);
    if (bone == root) break;
    bone = parent;
  }
}

void IKChain::rebuild(const gdx::Skeleton3D& skel) {
  dirty_ = false;
  const bool was_ok = chain_ok_;
  const size_t old_problem_count = chain_problems_.size();
  chain_ok_ = false;
  chain_problems_.clear();
  if (skel && skel.instance_id() != built_skeleton_id_) watch_skeleton(skel);
  built_skeleton_id_ = skel.instance_id();
  built_skeleton_version_ = skel ? skel.get_version() : -1;
  built_settings_generation_ = IKChainJoint::generation();
  record_ancestry(skel);

  SkeletonChainDesc desc;
  collect_chain_problems(skel, chain_problems_, &desc);
  if (chain_problems_.empty()) {
    const Message built = mapping_.build(desc);
    if (!built.empty())
      chain_problems_.push_back({"joints", std::string("IKChain: cannot build the chain: ") + built.c_str()});
  }
  if (chain_problems_.empty()) {
    const int n = mapping_.joint_count();
    const int bones = mapping_.bone_count();
    base_bone_ = int(skel.get_bone_parent(desc.bones.front().skeleton_bone));
    root_bone_name_ = text(root_bone_);
    tip_bone_name_ = text(tip_bone_);
    root_bone_index_ = desc.bones.front().skeleton_bone;
    tip_bone_index_ = desc.bones.back().skeleton_bone;

    // Extra goals: effector and frame of each IKChainGoal. A goal on a bone the chain cannot move
    // stops the chain; the other problems only show as warnings (the chain runs without the goal).
    extra_goals_.clear();
    std::vector<Problem> warnings_only;
    resolve_goals(mapping_, &extra_goals_, warnings_only, chain_problems_);
    if (chain_problems_.empty()) {
      const int max_goals = 2 + int(extra_goals_.size());
      workspace_.reset(mapping_.chain(), max_goals);
      goal_buffer_.assign(size_t(max_goals), Goal());
      params_ = Eigen::VectorXd::Zero(mapping_.chain().dof_count());
      params_from_last_solve_ = false;
      have_good_pose_ = false;
      bone_poses_.assign(size_t(bones), BonePose());
      old_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
      new_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
      blended_rotations_.assign(size_t(n), glm::dquat(1.0, 0.0, 0.0, 0.0));
      chain_ok_ = true;
    }
  }
  if (chain_ok_ != was_ok || chain_problems_.size() != old_problem_count) settings_changed();
}

SolverKind IKChain::resolved_solver() const {
  if (solver_ != SOLVER_AUTO) return SolverKind(solver_);
  // Auto: the analytic solver when it is exact for the chain and goals (2 free ball joints, one
  // position goal); otherwise damped least squares, the fastest of the robust solvers in the
  // benchmark (docs/benchmarks.md), which pursues every goal kind and respects limits.
  const Chain& chain = mapping_.chain();
  const bool position_only = goal_count_ == 1 && goal_buffer_[0].kind == GoalKind::kPosition;
  if (chain.joint_count() == 2 && position_only && !chain.any_limits() &&
      chain.joint_type(0) == JointType::kBall && chain.joint_type(1) == JointType::kBall)
    return SolverKind::kTwoBone;
  return SolverKind::kDLS;
}

// ---------------------------------------------------------------- solving

void IKChain::report_runtime(const char* message) {
  for (const std::string& r : runtime_reported_)
    if (r == message) return;
  gdx::print_error(message, "IKChain::_process_modification_with_delta", __FILE__, __LINE__);
  runtime_reported_.emplace_back(message);
}

void IKChain::Spell::report(const char* message) {
  if (reported) return;
  gdx::print_error(message, "IKChain::_process_modification_with_delta", __FILE__, __LINE__);
  reported = true;
}

void IKChain::set_invalid_result(const char* message) {
  // The modification did nothing this frame: a defined result, the pose is left as it was.
  has_result_ = true;
  last_ = SolveResult();
  last_.reason = TerminationReason::kInvalidInput;
  last_.message = Message::format("%s", message);
  solver_refused_ = false;
}

void IKChain::notification(int32_t what) {
  if (what == gdx::gen::kNode_NOTIFICATION_ENTER_TREE) settings_changed();
}

void IKChain::process_modification(double /*delta*/) {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    // Configuration problems show as the warning triangle (like Godot's own modifiers), not as
    // an error every frame.
    set_invalid_result("IKChain: the parent is not a Skeleton3D.");
    return;
  }
  run(skel);
}

bool IKChain::assemble_goals(const gdx::Skeleton3D& skel) {
  const gdx::Node self = gdx::Node::unchecked(owner_);
  gdx::Transform3D target_global = target_transform_;
  if (!use_target_transform_) {
    const gdx::Node3D target = gdx::Node3D::cast(self.get_node_or_null(target_));
    if (!target || !target.is_inside_tree()) {
      set_invalid_result("IKChain: target does not point to a Node3D in the scene tree.");
      return false;
    }
    target_global = target.get_global_transform();
  }
  const glm::dmat4 base_bone =
      base_bone_ >= 0 ? gdx::to_glm(skel.get_bone_global_pose(base_bone_)) : glm::dmat4(1.0);
  BaseFrame base;
  const char* bad = !finite(target_global) ? kBadTarget
                    : !BaseFrame::make(gdx::to_glm(skel.get_global_transform()), base_bone, base) ? kBadBase
                                                                                                  : nullptr;
  if (bad != nullptr) {
    report_runtime(bad);
    set_invalid_result(bad);
    return false;
  }
  const glm::dmat4 target_m = gdx::to_glm(target_global);
  const glm::dvec3 target_in_base = base.point_in_base(glm::dvec3(target_m[3]));
  const double length = mapping_.chain().total_length();

  goal_count_ = 0;
  bool bad_target_basis = false;
  if (goal_mode_ == GOAL_MODE_AIM) {
    goal_buffer_[size_t(goal_count_++)] =
        Goal::aim_at(target_in_base, mapping_.aim_axis_in_effector(gdx::to_glm(aim_axis_)), 0, 1.0);
  } else {
    goal_buffer_[size_t(goal_count_++)] = Goal::position(target_in_base, 0, 1.0);
    if (use_target_rotation_ && rotation_weight_ > 0.0) {
      if (has_rotation(glm::dmat3(target_m))) {
        // rotation_weight 1: a radian of orientation error costs as much as one chain length of
        // position error.
        goal_buffer_[size_t(goal_count_++)] = Goal::orientation(
            mapping_.effector_orientation_for_tip_bone(base.rotation_in_base(target_m)), 0,
            rotation_weight_ * length * length);
      } else {
        bad_target_basis = true;
      }
    }
  }
  // A spell ends on any frame without the problem (also when the spoiled part is no longer asked for).
  if (bad_target_basis)
    target_basis_spell_.report(kBadTargetBasis);
  else
    target_basis_spell_.clear();
  bool bad_goal_basis = false;
  for (const ExtraGoal& e : extra_goals_) {
    const gdx::Node3D node = gdx::Node3D::cast(self.get_node_or_null(e.target));
    if (!node) continue;  // a configuration warning says so
    const glm::dmat4 m = gdx::to_glm(node.get_global_transform());
    Goal g;
    switch (e.kind) {
      case GoalKind::kPosition: g = Goal::position(base.point_in_base(glm::dvec3(m[3])), e.effector, e.weight); break;
      case GoalKind::kOrientation:
        // Like the tip's orientation goal: rotation_weight scales every orientation goal.
        if (!(rotation_weight_ > 0.0)) continue;
        if (!has_rotation(glm::dmat3(m))) {
          bad_goal_basis = true;
          continue;
        }
        g = Goal::orientation(base.rotation_in_base(m), e.effector, e.weight * rotation_weight_ * length * length);
        break;
      default:
        g = Goal::aim_at(base.point_in_base(glm::dvec3(m[3])), e.axis_in_effector, e.effector,
                         e.weight * length * length);
        break;
    }
    goal_buffer_[size_t(goal_count_++)] = g;
  }

  if (bad_goal_basis)
    goal_basis_spell_.report(kBadGoalBasis);
  else
    goal_basis_spell_.clear();

  options_.use_pole = false;
  bool bad_pole = false;
  if (!pole_target_.is_empty()) {
    const gdx::Node3D pole = gdx::Node3D::cast(self.get_node_or_null(pole_target_));
    if (pole) {  // a missing node is a configuration warning
      const glm::dvec3 pole_in_base = base.point_in_base(glm::dvec3(gdx::to_glm(pole.get_global_transform())[3]));
      const glm::dvec3 root_in_base = bone_poses_[0].position;  // root_bone's origin, in its parent
      const double reach = kMaxPoleDistanceInChainLengths * std::max(length, 1e-6);
      if (so3::finite(pole_in_base) && glm::all(glm::lessThanEqual(glm::abs(pole_in_base - root_in_base),
                                                                    glm::dvec3(reach)))) {
        options_.use_pole = true;
        options_.pole_in_base = pole_in_base;
      } else {
        bad_pole = true;  // the solve goes on without the pole
      }
    }
  }
  if (bad_pole)
    pole_spell_.report(kBadPole);
  else
    pole_spell_.clear();
  return true;
}

bool IKChain::run(const gdx::Skeleton3D& skel) {
  if (needs_rebuild(skel)) rebuild(skel);  // allocates, but only when something changed
  if (!chain_ok_) {
    set_invalid_result(chain_problems_.empty() ? "IKChain: the chain is not configured."
                                               : chain_problems_.front().message.c_str());
    return false;
  }
  // The bones' current poses: an animation may have moved a chain bone's position or scale.
  const int n = mapping_.joint_count();
  for (int i = 0; i < mapping_.bone_count(); ++i) {
    const int bone = mapping_.skeleton_bone(i);
    BonePose& p = bone_poses_[size_t(i)];
    p.position = gdx::to_glm(skel.get_bone_pose_position(bone));
    p.rotation = gdx::to_glm(skel.get_bone_pose_rotation(bone));
    p.scale = gdx::to_glm(skel.get_bone_pose_scale(bone));
    if (i < n) old_rotations_[size_t(i)] = p.rotation;
  }
  const PoseUpdate update = mapping_.update_pose(bone_poses_);
  if (!update.error.empty()) {
    report_runtime(update.error.c_str());
    set_invalid_result(update.error.c_str());
    return false;
  }
  if (!assemble_goals(skel)) {
    if (have_good_pose_)
      for (int i = 0; i < n; ++i)
        skel.set_bone_pose_rotation(mapping_.skeleton_bone(i), gdx::from_glm(new_rotations_[size_t(i)]));
    return false;
  }

  if (deterministic_) {
    params_.setZero();
  } else if (!params_from_last_solve_) {
    mapping_.params_from_rotations(old_rotations_, params_.data());
  }
  last_solver_ = resolved_solver();
  last_ = solve(last_solver_, mapping_.chain(), Span<const Goal>(goal_buffer_.data(), goal_count_), options_,
                workspace_, params_);
  has_result_ = true;
  solver_refused_ = !last_.usable();
  params_from_last_solve_ = !solver_refused_;
  if (solver_refused_) {
    report_runtime(last_.message.c_str());
    return false;
  }
  if (!mapping_.rotations_from_params(params_.data(), new_rotations_)) {
    params_from_last_solve_ = false;
    have_good_pose_ = false;
    report_runtime(kNonFinite);
    set_invalid_result(kNonFinite);
    return false;
  }
  for (int i = 0; i < n; ++i)
    skel.set_bone_pose_rotation(mapping_.skeleton_bone(i), gdx::from_glm(new_rotations_[size_t(i)]));
  have_good_pose_ = true;

  // The error of the pose the skeleton ends with: the skeleton blends our rotations with the
  // previous ones by `influence`, and a non-uniform scale makes the rigid chain approximate.
  const double influence = gdx::SkeletonModifier3D::unchecked(owner_).get_influence();
  const Span<const Goal> goals(goal_buffer_.data(), goal_count_);
  if (influence < 1.0) {
    written_ = mapping_.measure_blended_pose(old_rotations_, new_rotations_, influence, goals, blended_rotations_);
  } else if (mapping_.has_non_uniform_scale()) {
    written_ = mapping_.measure_pose(new_rotations_, goals);
  } else {
    written_.combined = last_.final_error;
    written_.max_position = last_.final_position_error;
    written_.max_orientation = last_.final_orientation_error;
  }
  clear_runtime_reports();
  return true;
}

}  // namespace ikchain::godot
