#include "wasm/web_chain.hpp"

#include "wasm/bench_cases.hpp"

namespace ikchain {
namespace web {

void WebChain::clear_joints() { builder_.clear(); }

void WebChain::add_hinge(double ox, double oy, double oz, double ax, double ay, double az, bool limited,
                         double min_angle, double max_angle) {
  JointDesc j;
  j.type = JointType::kHinge;
  j.offset_translation = glm::dvec3(ox, oy, oz);
  j.axis = glm::dvec3(ax, ay, az);
  set_hinge_limits(j.limits, limited, min_angle, max_angle);
  builder_.add_joint(j);
}

void WebChain::add_ball(double ox, double oy, double oz, bool limited, double cone_angle, double twist_min,
                        double twist_max) {
  JointDesc j;
  j.type = JointType::kBall;
  j.offset_translation = glm::dvec3(ox, oy, oz);
  set_ball_limits(j.limits, limited, cone_angle, twist_min, twist_max);
  builder_.add_joint(j);
}

void WebChain::set_tip(double x, double y, double z) { builder_.set_tip_offset(glm::dvec3(x, y, z)); }

std::string WebChain::build() {
  Chain built;
  const Message m = builder_.build(built).message;
  if (!m.empty()) return m.c_str();
  chain_ = built;
  // Sized once here: solves then allocate nothing.
  workspace_.reset(chain_, kMaxGoals);
  fk_workspace_.reset(chain_, 1);
  params_ = Eigen::VectorXd::Zero(chain_.dof_count());
  frames_.assign(7 * chain_.joint_count() + 3, 0.0);
  result_ = SolveResult();
  for (Goal& g : goals_)  // effectors beyond the new chain fall back to its tip
    if (g.effector > chain_.joint_count()) g.effector = 0;
  return "";
}

std::string WebChain::build_bench_chain(int joints, bool planar) {
  if (joints < 1 || joints > 1000) return "joints must be in 1..1000, got " + std::to_string(joints);
  builder_.clear();
  Chain probe;
  const Message m = bench_cases::make_hinge_chain(joints, planar, 1.0, probe);
  if (!m.empty()) return m.c_str();
  for (int i = 0; i < joints; ++i) {
    const glm::dvec3 axis = probe.axis(i);
    const glm::dvec3 offset = probe.offset_translation(i);
    add_hinge(offset.x, offset.y, offset.z, axis.x, axis.y, axis.z, false, 0.0, 0.0);
  }
  const glm::dvec3 tip = probe.tip_offset();
  set_tip(tip.x, tip.y, tip.z);
  return build();
}

std::string WebChain::add_goal(const Goal& goal) {
  if (goal_count() >= kMaxGoals)
    return "goals: at most " + std::to_string(kMaxGoals) + " goals; call clearGoals() first";
  goals_.push_back(goal);
  return "";
}

std::string WebChain::add_position_goal(double x, double y, double z, int effector, double weight) {
  return add_goal(Goal::position(glm::dvec3(x, y, z), effector, weight));
}

std::string WebChain::add_orientation_goal(double qx, double qy, double qz, double qw, int effector,
                                           double weight) {
  return add_goal(orientation_goal(qx, qy, qz, qw, effector, weight));
}

std::string WebChain::add_aim_goal(double axis_x, double axis_y, double axis_z, double dir_x, double dir_y,
                                   double dir_z, int effector, double weight) {
  return add_goal(aim_goal(axis_x, axis_y, axis_z, dir_x, dir_y, dir_z, effector, weight));
}

int WebChain::solve(int solver_kind) {
  // The core validates everything (chain built, goals, options, kind) and names the bad field.
  result_ = ikchain::solve(static_cast<SolverKind>(solver_kind), chain_, Span<const Goal>(goals_), options_,
                           workspace_, params_);
  return static_cast<int>(result_.reason);
}

void WebChain::reset_pose() { params_.setZero(); }

std::string WebChain::set_params(const double* values, int count) {
  std::string error = check_dof_values("params", values, count, chain_.dof_count());
  if (!error.empty()) return error;
  for (int i = 0; i < count; ++i) params_[i] = values[i];
  return "";
}

const std::vector<double>& WebChain::frames() {
  if (!chain_.valid()) {
    frames_.clear();
    return frames_;
  }
  forward_kinematics(chain_, params_.data(), fk_workspace_);
  double* tip = write_joint_frames(fk_workspace_.joint_origins.data(), fk_workspace_.joint_orientations.data(),
                                   chain_.joint_count(), frames_.data());
  write_point(fk_workspace_.tip, tip);
  return frames_;
}

// ------------------------------------------------------------------------------ benchmark cases

int bench_max_iterations(int solver_kind) {
  return bench_cases::max_iterations_for(static_cast<SolverKind>(solver_kind));
}

std::vector<double> bench_targets(int joints, int count, unsigned seed) {
  std::vector<double> out;
  Chain chain;
  if (joints < 1 || count < 1 || !bench_cases::make_hinge_chain(joints, false, 1.0, chain).empty()) return out;
  for (const glm::dvec3& t : bench_cases::random_targets(chain, count, seed)) {
    out.push_back(t.x);
    out.push_back(t.y);
    out.push_back(t.z);
  }
  return out;
}

ConvergenceTrace convergence_trace(int solver_kind) {
  ConvergenceTrace trace;
  trace.stopped = "budget";
  WebChain c;
  c.build_bench_chain(bench_cases::kConvergenceJoints, false);
  Chain probe;
  bench_cases::make_hinge_chain(bench_cases::kConvergenceJoints, false, 1.0, probe);
  const glm::dvec3 target = bench_cases::random_targets(probe, 1, bench_cases::kConvergenceSeed)[0];
  trace.tolerance = bench_cases::kRelTolerance * c.total_length();
  c.set_tolerances(trace.tolerance, c.options().orientation_tolerance);
  c.set_warm_start(false);
  // Every budget runs in full: the core's 50 ms CPU-time cap would make the figure depend on
  // how busy the machine is.
  c.set_time_cap_usec(0.0);
  c.add_position_goal(target.x, target.y, target.z, 0, 1.0);
  trace.errors.push_back(glm::length(probe.rest_tip() - target));  // k = 0
  const int max_k = std::min(bench_cases::max_iterations_for(static_cast<SolverKind>(solver_kind)),
                             bench_cases::kConvergenceMaxBudget);
  for (int k = 1; k <= max_k; ++k) {
    c.set_max_iterations(k);
    c.solve(solver_kind);
    const SolveResult& r = c.last_result();
    if (!r.usable()) {
      trace.stopped = r.message.c_str();
      break;
    }
    trace.errors.push_back(r.final_position_error);
    if (r.iterations < k) {
      trace.stopped = to_string(r.reason);
      break;
    }
  }
  return trace;
}

PrecisionRun precision_run(int solver_kind, bool planar) {
  PrecisionRun run;
  WebChain c;
  c.build_bench_chain(bench_cases::kPrecisionJoints, planar);
  Chain probe;
  bench_cases::make_hinge_chain(bench_cases::kPrecisionJoints, planar, 1.0, probe);
  const bench_cases::PrecisionCase pc = bench_cases::precision_case(probe, planar);
  c.set_params(pc.start.data(), static_cast<int>(pc.start.size()));
  c.set_tolerances(bench_cases::kRelTolerance * c.total_length(), c.options().orientation_tolerance);
  c.set_warm_start(true);
  c.set_max_iterations(bench_cases::max_iterations_for(static_cast<SolverKind>(solver_kind)));
  c.set_time_cap_usec(0.0);  // as in convergence_trace: the iteration budget alone ends the run
  c.add_position_goal(pc.target.x, pc.target.y, pc.target.z, 0, 1.0);
  c.solve(solver_kind);
  const SolveResult& r = c.last_result();
  run.distance = r.final_position_error;
  run.reason = r.usable() ? to_string(r.reason) : r.message.c_str();
  run.iterations = r.iterations;
  return run;
}

}  // namespace web
}  // namespace ikchain
