#include <cmath>
#include <cstdlib>
#include "ik_modifier.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include "binding/classes.hpp"
#include "node_util.hpp"
#include "property_report.hpp"

namespace ikchain::godot {

namespace hint = gdx::gen::PropertyHint;

namespace {

// StringNames the instances compare against and connect with; allocated at SCENE init.
struct Names {
  gdx::StringName root_bone{"root_bone"};
  gdx::StringName tip_bone{"tip_bone"};
  gdx::StringName bone_list_changed{"bone_list_changed"};
  gdx::StringName rest_updated{"rest_updated"};
  gdx::StringName skeleton_changed{"_skeleton_changed"};
  gdx::StringName changed{"changed"};
  gdx::StringName resource_changed{"_resource_changed"};
};
Names* g_names = nullptr;

}  // namespace

void IKModifier::register_names() {
  if (g_names == nullptr) g_names = new Names();
}

void IKModifier::unregister_names() {
  delete g_names;
  g_names = nullptr;
}

namespace {
// The core's safety cap on a solve's CPU time (SolverOptions::time_cap_usec), or what the environment
// variable IKCHAIN_TIME_CAP_USEC sets (microseconds, 0 = none), read once. Only for measuring: under
// valgrind the code runs 20-100x slower, its CPU time with it, so the cap would cut solves
// that take a millisecond natively, and the instruction counts would depend on the machine's load
// (tools/bench_godot.py sets it to 0 for its callgrind runs).
double time_cap_usec() {
  static const double cap = [] {
    const char* text = std::getenv("IKCHAIN_TIME_CAP_USEC");
    char* end = nullptr;
    const double v = text ? std::strtod(text, &end) : -1.0;
    return text && end != text && *end == '\0' && v >= 0.0 && std::isfinite(v) ? v : kDefaultTimeCapUsec;
  }();
  return cap;
}
}  // namespace

IKModifier::IKModifier(gdx::ObjectPtr owner, const Traits& traits)
    : owner_(owner), traits_(traits), max_iterations_(traits.default_max_iterations) {
  options_.time_cap_usec = time_cap_usec();
  options_.max_iterations = int(max_iterations_);
  options_.position_tolerance = tolerance_;
  options_.orientation_tolerance = orientation_tolerance_;
}

// ---------------------------------------------------------------- shared properties

void IKModifier::set_root_bone(const gdx::String& name) {
  std::string v = name.utf8();
  if (v == root_bone_) return;  // re-assigning the same value rebuilds nothing
  root_bone_ = std::move(v);
  mark_dirty();
}
gdx::String IKModifier::get_root_bone() const { return gdx::String(std::string_view(root_bone_)); }

void IKModifier::set_solver(int64_t solver) {
  int64_t used = std::clamp<int64_t>(solver, min_solver_value(), max_solver_value());
  if (find_solver_choice(used) == nullptr) used = kSolverAutoValue;  // a gap in the table
  if (used != solver) {
    const std::string range = std::to_string(min_solver_value()) + ".." + std::to_string(max_solver_value()) + " (" +
                              traits_.class_name + ".SOLVER_*)";
    report_clamped(traits_.class_name, "solver", range.c_str(), double(solver), double(used));
  }
  if (used == solver_) return;
  solver_ = used;
  if (traits_.solver_change_rebuilds)
    mark_dirty();
  else
    settings_changed();
}

void IKModifier::set_max_iterations(int64_t n) {
  max_iterations_ = std::clamp<int64_t>(n, 1, 1000);
  if (max_iterations_ != n)
    report_clamped(traits_.class_name, "max_iterations", "1..1000", double(n), double(max_iterations_));
  options_.max_iterations = int(max_iterations_);
}

void IKModifier::set_tolerance(double units) {
  const double used = std::isnan(units) ? tolerance_ : std::clamp(units, 1e-6, 1.0);
  if (used != units) report_clamped(traits_.class_name, "tolerance", traits_.tolerance_range, units, used);
  tolerance_ = used;
  options_.position_tolerance = tolerance_;
}

void IKModifier::set_time_budget_usec(double usec) {
  const double used = std::isnan(usec) ? time_budget_usec_ : std::clamp(usec, 0.0, 1e9);
  if (used != usec) report_clamped(traits_.class_name, "time_budget_usec", "[0, 1e+09] us (0 = none)", usec, used);
  time_budget_usec_ = used;
  options_.time_budget_usec = time_budget_usec_;
}

void IKModifier::set_orientation_tolerance(double radians) {
  const double used = std::isnan(radians) ? orientation_tolerance_ : std::clamp(radians, 1e-6, 1.0);
  if (used != radians) report_clamped(traits_.class_name, "orientation_tolerance", "[1e-06, 1] rad", radians, used);
  orientation_tolerance_ = used;
  options_.orientation_tolerance = orientation_tolerance_;
}

void IKModifier::set_deterministic(bool on) {
  deterministic_ = on;
  if (traits_.deterministic_is_cold_start) options_.warm_start = !on;
}

// ---------------------------------------------------------------- skeleton and resources

gdx::Skeleton3D IKModifier::skeleton() const {
  // Before the node enters the tree get_skeleton() has not cached it yet, so fall back to the
  // parent (the editor asks for warnings at any time).
  const gdx::SkeletonModifier3D self = gdx::SkeletonModifier3D::unchecked(owner_);
  gdx::Skeleton3D skel = self.get_skeleton();
  if (!skel) skel = gdx::Skeleton3D::cast(self.get_parent());
  return skel;
}

void IKModifier::watch_skeleton(const gdx::Skeleton3D& skel) {
  if (!skel || g_names == nullptr) return;
  const gdx::Callable callback(owner_, g_names->skeleton_changed);
  for (const gdx::StringName* signal : {&g_names->bone_list_changed, &g_names->rest_updated})
    if (!skel.is_connected(*signal, callback)) skel.connect(*signal, callback);
}

void IKModifier::skeleton_changed() {
  dirty_ = true;
  gdx::Object(owner_).notify_property_list_changed();
}

bool IKModifier::is_bone_property(GDExtensionConstStringNamePtr name) const {
  return g_names != nullptr && (g_names->root_bone.equals(name) || g_names->tip_bone.equals(name));
}

void IKModifier::bone_drop_down(GDExtensionPropertyInfo& property) const {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    property.hint = uint32_t(hint::PROPERTY_HINT_NONE);  // free text until there is a skeleton
    return;
  }
  // The same drop-down Godot's own modifiers use: "bone0,bone1,...".
  const gdx::String names(skel.get_concatenated_bone_names());
  property.hint = uint32_t(hint::PROPERTY_HINT_ENUM);
  gdx::String::assign_to(property.hint_string, names);
}

