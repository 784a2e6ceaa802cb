// embind: the flat APIs (web_chain.hpp, web_tree.hpp) as the JS module's `WebChain` and `WebTree`
// classes and free functions.
// Arrays cross as Float64Array copies; results as plain objects.
#include <emscripten/bind.h>
#include <emscripten/val.h>

#include <algorithm>

#include "wasm/web_chain.hpp"
#include "wasm/web_tree.hpp"

namespace {

using emscripten::val;
using ikchain::web::WebChain;
using ikchain::web::WebTree;

val float64_copy(const double* data, size_t count) {
  // A view into wasm memory is invalidated by memory growth: hand JS its own copy.
  return val(emscripten::typed_memory_view(count, data)).call<val>("slice");
}

// What both classes read and take alike (templates over WebChain and WebTree).
template <class W>
val params_of(const W& w) {
  return float64_copy(w.params().data(), w.params().size());
}

template <class W>
val frames_of(W& w) {
  const std::vector<double>& f = w.frames();
  return float64_copy(f.data(), f.size());
}

template <class W>
std::string set_params_from(W& w, const val& values) {
  const std::vector<double> v = emscripten::convertJSArrayToNumberVector<double>(values);
  return w.set_params(v.data(), static_cast<int>(v.size()));
}

val summary_of(const ikchain::SolveResult& r) {
  val out = val::object();
  out.set("reason", std::string(ikchain::to_string(r.reason)));
  out.set("usable", r.usable());
  out.set("iterations", r.iterations);
  out.set("initialError", r.initial_error);
  out.set("finalError", r.final_error);
  out.set("initialPositionError", r.initial_position_error);
  out.set("finalPositionError", r.final_position_error);
  out.set("initialOrientationError", r.initial_orientation_error);
  out.set("finalOrientationError", r.final_orientation_error);
  out.set("elapsedUs", r.elapsed_us);
  out.set("budgetExhausted", r.budget_exhausted);
  out.set("restarts", r.restarts);
  out.set("escapes", r.escapes);
  out.set("message", std::string(r.message.c_str()));
  return out;
}

// A chain's result is its summary; a tree's result holds one.
const ikchain::SolveResult& summary(const WebChain& c) { return c.last_result(); }
const ikchain::SolveResult& summary(const WebTree& t) { return t.last_result().summary; }

val result_of(const WebChain& c) { return summary_of(c.last_result()); }

// Cheap per-frame reads without building an object.
template <class W>
int last_iterations(const W& w) {
  return summary(w).iterations;
}
template <class W>
double last_final_error(const W& w) {
  return summary(w).final_error;
}

// --- WebTree

std::string tree_set_posture_from(WebTree& t, const val& values, double stiffness) {
  const std::vector<double> v = emscripten::convertJSArrayToNumberVector<double>(values);
  return t.set_posture(v.data(), static_cast<int>(v.size()), stiffness);
}

// The whole result: the summary's fields, the per-goal errors (problem order) and per-level met flags.
val tree_result_of(const WebTree& t) {
  const ikchain::TreeSolveResult& r = t.last_result();
  val out = summary_of(r.summary);
  out.set("goalErrors", float64_copy(r.goal_error.data(), static_cast<size_t>(r.goal_count)));
  val levels = val::array();
  for (bool met : r.level_met) levels.call<void>("push", met);
  out.set("levelMet", levels);
  return out;
}

// Cheap per-frame reads: the goal errors into a caller's Float64Array (no object built).
void tree_goal_errors_into(const WebTree& t, val out) {
  const ikchain::TreeSolveResult& r = t.last_result();
  const int n = std::min(r.goal_count, out["length"].as<int>());
  for (int i = 0; i < n; ++i) out.set(i, r.goal_error[i]);
}
double tree_last_elapsed_us(const WebTree& t) { return summary(t).elapsed_us; }

val bench_targets_js(int joints, int count, unsigned seed) {
  const std::vector<double> t = ikchain::web::bench_targets(joints, count, seed);
  return float64_copy(t.data(), t.size());
}

val convergence_trace_js(int solver_kind) {
  const ikchain::web::ConvergenceTrace t = ikchain::web::convergence_trace(solver_kind);
  val out = val::object();
  out.set("errors", float64_copy(t.errors.data(), t.errors.size()));
  out.set("stopped", t.stopped);
  out.set("tolerance", t.tolerance);
  return out;
}

val precision_run_js(int solver_kind, bool planar) {
  const ikchain::web::PrecisionRun p = ikchain::web::precision_run(solver_kind, planar);
  val out = val::object();
  out.set("distance", p.distance);
  out.set("reason", p.reason);
  out.set("iterations", p.iterations);
  return out;
}

// The methods both classes have, under the same JS names.
template <class W>
const emscripten::class_<W>& bind_common(const emscripten::class_<W>& c) {
  // embind registers a method on the class its member pointer names: the bases' members are
  // bound as members of W.
  using Options = ikchain::web::WebOptions;
  using Goals = ikchain::web::WebGoalUpdates<W>;
  return c.function("build", &W::build)
      .function("jointCount", &W::joint_count)
      .function("dofCount", &W::dof_count)
      .function("clearGoals", &W::clear_goals)
      .function("goalCount", &W::goal_count)
      .function("setGoalPosition", static_cast<bool (W::*)(int, double, double, double)>(&Goals::set_goal_position))
      .function("setGoalOrientation",
                static_cast<bool (W::*)(int, double, double, double, double)>(&Goals::set_goal_orientation))
      .function("setGoalAimDirection",
                static_cast<bool (W::*)(int, double, double, double)>(&Goals::set_goal_aim_direction))
      .function("setMaxIterations", static_cast<void (W::*)(int)>(&Options::set_max_iterations))
      .function("setTolerances", static_cast<void (W::*)(double, double)>(&Options::set_tolerances))
      .function("setWarmStart", static_cast<void (W::*)(bool)>(&Options::set_warm_start))
      .function("setTimeBudgetUsec", static_cast<void (W::*)(double)>(&Options::set_time_budget_usec))
      .function("setTimeCapUsec", static_cast<void (W::*)(double)>(&Options::set_time_cap_usec))
      .function("solve", &W::solve)
      .function("resetPose", &W::reset_pose)
      .function("lastIterations", &last_iterations<W>)
      .function("lastFinalError", &last_final_error<W>)
      .function("params", &params_of<W>)
      .function("setParams", &set_params_from<W>)
      .function("frames", &frames_of<W>);
}

}  // namespace

