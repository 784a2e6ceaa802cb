// libFuzzer target over the core's public entry points: ChainBuilder::build and solve(), every
// solver, with hostile chains, goals, options and start poses. Built by `scripts/fuzz` with clang
// (-fsanitize=fuzzer,address,undefined); any violated property aborts with a message naming it.
//
// Properties (each an abort when broken):
//  - no crash and no sanitizer report;
//  - a chain that builds derives only finite data (lengths, unit rest rotations, rest-pose FK);
//    a build that fails says why;
//  - no NaN/inf in any output (result fields, params);
//  - invalid input: params bit-identical to the input and a non-empty message;
//  - iterations <= max_iterations per run (the first and each restart), restarts <= max_restarts;
//  - solving the same input again on the same workspace gives the same verdict and pose, bit for bit;
//  - the returned pose respects the joint limits;
//  - "converged" => every goal within tolerance by an independent FK (plain GLM, none of the core's
//    fast paths), and the reported final error agrees with that FK;
//  - the returned pose is never worse than the start pose by the solve's own objective
//    0.5 * sum w |e|^2, both measured by the independent FK;
//  - the time budget (on a fake clock advancing a fuzzed tick per reading, so every run is
//    reproducible): the solve reads the clock no more after the reading that found the budget spent
//    (it is checked before every iteration and in the long inner loops, and nothing after it reads
//    the clock; the reading finds it spent at the budget's end, or before it when the next stretch
//    and the exit work would end past the bound: Deadline::foreseen), budget_exhausted says exactly
//    whether that reading came, and it comes only with max_iterations or unreachable (result.hpp);
//  - work per clock reading (issue 16, item 6): with a budget, no stretch of work between two clock
//    readings, nor the exit work after the last, is longer than Deadline::stretch_bound of the
//    problem's size (the kernels' charged flops: deterministic, so a finding replays exactly).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "ikchain/ikchain.hpp"
#include "ikchain/kinematics.hpp"

using namespace ikchain;

