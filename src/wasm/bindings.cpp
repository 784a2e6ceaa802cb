// embind: the flat API (web_chain.hpp) as the JS module's `WebChain` class and free functions.
// Arrays cross as Float64Array copies; results as plain objects.
#include <emscripten/bind.h>
#include <emscripten/val.h>

#include "wasm/web_chain.hpp"

namespace {

using emscripten::val;
using ikchain::web::WebChain;

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

val result_of(const WebChain& c) {
  const ikchain::SolveResult& r = c.last_result();
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

// Cheap per-frame reads without building an object.
int last_iterations(const WebChain& c) { return c.last_result().iterations; }
double last_final_error(const WebChain& c) { return c.last_result().final_error; }

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
  function("benchMaxIterations", &ikchain::web::bench_max_iterations);
  function("benchTargets", &bench_targets_js);
  function("convergenceTrace", &convergence_trace_js);
  function("precisionRun", &precision_run_js);
}