EMSCRIPTEN_BINDINGS(ikchain_web) {
  using namespace emscripten;
  bind_common(class_<WebChain>("WebChain").constructor<>())
      .function("clearJoints", &WebChain::clear_joints)
      .function("addHinge", &WebChain::add_hinge)
      .function("addBall", &WebChain::add_ball)
      .function("setTip", &WebChain::set_tip)
      .function("buildBenchChain", &WebChain::build_bench_chain)
      .function("totalLength", &WebChain::total_length)
      .function("addPositionGoal", &WebChain::add_position_goal)
      .function("addOrientationGoal", &WebChain::add_orientation_goal)
      .function("addAimGoal", &WebChain::add_aim_goal)
      .function("setMaxStepAngle", &WebChain::set_max_step_angle)
      .function("setMaxRestarts", &WebChain::set_max_restarts)
      .function("setRestartSeed", &WebChain::set_restart_seed)
      .function("result", &result_of);
  bind_common(class_<WebTree>("WebTree").constructor<>())
      .function("clear", &WebTree::clear)
      .function("addBall", &WebTree::add_ball)
      .function("addHinge", &WebTree::add_hinge)
      .function("addEffector", &WebTree::add_effector)
      .function("setFloatingRoot", &WebTree::set_floating_root)
      .function("effectorCount", &WebTree::effector_count)
      .function("addPositionGoal", &WebTree::add_position_goal)
      .function("addOrientationGoal", &WebTree::add_orientation_goal)
      .function("addAimGoal", &WebTree::add_aim_goal)
      .function("setPosture", &tree_set_posture_from)
      .function("clearPosture", &WebTree::clear_posture)
      .function("setPostureIterations", &WebTree::set_posture_iterations)
      .function("result", &tree_result_of)
      .function("goalErrorsInto", &tree_goal_errors_into)
      .function("lastElapsedUs", &tree_last_elapsed_us);
  function("benchMaxIterations", &ikchain::web::bench_max_iterations);
  function("benchTargets", &bench_targets_js);
  function("convergenceTrace", &convergence_trace_js);
  function("precisionRun", &precision_run_js);
}