namespace {

[[noreturn]] void fail(const char* what, double a = 0.0, double b = 0.0) {
  std::fprintf(stderr, "FUZZ PROPERTY VIOLATED: %s (%.17g, %.17g)\n", what, a, b);
  std::abort();
}
#define REQUIRE(cond, ...) \
  do {                     \
    if (!(cond)) fail(__VA_ARGS__); \
  } while (0)

// A double that is usually ordinary (within +-scale) and sometimes hostile.
double pick(FuzzedDataProvider& d, double scale) {
  switch (d.ConsumeIntegralInRange<int>(0, 15)) {
    case 0: return 0.0;
    case 1: return std::numeric_limits<double>::quiet_NaN();
    case 2: return std::numeric_limits<double>::infinity();
    case 3: return -std::numeric_limits<double>::infinity();
    case 4: return (d.ConsumeBool() ? 1 : -1) * std::pow(10.0, d.ConsumeIntegralInRange<int>(3, 308));
    case 5: return (d.ConsumeBool() ? 1 : -1) * std::pow(10.0, -d.ConsumeIntegralInRange<int>(3, 320));
    case 6: {
      const uint64_t bits = d.ConsumeIntegral<uint64_t>();
      double v;
      std::memcpy(&v, &bits, sizeof v);
      return v;
    }
    case 7: return scale;
    default: return d.ConsumeFloatingPointInRange<double>(-scale, scale);
  }
}

// Mostly ordinary values: a hostile component only when the fuzzer asks for one.
double pick_mostly(FuzzedDataProvider& d, double scale) {
  return d.ConsumeIntegralInRange<int>(0, 3) == 0 ? pick(d, scale)
                                                  : d.ConsumeFloatingPointInRange<double>(-scale, scale);
}

glm::dvec3 pick_vec(FuzzedDataProvider& d, double scale) {
  const double x = pick_mostly(d, scale), y = pick_mostly(d, scale), z = pick_mostly(d, scale);
  return glm::dvec3(x, y, z);
}

// The fake clock every solve here runs on (Deadline::clock_us): g_tick microseconds per reading.
double g_now = 0.0, g_previous = 0.0;  // the last reading and the one before it
double g_tick = 1.0;
double fake_clock() {
  g_previous = g_now;
  return g_now += g_tick;
}

bool all_finite(double v) { return std::isfinite(v); }
bool all_finite(const glm::dvec3& v) { return all_finite(v.x) && all_finite(v.y) && all_finite(v.z); }
bool all_finite(const glm::dquat& q) { return all_finite(q.w) && all_finite(q.x) && all_finite(q.y) && all_finite(q.z); }

// ---------------------------------------------------------------- independent forward kinematics
// The chain's definition (chain.hpp) in plain GLM: no direction codes, no fast sincos, no cached
// rest pose. Computed from the JointDescs as given (rest rotations normalised here).
struct Pose {
  std::vector<glm::dvec3> origins;
  std::vector<glm::dquat> orientations;
  glm::dvec3 tip{0.0};
};

// Normalised without overflow in the squares: divide by the largest component first.
template <typename V>
V unit(const V& v) {
  double m = 0.0;
  for (int i = 0; i < V::length(); ++i) m = std::max(m, std::abs(v[i]));
  return glm::normalize(v / m);
}

Pose reference_fk(const std::vector<JointDesc>& joints, const glm::dvec3& tip_offset, const double* params) {
  Pose pose;
  glm::dvec3 origin(0.0);
  glm::dquat q(1.0, 0.0, 0.0, 0.0);
  int o = 0;
  for (const JointDesc& j : joints) {
    origin += q * j.offset_translation;
    q = q * unit(j.rest_rotation);
    if (j.type == JointType::kHinge) {
      q = q * glm::angleAxis(params[o], unit(j.axis));
      o += 1;
    } else if (j.type == JointType::kPrismatic) {
      // The slide moves what comes after the joint, along its axis in the joint's frame.
      pose.origins.push_back(origin);
      pose.orientations.push_back(q);
      origin += q * (unit(j.axis) * params[o]);
      o += 1;
      continue;
    } else {
      const glm::dvec3 r(params[o], params[o + 1], params[o + 2]);
      const double angle = glm::length(r);
      if (angle > 0.0) q = q * glm::angleAxis(angle, r / angle);
      o += 3;
    }
    pose.origins.push_back(origin);
    pose.orientations.push_back(q);
  }
  pose.tip = origin + q * tip_offset;
  return pose;
}

// cost: 0.5 * sum w |e|^2. An aim-at goal whose effector lies on the on-point radius, within
// the two FKs' rounding (`position_slack`), may be on the point by one FK and off it by the other:
// its error is 0 or the angle (kinematics.hpp), so the cost is known only between cost_low (0)
// and cost (the angle), and max_orientation takes the 0. Solvers do end there: a goal pulling the
// effector away from the point meets the aim-at cost's jump at that radius, and descent stops on it.
struct Errors {
  double cost = 0.0;
  double cost_low = 0.0;
  double max_position = 0.0;
  double max_orientation = 0.0;
};

double angle_between(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

// chain_length: the chain's total length, for the aim-at rule below; position_slack: how far the
// two FKs' positions may differ by rounding.
Errors reference_errors(const Pose& pose, const std::vector<Goal>& goals, double chain_length,
                        double position_slack) {
  Errors out;
  const int n = static_cast<int>(pose.origins.size());
  for (const Goal& g : goals) {
    const int k = g.effector <= 0 ? n : g.effector;
    const glm::dquat eff_q = pose.orientations[k - 1];
    double e = 0.0;
    switch (g.kind) {
      case GoalKind::kPosition:
        e = glm::length(g.target_position - (k == n ? pose.tip : pose.origins[k]));
        out.max_position = std::max(out.max_position, e);
        break;
      case GoalKind::kOrientation: {
        // unit(): a finite target of huge components is a valid rotation (issue 16, item 2).
        const glm::dquat d = unit(g.target_orientation) * glm::conjugate(eff_q);
        e = 2.0 * std::atan2(glm::length(glm::dvec3(d.x, d.y, d.z)), std::abs(d.w));
        out.max_orientation = std::max(out.max_orientation, e);
        break;
      }
      case GoalKind::kAim:
        e = angle_between(glm::normalize(eff_q * g.aim_axis), glm::normalize(g.aim_direction));
        out.max_orientation = std::max(out.max_orientation, e);
        break;
      case GoalKind::kAimAt: {
        // The direction from the effector to the point; an effector on the point (nearer than
        // kAimAtOnPoint of chain length + |point|, kinematics.hpp) has no direction and counts as met.
        const glm::dvec3 to_point = g.target_position - (k == n ? pose.tip : pose.origins[k]);
        const double on_point = kAimAtOnPoint * (chain_length + glm::length(g.target_position));
        const double distance = glm::length(to_point);
        const double angle = angle_between(glm::normalize(eff_q * g.aim_axis), to_point);
        e = distance > on_point ? angle : 0.0;
        if (std::abs(distance - on_point) <= position_slack) {
          // On the radius: cost takes the angle, cost_low and max_orientation the 0.
          out.cost += 0.5 * g.weight * angle * angle;
          continue;
        }
        out.max_orientation = std::max(out.max_orientation, e);
        break;
      }
    }
    out.cost += 0.5 * g.weight * e * e;
    out.cost_low += 0.5 * g.weight * e * e;
  }
  return out;
}

// With IKCHAIN_FUZZ_STATS set, how many inputs ended in each verdict, per solver (printed at exit):
// shows that the fuzzer gets past validation into every solver, not only into the rejections.
long g_verdicts[kSolverKindCount + 1][5] = {};
void print_stats() {
  std::fprintf(stderr, "verdicts per solver (converged max_iterations stalled unreachable invalid_input):\n");
  for (int k = 0; k <= kSolverKindCount; ++k) {
    std::fprintf(stderr, "  %-14s", k < kSolverKindCount ? to_string(static_cast<SolverKind>(k)) : "unknown kind");
    for (long v : g_verdicts[k]) std::fprintf(stderr, " %8ld", v);
    std::fprintf(stderr, "\n");
  }
}
void count(SolverKind kind, TerminationReason reason) {
  static const bool enabled = [] {
    const bool on = std::getenv("IKCHAIN_FUZZ_STATS") != nullptr;
    if (on) std::atexit(print_stats);
    return on;
  }();
  if (!enabled) return;
  const int k = static_cast<int>(kind);
  ++g_verdicts[k >= 0 && k < kSolverKindCount ? k : kSolverKindCount][static_cast<int>(reason)];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider d(data, size);

  // ---------------------------------------------------------------- the chain
  const int size_class = d.ConsumeIntegralInRange<int>(0, 15);
  const int n = size_class < 14 ? d.ConsumeIntegralInRange<int>(0, 12) : d.ConsumeIntegralInRange<int>(0, 200);
  std::vector<JointDesc> joints(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    JointDesc& j = joints[i];
    const int type = d.ConsumeIntegralInRange<int>(0, 9);
    j.type = type < 4   ? JointType::kBall
             : type < 7 ? JointType::kHinge
             : type < 9 ? JointType::kPrismatic
                        : static_cast<JointType>(7);
    if (i > 0 || d.ConsumeBool()) j.offset_translation = pick_vec(d, 2.0);
    if (d.ConsumeBool()) {
      j.rest_rotation = glm::dquat(pick_mostly(d, 2.0), pick_mostly(d, 2.0), pick_mostly(d, 2.0), pick_mostly(d, 2.0));
    }
    if (d.ConsumeBool()) j.axis = pick_vec(d, 1.0);
    const uint8_t lim = d.ConsumeIntegral<uint8_t>();
    JointLimits& l = j.limits;
    if (lim & 1) {  // the one param's range: a hinge's angle, a slide's metres
      const double low = pick_mostly(d, 4.0), high = pick_mostly(d, 4.0);
      if (j.type == JointType::kPrismatic) {
        l.has_slide_limit = true;
        l.slide_min = low;
        l.slide_max = high;
      } else {
        l.has_hinge_limit = true;
        l.hinge_min = low;
        l.hinge_max = high;
      }
    }
    if (lim & 2) {
      l.has_cone_limit = true;
      l.cone_angle = pick_mostly(d, 4.0);
    }
    if (lim & 4) {
      l.has_twist_limit = true;
      l.twist_min = pick_mostly(d, 4.0);
      l.twist_max = pick_mostly(d, 4.0);
    }
    if (lim & 8) l.twist_axis = pick_vec(d, 1.0);
  }
  const glm::dvec3 tip_offset = d.ConsumeBool() ? pick_vec(d, 2.0) : glm::dvec3(0.0, 1.0, 0.0);

  ChainBuilder builder;
  for (const JointDesc& j : joints) builder.add_joint(j);
  builder.set_tip_offset(tip_offset);
  Chain chain;
  const Message built = builder.build(chain).message;
  if (!built.empty()) {
    REQUIRE(!chain.valid(), "a failed build left a valid chain");
  } else {
    REQUIRE(chain.valid() && chain.joint_count() == n, "build succeeded but the chain is not valid");
  }

  // Derived data of a chain that builds: all finite, rest rotations unit.
  if (chain.valid()) {
    REQUIRE(all_finite(chain.total_length()) && chain.total_length() > 0.0, "total_length", chain.total_length());
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      REQUIRE(all_finite(chain.bone_length(i)), "bone_length", i, chain.bone_length(i));
      sum += chain.bone_length(i);
      const glm::dquat& r = chain.rest_rotation(i);
      REQUIRE(all_finite(r) && std::abs(glm::length(r) - 1.0) < 1e-9, "rest_rotation not unit", i, glm::length(r));
      REQUIRE(all_finite(chain.rest_joint_origins()[i]), "rest joint origin", i);
      REQUIRE(all_finite(chain.axis(i)), "axis", i);
      REQUIRE(all_finite(chain.limits(i).twist_axis), "twist_axis", i);
    }
    REQUIRE(all_finite(sum), "bone lengths sum", sum);
    for (const glm::dvec3& a : chain.rest_dof_axes()) REQUIRE(all_finite(a), "rest dof axis");
    REQUIRE(all_finite(chain.rest_tip()), "rest tip");
  }

  // ---------------------------------------------------------------- the goals
  const int goal_count = d.ConsumeIntegralInRange<int>(0, 5);
  std::vector<Goal> goals(static_cast<size_t>(goal_count));
  const double reach = chain.valid() ? chain.total_length() : 2.0;
  // Reachable goals too (so "converged" is claimed often enough to be checked): the pose of a
  // random configuration, by the independent FK.
  Pose reachable;
  if (chain.valid()) {
    std::vector<double> q(static_cast<size_t>(chain.dof_count()));
    for (double& v : q) v = d.ConsumeFloatingPointInRange<double>(-3.0, 3.0);
    reachable = reference_fk(joints, tip_offset, q.data());
  }
  for (Goal& g : goals) {
    const int kind = d.ConsumeIntegralInRange<int>(0, 14);
    g.kind = kind < 6    ? GoalKind::kPosition
             : kind < 9  ? GoalKind::kOrientation
             : kind < 11 ? GoalKind::kAim
             : kind < 14 ? GoalKind::kAimAt
                         : static_cast<GoalKind>(9);
    g.effector = d.ConsumeIntegralInRange<int>(0, 7) == 0 ? d.ConsumeIntegralInRange<int>(-3, n + 3)
                                                          : d.ConsumeIntegralInRange<int>(0, n > 0 ? n : 0);
    g.weight = d.ConsumeIntegralInRange<int>(0, 3) == 0 ? pick(d, 10.0) : 1.0;
    g.target_position = pick_vec(d, 1.5 * reach);
    g.target_orientation =
        glm::dquat(pick_mostly(d, 1.0), pick_mostly(d, 1.0), pick_mostly(d, 1.0), pick_mostly(d, 1.0));
    g.aim_axis = pick_vec(d, 1.0);
    g.aim_direction = pick_vec(d, 1.0);
    if (chain.valid() && g.effector >= 0 && g.effector <= n && d.ConsumeBool()) {
      const int k = g.effector == 0 ? n : g.effector;
      g.target_position = k == n ? reachable.tip : reachable.origins[k];
      g.target_orientation = reachable.orientations[k - 1];
      g.aim_direction = reachable.orientations[k - 1] * g.aim_axis;
    }
  }

  // ---------------------------------------------------------------- the options
  SolverOptions o;
  const uint32_t mask = d.ConsumeIntegral<uint32_t>();
  auto maybe = [&](int bit) { return (mask >> bit) & 1u; };
  // Bounded: a legal budget of 2^31 iterations is the caller's choice, not a finding.
  if (maybe(0)) o.max_iterations = d.ConsumeIntegralInRange<int>(-2, 300);
  if (maybe(1)) o.position_tolerance = pick(d, 1e-3);
  if (maybe(2)) o.orientation_tolerance = pick(d, 1e-3);
  if (maybe(3)) o.stall_tolerance = pick(d, 1e-6);
  if (maybe(4)) o.warm_start = false;
  if (maybe(5)) o.max_step_angle = pick(d, 1.0);
  if (maybe(6)) o.pinv_residual_tolerance = pick(d, 1.0);
  if (maybe(7)) {
    o.pinv_max_halvings = d.ConsumeBool() ? d.ConsumeIntegralInRange<int>(-2, 100) : d.ConsumeIntegral<int>();
  }
  if (maybe(8)) o.pinv_singular_threshold = pick(d, 1e-6);
  if (maybe(9)) o.dls_initial_damping = pick(d, 1.0);
  if (maybe(10)) o.dls_min_damping = pick(d, 1e-6);
  if (maybe(11)) o.dls_max_damping = pick(d, 1e6);
  if (maybe(12)) o.bfgs_wolfe_c1 = pick(d, 1.0);
  if (maybe(13)) o.bfgs_wolfe_c2 = pick(d, 1.0);
  if (maybe(14)) {
    o.bfgs_max_line_search_steps =
        d.ConsumeBool() ? d.ConsumeIntegralInRange<int>(-2, 100) : d.ConsumeIntegral<int>();
  }
  if (maybe(15)) {
    o.use_pole = true;
    o.pole_in_base = glm::dvec3(pick_mostly(d, reach), pick_mostly(d, reach), pick_mostly(d, reach));
  }
  // Budgets and restarts: small, so a run stays fast (the budget's overrun is checked below).
  if (maybe(20)) o.time_budget_usec = d.ConsumeBool() ? pick(d, 200.0) : d.ConsumeFloatingPointInRange(0.0, 50.0);
  if (maybe(22)) o.time_cap_usec = d.ConsumeBool() ? pick(d, 200.0) : d.ConsumeFloatingPointInRange(0.0, 100.0);
  // The fake clock's tick (us per reading): budgets run out after a fuzzed number of checks.
  g_tick = maybe(23) ? d.ConsumeFloatingPointInRange(1e-3, 50.0) : 1.0;
  if (maybe(21)) {
    o.max_restarts = d.ConsumeIntegralInRange<int>(-1, 3);
    o.restart_seed = d.ConsumeIntegral<unsigned>();
  }
  const SolverKind kind = static_cast<SolverKind>(d.ConsumeIntegralInRange<int>(-1, kSolverKindCount));

  // ---------------------------------------------------------------- workspace and start pose
  const int ws_goals = maybe(16) ? d.ConsumeIntegralInRange<int>(0, 5) : goal_count;
  Workspace ws;
  if (chain.valid()) ws.reset(chain, ws_goals);
  ws.deadline.clock_us = &fake_clock;
  const int dofs = chain.valid() ? chain.dof_count() : 0;
  const int param_count = maybe(17) ? d.ConsumeIntegralInRange<int>(0, dofs + 2) : dofs;
  Eigen::VectorXd params = Eigen::VectorXd::Zero(param_count);
  if (maybe(18)) {
    for (int i = 0; i < param_count; ++i) params[i] = pick_mostly(d, 3.5);
  }
  const Eigen::VectorXd input = params;

  // ---------------------------------------------------------------- the solve
  const bool dump = std::getenv("IKCHAIN_FUZZ_DUMP") != nullptr;
  if (dump) {  // the decoded input, to turn a finding into a test
    std::fprintf(stderr, "chain: %d joints, build '%s'\n", n, built.c_str());
    for (int i = 0; i < n; ++i) {
      const JointDesc& j = joints[i];
      const JointLimits& l = j.limits;
      std::fprintf(stderr,
                   "  joint %d type %d offset (%.17g, %.17g, %.17g) rest (%.17g, %.17g, %.17g, %.17g) axis "
                   "(%.17g, %.17g, %.17g)\n    hinge %d [%.17g, %.17g] slide %d [%.17g, %.17g] cone %d %.17g twist %d [%.17g, %.17g] "
                   "twist_axis (%.17g, %.17g, %.17g)\n",
                   i, static_cast<int>(j.type), j.offset_translation.x, j.offset_translation.y,
                   j.offset_translation.z, j.rest_rotation.w, j.rest_rotation.x, j.rest_rotation.y, j.rest_rotation.z,
                   j.axis.x, j.axis.y, j.axis.z, l.has_hinge_limit, l.hinge_min, l.hinge_max,
                   l.has_slide_limit, l.slide_min, l.slide_max, l.has_cone_limit, l.cone_angle, l.has_twist_limit, l.twist_min, l.twist_max, l.twist_axis.x,
                   l.twist_axis.y, l.twist_axis.z);
    }
    std::fprintf(stderr, "  tip_offset (%.17g, %.17g, %.17g)\n", tip_offset.x, tip_offset.y, tip_offset.z);
    for (const Goal& g : goals) {
      std::fprintf(stderr,
                   "goal kind %d effector %d weight %.17g pos (%.17g, %.17g, %.17g) q (%.17g, %.17g, %.17g, %.17g) "
                   "aim (%.17g, %.17g, %.17g) -> (%.17g, %.17g, %.17g)\n",
                   static_cast<int>(g.kind), g.effector, g.weight, g.target_position.x, g.target_position.y,
                   g.target_position.z, g.target_orientation.w, g.target_orientation.x, g.target_orientation.y,
                   g.target_orientation.z, g.aim_axis.x, g.aim_axis.y, g.aim_axis.z, g.aim_direction.x,
                   g.aim_direction.y, g.aim_direction.z);
    }
    std::fprintf(stderr,
                 "options: max_iterations %d pos_tol %.17g ori_tol %.17g stall %.17g warm %d max_step %.17g "
                 "pinv_res %.17g halvings %d pinv_sing %.17g dls %.17g/%.17g/%.17g wolfe %.17g/%.17g ls %d pole %d "
                 "(%.17g, %.17g, %.17g) budget %.17g cap %.17g tick %.17g restarts %d seed %llu\n",
                 o.max_iterations, o.position_tolerance, o.orientation_tolerance, o.stall_tolerance, o.warm_start,
                 o.max_step_angle, o.pinv_residual_tolerance, o.pinv_max_halvings, o.pinv_singular_threshold,
                 o.dls_initial_damping, o.dls_min_damping, o.dls_max_damping, o.bfgs_wolfe_c1, o.bfgs_wolfe_c2,
                 o.bfgs_max_line_search_steps, o.use_pole, o.pole_in_base.x, o.pole_in_base.y, o.pole_in_base.z,
                 o.time_budget_usec, o.time_cap_usec, g_tick, o.max_restarts,
                 static_cast<unsigned long long>(o.restart_seed));
    std::fprintf(stderr, "solver %d, workspace goals %d, params:", static_cast<int>(kind), ws_goals);
    for (int i = 0; i < input.size(); ++i) std::fprintf(stderr, " %.17g", input[i]);
    std::fprintf(stderr, "\n");
  }
  g_now = g_previous = 0.0;
  const SolveResult r = solve(kind, chain, goals, o, ws, params);
  count(kind, r.reason);
  const double clock_end = g_now, clock_before_end = g_previous;
  if (dump) {
    std::fprintf(stderr, "result: %s, %d iterations, error %.17g -> %.17g, '%s'\nreturned:", to_string(r.reason),
                 r.iterations, r.initial_error, r.final_error, r.message.c_str());
    for (int i = 0; i < params.size(); ++i) std::fprintf(stderr, " %.17g", params[i]);
    std::fprintf(stderr, "\n");
  }

  REQUIRE(all_finite(r.initial_error) && all_finite(r.final_error) && all_finite(r.initial_position_error) &&
              all_finite(r.final_position_error) && all_finite(r.initial_orientation_error) &&
              all_finite(r.final_orientation_error) && all_finite(r.elapsed_us),
          "non-finite result field", r.initial_error, r.final_error);
  REQUIRE(r.iterations >= 0, "negative iterations", r.iterations);
  // The budget (and the cap): no reading after the one that found it spent, and the flag says so.
  // The cap is checked at every 8th check only (once armed), so with a budget a reading between two of its checks
  // may pass its end unnoticed; alone, all its readings are its checks.
  if (ws.deadline.hit && ws.deadline.cap_hit) {
    // (The reading before may be the arming one when the cap is below its ulp.)
    REQUIRE(clock_end >= ws.deadline.cap_end_us &&
                (ws.deadline.every_call || clock_before_end < ws.deadline.cap_end_us ||
                 clock_before_end == ws.deadline.cap_start_us),
            "the clock was read again after the cap was found spent", clock_end, ws.deadline.cap_end_us);
  } else if (ws.deadline.hit) {
    // (The reading before may be the arming one, at g_tick, when the budget is below its ulp.)
    // It found it spent at the budget's end, or before it when the next stretch and the exit work,
    // predicted from the gaps between readings, would have ended past the bound (Deadline::foreseen).
    REQUIRE((clock_end >= ws.deadline.end_us || (ws.deadline.foreseen && clock_end == ws.deadline.last_reading_us)) &&
                (clock_before_end < ws.deadline.end_us || clock_before_end == g_tick),
            "the clock was read again after the budget was found spent", clock_end, ws.deadline.end_us);
  } else if (ws.deadline.every_call) {
    // (Again except the arming reading, which is no check: a solve may make no check at all.)
    REQUIRE(clock_end < ws.deadline.end_us || clock_end == g_tick, "a reading past the budget went unnoticed",
            clock_end, ws.deadline.end_us);
  } else {
    REQUIRE(!ws.deadline.cap_armed || clock_end < ws.deadline.cap_end_us || clock_end == ws.deadline.cap_start_us,
            "a reading past the cap went unnoticed",
            clock_end, ws.deadline.cap_end_us);
  }
  REQUIRE(!r.budget_exhausted || r.reason == TerminationReason::kMaxIterations ||
              r.reason == TerminationReason::kUnreachable,
          "budget_exhausted with a reason other than max_iterations/unreachable", static_cast<double>(r.reason));
  REQUIRE(!r.budget_exhausted || ws.deadline.hit, "budget_exhausted but the budget was not spent");
  if (r.reason != TerminationReason::kInvalidInput && ws.deadline.every_call) {
    const double bound = Deadline::stretch_bound(chain.joint_count(), chain.dof_count(), 3 * goal_count);
    REQUIRE(ws.deadline.longest_stretch <= bound, "a stretch of work without a clock reading (flops, bound)",
            ws.deadline.longest_stretch, bound);
  }

  if (r.reason == TerminationReason::kInvalidInput) {
    REQUIRE(!r.message.empty(), "invalid_input without a message");
    REQUIRE(!r.usable(), "invalid_input but usable");
    REQUIRE(params.size() == input.size() &&
                (input.size() == 0 ||
                 std::memcmp(params.data(), input.data(), sizeof(double) * input.size()) == 0),
            "invalid_input changed params");
    return 0;
  }

  // A usable result: the input was valid, so the chain built and everything below is defined.
  REQUIRE(chain.valid() && o.validate().empty() && goal_count > 0, "usable result for invalid input");
  // max_iterations bounds each run; the result counts every run (options.hpp, restarts).
  REQUIRE(r.restarts >= 0 && r.restarts <= o.max_restarts, "restarts outside 0..max_restarts", r.restarts,
          o.max_restarts);
  REQUIRE(r.iterations <= o.max_iterations * (1 + r.restarts), "iterations > max_iterations per run", r.iterations,
          o.max_iterations);
  REQUIRE(params.allFinite(), "non-finite params");
  REQUIRE(within_limits(chain, params.data(), 1e-6), "returned pose violates the limits");

  // The same input again, on the same (now dirty) workspace: the same verdict and pose, bit for bit
  // (nothing may depend on what a previous solve left in the workspace). With a time budget too:
  // the fake clock starts again where it started, so the budget cuts the solve at the same check.
  {
    Eigen::VectorXd again = input;
    g_now = g_previous = 0.0;
    const SolveResult r2 = solve(kind, chain, goals, o, ws, again);
    REQUIRE(r2.reason == r.reason && r2.iterations == r.iterations, "a repeated solve gave another verdict",
            static_cast<double>(r.reason), static_cast<double>(r2.reason));
    REQUIRE(std::memcmp(again.data(), params.data(), sizeof(double) * params.size()) == 0,
            "a repeated solve gave another pose");
  }

  // The start pose, as solve() defines it: the input (warm) or rest, projected onto the limits.
  Eigen::VectorXd start = o.warm_start ? input : Eigen::VectorXd::Zero(dofs);
  project_to_limits(chain, start.data());

  // Rounding allowance of two FK implementations on this chain and these goals: a few ulps of the
  // largest coordinate involved, per joint.
  double scale = glm::length(chain.root_in_base()) + chain.total_length();
  double weights = 0.0;
  for (const Goal& g : goals) {
    if (g.kind == GoalKind::kPosition) scale = std::max(scale, glm::length(g.target_position));
    weights += g.weight;
  }
  const double pos_slack = 1e-12 * (n + 1) * (1.0 + scale);
  const double rot_slack = 1e-10 * (n + 1);

  const Pose start_pose = reference_fk(joints, tip_offset, start.data());
  const Pose final_pose = reference_fk(joints, tip_offset, params.data());
  const Errors e0 = reference_errors(start_pose, goals, chain.total_length(), pos_slack);
  const Errors e1 = reference_errors(final_pose, goals, chain.total_length(), pos_slack);

  const double error_slack = 1e-6 * (1.0 + r.final_error) + std::sqrt(weights) * (pos_slack + rot_slack);
  REQUIRE(r.final_error >= std::sqrt(2.0 * e1.cost_low) - error_slack &&
              r.final_error <= std::sqrt(2.0 * e1.cost) + error_slack,
          "final_error disagrees with an independent FK", r.final_error, std::sqrt(2.0 * e1.cost));

  if (r.reason == TerminationReason::kConverged) {
    REQUIRE(e1.max_position <= o.position_tolerance + pos_slack, "converged but a position goal is not met",
            e1.max_position, o.position_tolerance);
    REQUIRE(e1.max_orientation <= o.orientation_tolerance + rot_slack,
            "converged but an orientation/aim goal is not met", e1.max_orientation, o.orientation_tolerance);
  }

  const double cost_slack = 1e-9 * e0.cost + weights * (pos_slack + rot_slack) * (1.0 + std::sqrt(2.0 * e0.cost));
  REQUIRE(e1.cost_low <= e0.cost + cost_slack, "returned pose worse than the start pose", e0.cost, e1.cost_low);
  return 0;
}
