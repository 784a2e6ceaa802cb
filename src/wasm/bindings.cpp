// embind: the flat API (web_chain.hpp) as the JS module's `WebChain` class and free functions.
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

val params_of(const WebChain& c) { return float64_copy(c.params().data(), c.params().size()); }

val frames_of(WebChain& c) {
  const std::vector<double>& f = c.frames();
  return float64_copy(f.data(), f.size());
}

std::string set_params_from(WebChain& c, const val& values) {
  const std::vector<double> v = emscripten::convertJSArrayToNumberVector<double>(values);
  return c.set_params(v.data(), static_cast<int>(v.size()));
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

val result_of(const WebChain& c) { return summary_of(c.last_result()); }

// Cheap per-frame reads without building an object.
int last_iterations(const WebChain& c) { return c.last_result().iterations; }
double last_final_error(const WebChain& c) { return c.last_result().final_error; }

// --- WebTree
val tree_params_of(const WebTree& t) { return float64_copy(t.params().data(), t.params().size()); }

val tree_frames_of(WebTree& t) {
  const std::vector<double>& f = t.frames();
  return float64_copy(f.data(), f.size());
}

std::string tree_set_params_from(WebTree& t, const val& values) {
  const std::vector<double> v = emscripten::convertJSArrayToNumberVector<double>(values);
  return t.set_params(v.data(), static_cast<int>(v.size()));
}

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
int tree_last_iterations(const WebTree& t) { return t.last_result().summary.iterations; }
double tree_last_elapsed_us(const WebTree& t) { return t.last_result().summary.elapsed_us; }
double tree_last_final_error(const WebTree& t) { return t.last_result().summary.final_error; }

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

}  // namespace

EMSCRIPTEN_BINDINGS(ikchain_web) {
  using namespace emscripten;
  class_<WebChain>("WebChain")
      .constructor<>()
      .function("clearJoints", &WebChain::clear_joints)
      .function("addHinge", &WebChain::add_hinge)
      .function("addBall", &WebChain::add_ball)
      .function("setTip", &WebChain::set_tip)
      .function("build", &WebChain::build)
      .function("buildBenchChain", &WebChain::build_bench_chain)
      .function("jointCount", &WebChain::joint_count)
      .function("dofCount", &WebChain::dof_count)
      .function("totalLength", &WebChain::total_length)
      .function("clearGoals", &WebChain::clear_goals)
      .function("goalCount", &WebChain::goal_count)
      .function("addPositionGoal", &WebChain::add_position_goal)
      .function("addOrientationGoal", &WebChain::add_orientation_goal)
      .function("addAimGoal", &WebChain::add_aim_goal)
      .function("setGoalPosition", &WebChain::set_goal_position)
      .function("setGoalOrientation", &WebChain::set_goal_orientation)
      .function("setGoalAimDirection", &WebChain::set_goal_aim_direction)
      .function("setMaxIterations", &WebChain::set_max_iterations)
      .function("setTolerances", &WebChain::set_tolerances)
      .function("setWarmStart", &WebChain::set_warm_start)
      .function("setMaxStepAngle", &WebChain::set_max_step_angle)
      .function("setTimeBudgetUsec", &WebChain::set_time_budget_usec)
      .function("setTimeCapUsec", &WebChain::set_time_cap_usec)
      .function("setMaxRestarts", &WebChain::set_max_restarts)
      .function("setRestartSeed", &WebChain::set_restart_seed)
      .function("solve", &WebChain::solve)
      .function("resetPose", &WebChain::reset_pose)
      .function("result", &result_of)
      .function("lastIterations", &last_iterations)
      .function("lastFinalError", &last_final_error)
      .function("params", &params_of)
      .function("setParams", &set_params_from)
      .function("frames", &frames_of);
  class_<WebTree>("WebTree")
      .constructor<>()
      .function("clear", &WebTree::clear)
      .function("addBall", &WebTree::add_ball)
      .function("addHinge", &WebTree::add_hinge)
      .function("addEffector", &WebTree::add_effector)
      .function("setFloatingRoot", &WebTree::set_floating_root)
      .function("build", &WebTree::build)
      .function("jointCount", &WebTree::joint_count)
      .function("dofCount", &WebTree::dof_count)
      .function("effectorCount", &WebTree::effector_count)
      .function("clearGoals", &WebTree::clear_goals)
      .function("goalCount", &WebTree::goal_count)
      .function("addPositionGoal", &WebTree::add_position_goal)
      .function("addOrientationGoal", &WebTree::add_orientation_goal)
      .function("addAimGoal", &WebTree::add_aim_goal)
      .function("setGoalPosition", &WebTree::set_goal_position)
      .function("setGoalOrientation", &WebTree::set_goal_orientation)
      .function("setGoalAimDirection", &WebTree::set_goal_aim_direction)
      .function("setPosture", &tree_set_posture_from)
      .function("clearPosture", &WebTree::clear_posture)
      .function("setPostureIterations", &WebTree::set_posture_iterations)
      .function("setMaxIterations", &WebTree::set_max_iterations)
      .function("setTolerances", &WebTree::set_tolerances)
      .function("setWarmStart", &WebTree::set_warm_start)
      .function("setTimeBudgetUsec", &WebTree::set_time_budget_usec)
      .function("setTimeCapUsec", &WebTree::set_time_cap_usec)
      .function("solve", &WebTree::solve)
      .function("resetPose", &WebTree::reset_pose)
      .function("result", &tree_result_of)
      .function("goalErrorsInto", &tree_goal_errors_into)
      .function("lastIterations", &tree_last_iterations)
      .function("lastElapsedUs", &tree_last_elapsed_us)
      .function("lastFinalError", &tree_last_final_error)
      .function("params", &tree_params_of)
      .function("setParams", &tree_set_params_from)
      .function("frames", &tree_frames_of);
  function("benchMaxIterations", &ikchain::web::bench_max_iterations);
  function("benchTargets", &bench_targets_js);
  function("convergenceTrace", &convergence_trace_js);
  function("precisionRun", &precision_run_js);
}