void IKModifier::listen_to(const gdx::Array& resources) { set_listening(resources, true); }

void IKModifier::stop_listening_to(const gdx::Array& resources) { set_listening(resources, false); }

void IKModifier::set_listening(const gdx::Array& resources, bool on) {
  if (g_names == nullptr) return;
  const gdx::Callable callback(owner_, g_names->resource_changed);
  for (int64_t i = 0; i < resources.size(); ++i) {
    const gdx::ObjectPtr object = object_at(resources, i);
    if (object == nullptr) continue;
    const gdx::Object resource(object);
    // Once each: a resource may stand twice in an array, or in the arrays of several nodes.
    const bool connected = resource.is_connected(g_names->changed, callback);
    if (on && !connected) resource.connect(g_names->changed, callback);
    if (!on && connected) resource.disconnect(g_names->changed, callback);
  }
}

void IKModifier::resource_changed() { on_resource_changed(); }

// ---------------------------------------------------------------- frames

void IKModifier::process_modification(double /*delta*/) {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    // Configuration problems show as the warning triangle (like Godot's own modifiers), not as
    // an error every frame.
    set_invalid_result(traits_.no_skeleton_frame);
    return;
  }
  run(skel);
}

void IKModifier::run_now() {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel)
    set_invalid_result(traits_.no_skeleton_fix);
  else
    run(skel);
}

void IKModifier::notification(int32_t what) {
  if (what == gdx::gen::kNode_NOTIFICATION_ENTER_TREE) settings_changed();
}

void IKModifier::mark_dirty() {
  dirty_ = true;
  gdx::Node::unchecked(owner_).update_configuration_warnings();
}

void IKModifier::settings_changed() { gdx::Node::unchecked(owner_).update_configuration_warnings(); }

}  // namespace ikchain::godot
