// One regression test per class of finding of the core fuzzer (tests/fuzz/solve_fuzz.cpp), each
// named after it, with the reproducer it was found with (or the smallest input of that class).
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ikchain/kinematics.hpp"
#include "ikchain/solve.hpp"
#include "core/solvers/solvers.hpp"
#include "test_util.hpp"

namespace ikchain {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool contains(const Message& m, const char* needle) {
  return std::string(m.c_str()).find(needle) != std::string::npos;
}

// Cost 0.5 * sum w |e|^2 of `params` by the core's own FK.
double cost_of(const Chain& chain, const std::vector<Goal>& goals, const Eigen::VectorXd& params) {
  Workspace ws(chain, static_cast<int>(goals.size()));
  forward_kinematics(chain, params.data(), ws);
  return measure_goals(chain, goals, ws).cost;
}

void expect_rejected_untouched(SolverKind kind, const Chain& chain, const std::vector<Goal>& goals,
                               const SolverOptions& options, Eigen::VectorXd params, const char* needle) {
  Workspace ws(chain, static_cast<int>(goals.size()));
  const Eigen::VectorXd before = params;
  const SolveResult r = solve(kind, chain, goals, options, ws, params);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput) << to_string(kind) << ": " << to_string(r.reason);
  EXPECT_TRUE(contains(r.message, needle)) << "'" << r.message.c_str() << "' should name '" << needle << "'";
  EXPECT_EQ(params, before);
  EXPECT_TRUE(std::isfinite(r.final_error) && std::isfinite(r.initial_error));
}

// measure_goals took the worst error with std::max, which drops a NaN (max(0, NaN) == 0): a NaN
// pose read as "every goal met".
TEST(FuzzFindings, MeasureGoalsKeepsNaNErrors) {
  const Chain chain = test::make_hinge_chain(2);
  Workspace ws(chain, 2);
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(2);
  forward_kinematics(chain, p.data(), ws);
  ws.tip.x = kNaN;
  ws.joint_orientations[1].w = kNaN;
  // The NaN goal first and last: neither order may lose it.
  const std::vector<Goal> goals{Goal::position(glm::dvec3(0, 2, 0)), Goal::orientation(glm::dquat(1, 0, 0, 0))};
  const GoalErrors e = measure_goals(chain, goals, ws);
  EXPECT_TRUE(std::isnan(e.max_position));
  EXPECT_TRUE(std::isnan(e.max_orientation));
  EXPECT_FALSE(e.within(SolverOptions()));
  const std::vector<Goal> met_then_nan{Goal::position(ws.joint_origins[1], 1), Goal::position(glm::dvec3(0, 2, 0))};
  EXPECT_TRUE(std::isnan(measure_goals(chain, met_then_nan, ws).max_position));
}

// Finite ball params of 1e155 have an infinite squared angle: FK was NaN everywhere, and the solve
// said "converged", usable, with a NaN final error. Now rejected by name, pose untouched.
TEST(FuzzFindings, HugeBallParamsRejected) {
  const Chain chain = test::make_ball_chain(2);
  const std::vector<Goal> goals{Goal::position(glm::dvec3(0.5, 1.0, 0.2))};
  for (int k = 0; k < kSolverKindCount; ++k) {
    if (static_cast<SolverKind>(k) == SolverKind::kTwoBone) continue;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(chain.dof_count());
    p[1] = 1e155;
    expect_rejected_untouched(static_cast<SolverKind>(k), chain, goals, SolverOptions(), p, "params[1]");
  }
  // The bound itself is accepted and gives a finite result.
  Eigen::VectorXd p = Eigen::VectorXd::Zero(chain.dof_count());
  p[1] = kMaxMagnitude;
  Workspace ws(chain, 1);
  const SolveResult r = solve(SolverKind::kDLS, chain, goals, SolverOptions(), ws, p);
  EXPECT_TRUE(r.usable()) << r.message.c_str();
  EXPECT_TRUE(std::isfinite(r.final_error));
  EXPECT_TRUE(p.allFinite());
}

// An aim axis of (1e200, 0, 0) has an infinite glm::length: normalising it gave the zero vector,
// and the aim goal was "met" after 0 iterations.
TEST(FuzzFindings, HugeAimAxisRejectedNotSilentlyMet) {
  const Chain chain = test::make_ball_chain(2);
  for (int k = 0; k < kSolverKindCount; ++k) {
    if (static_cast<SolverKind>(k) == SolverKind::kTwoBone) continue;
    const std::vector<Goal> axis{Goal::aim(glm::dvec3(1e200, 0, 0), glm::dvec3(0, 0, 1))};
    expect_rejected_untouched(static_cast<SolverKind>(k), chain, axis, SolverOptions(),
                              Eigen::VectorXd::Zero(chain.dof_count()), "aim_axis");
    const std::vector<Goal> dir{Goal::aim(glm::dvec3(0, 1, 0), glm::dvec3(0, 0, -1e200))};
    expect_rejected_untouched(static_cast<SolverKind>(k), chain, dir, SolverOptions(),
                              Eigen::VectorXd::Zero(chain.dof_count()), "aim_direction");
  }
  // A large but bounded axis is a direction like any other: solved, and met by FK.
  const std::vector<Goal> big{Goal::aim(glm::dvec3(0, 1e20, 0), glm::dvec3(0, 0, 1e20))};
  Workspace ws(chain, 1);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(chain.dof_count());
  const SolveResult r = solve(SolverKind::kDLS, chain, big, SolverOptions(), ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  EXPECT_GT(r.iterations, 0);
  forward_kinematics(chain, p.data(), ws);
  const glm::dvec3 axis_in_base = effector_orientation(chain, ws, 0) * glm::dvec3(0, 1, 0);
  EXPECT_NEAR(axis_in_base.z, 1.0, 1e-8);
}

// The solver's own rules (a known kind, two-bone's 2 joints and single tip goal, CCD's goal cap)
// were checked inside the solver, which solve() skips when the start already meets the tolerance:
// the same input was "converged" or "invalid_input" depending on the target.
TEST(FuzzFindings, SolverRulesGiveTheSameVerdictWhateverTheStart) {
  const Chain three = test::make_hinge_chain(3);
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(3);
  const glm::dvec3 met = test::tip_of(three, p);
  for (const glm::dvec3& target : {met, glm::dvec3(1.0, 1.0, 0.5)}) {
    const std::vector<Goal> g{Goal::position(target)};
    expect_rejected_untouched(SolverKind::kTwoBone, three, g, SolverOptions(), p, "exactly 2 joints");
    expect_rejected_untouched(static_cast<SolverKind>(99), three, g, SolverOptions(), p, "solver kind 99");
    expect_rejected_untouched(static_cast<SolverKind>(-1), three, g, SolverOptions(), p, "solver kind -1");
    const std::vector<Goal> many(kCcdMaxGoals + 1, Goal::position(target));
    expect_rejected_untouched(SolverKind::kCCD, three, many, SolverOptions(), p, "ccd supports at most");
  }
  const Chain two = test::make_hinge_chain(2);
  const Eigen::VectorXd p2 = Eigen::VectorXd::Zero(2);
  const std::vector<Goal> orientation{Goal::orientation(glm::dquat(1, 0, 0, 0))};  // met at rest
  expect_rejected_untouched(SolverKind::kTwoBone, two, orientation, SolverOptions(), p2, "position goal on the tip");
  // The cap itself is accepted when met at the start.
  Workspace ws(three, kCcdMaxGoals);
  const std::vector<Goal> cap(kCcdMaxGoals, Goal::position(met));
  Eigen::VectorXd q = p;
  EXPECT_EQ(solve(SolverKind::kCCD, three, cap, SolverOptions(), ws, q).reason, TerminationReason::kConverged);
}

// The reproducer's chain (3 hinges, the root limited to [-0.3, 0.3]) and its unreachable goal.
Chain limited_root_chain() {
  ChainBuilder b;
  for (int i = 0; i < 3; ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = (i % 2 == 0) ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 1, 0);
    if (i == 0) {
      j.limits.has_hinge_limit = true;
      j.limits.hinge_min = -0.3;
      j.limits.hinge_max = 0.3;
    }
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain chain;
  EXPECT_TRUE(b.build(chain).ok());
  return chain;
}
const std::vector<Goal> kFarGoal{
    Goal::position(glm::dvec3(-4.8024093509053687, 0.7681347410697934, -4.020441898407074))};

// Found by the fuzzer's "never worse than the start" property: the pseudo-inverse, on an
// unreachable target with a limited root, stalled at a pose of higher cost than its start (it
// minimises the distance to the target clamped onto the reach sphere, not to the target).
// solve() now gives the start pose back.
TEST(FuzzFindings, PseudoInverseNeverWorseThanStart) {
  const Chain chain = limited_root_chain();
  ASSERT_TRUE(chain.valid());
  const std::vector<Goal>& goals = kFarGoal;
  Eigen::VectorXd start(3);
  start << 0.3, 2.8885714472476072, -1.4326639561548049;
  const double start_cost = cost_of(chain, goals, start);

  // The fuzzer's reproducer: the pseudo-inverse alone ended worse than it started (before the
  // limit-aware step it did; whether it still does is the solver's business). The guarantee is
  // solve()'s: never worse than the start, whatever the solver returns.
  Workspace ws(chain, 1);

  // Through solve(): never worse, and the reported errors are the returned pose's.
  Eigen::VectorXd p = start;
  const SolveResult r = solve(SolverKind::kJacobianPinv, chain, goals, SolverOptions(), ws, p);
  EXPECT_TRUE(r.usable());
  EXPECT_LE(cost_of(chain, goals, p), start_cost);
  EXPECT_NEAR(r.final_error, std::sqrt(2.0 * cost_of(chain, goals, p)), 1e-12);
  EXPECT_LE(r.final_error, r.initial_error);
}

// The fall-back pose of a solve (non-finite result, or worse than the start) was the caller's
// input, which may violate the limits; now it is the start pose, projected onto them. Same
// reproducer as above, with a warm start whose root angle (1.0) is outside [-0.3, 0.3].
TEST(FuzzFindings, FallbackPoseRespectsLimits) {
  const Chain chain = limited_root_chain();
  ASSERT_TRUE(chain.valid());
  const std::vector<Goal>& goals = kFarGoal;
  Eigen::VectorXd p(3);
  p << 1.0, 2.8885714472476072, -1.4326639561548049;
  Workspace ws(chain, 1);
  const SolveResult r = solve(SolverKind::kJacobianPinv, chain, goals, SolverOptions(), ws, p);
  EXPECT_TRUE(r.usable());
  EXPECT_TRUE(within_limits(chain, p.data()));
  EXPECT_EQ(p[0], 0.3);
}

// A rest rotation of (1e200, 0, 0, 1e200) has an infinite glm::length: it was stored as the zero
// quaternion (FK collapsed every later bone onto its joint). Its direction is what counts.
TEST(FuzzFindings, HugeRestRotationStoredNormalised) {
  ChainBuilder b;
  JointDesc j;
  j.type = JointType::kHinge;
  j.rest_rotation = glm::dquat(1e200, 0, 0, 1e200);  // w, x, y, z: 90 degrees about z
  b.add_joint(j).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain chain;
  ASSERT_TRUE(b.build(chain).ok());
  const glm::dquat& r = chain.rest_rotation(0);
  EXPECT_NEAR(r.w, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(r.z, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(chain.rest_tip().x, -1.0, 1e-15);
  EXPECT_NEAR(chain.rest_tip().y, 0.0, 1e-15);
  // Zero and non-finite stay rejected.
  for (const glm::dquat& bad : {glm::dquat(0, 0, 0, 0), glm::dquat(kNaN, 0, 0, 1)}) {
    ChainBuilder z;
    JointDesc k;
    k.rest_rotation = bad;
    z.add_joint(k).set_tip_offset(glm::dvec3(0, 1, 0));
    Chain c;
    EXPECT_TRUE(contains(z.build(c).message, "joint 0: rest_rotation"));
    EXPECT_FALSE(c.valid());
  }
}

// Offsets of 1e200 gave bone lengths and a chain length of inf (and every error inf). Coordinates
// beyond +-kMaxMagnitude are rejected, naming the joint and field.
TEST(FuzzFindings, HugeOffsetsRejectedNotInfiniteLength) {
  ChainBuilder b;
  JointDesc j;
  b.add_joint(j);
  j.offset_translation = glm::dvec3(1e200, 0, 0);
  b.add_joint(j).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain chain;
  EXPECT_TRUE(contains(b.build(chain).message, "joint 1: offset_translation"));
  EXPECT_FALSE(chain.valid());

  ChainBuilder t;
  t.add_joint(JointDesc()).set_tip_offset(glm::dvec3(0, -1e51, 0));
  EXPECT_TRUE(contains(t.build(chain).message, "tip_offset"));

  // At the bound: builds, with finite lengths.
  ChainBuilder ok;
  JointDesc far;
  ok.add_joint(far);
  far.offset_translation = glm::dvec3(kMaxMagnitude, -kMaxMagnitude, kMaxMagnitude);
  ok.add_joint(far).set_tip_offset(far.offset_translation);
  ASSERT_TRUE(ok.build(chain).ok());
  EXPECT_TRUE(std::isfinite(chain.total_length()));
  EXPECT_NEAR(chain.total_length(), 2.0 * std::sqrt(3.0) * kMaxMagnitude, 1e-12 * kMaxMagnitude);
}

// Targets and weights large enough to overflow the squared errors gave inf results.
TEST(FuzzFindings, HugeTargetsAndWeightsRejected) {
  const Chain chain = test::make_hinge_chain(2);
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(2);
  expect_rejected_untouched(SolverKind::kDLS, chain, {Goal::position(glm::dvec3(0, 1e200, 0))}, SolverOptions(), p,
                            "target_position");
  expect_rejected_untouched(SolverKind::kDLS, chain, {Goal::position(glm::dvec3(0, 1, 0), 0, 1e300)},
                            SolverOptions(), p, "weight");
  SolverOptions pole;
  pole.use_pole = true;
  pole.pole_in_base = glm::dvec3(0.0, 1e200, 0.0);
  expect_rejected_untouched(SolverKind::kTwoBone, chain, {Goal::position(glm::dvec3(0, 1, 0))}, pole, p, "pole");
  // The bounds themselves are valid: unreachable, finite.
  Workspace ws(chain, 1);
  Eigen::VectorXd q = p;
  const std::vector<Goal> far{Goal::position(glm::dvec3(0, kMaxMagnitude, -kMaxMagnitude), 0, kMaxWeight)};
  const SolveResult r = solve(SolverKind::kDLS, chain, far, SolverOptions(), ws, q);
  EXPECT_TRUE(r.usable()) << r.message.c_str();
  EXPECT_NE(r.reason, TerminationReason::kConverged);
  EXPECT_TRUE(std::isfinite(r.final_error));
  EXPECT_TRUE(q.allFinite());
}

// A ball joint's axis (and a hinge's twist_axis) was stored as given, NaN included: a chain
// that built held non-finite data. The unused axis is stored as its default.
TEST(FuzzFindings, UnusedAxesStoredAsDefaults) {
  ChainBuilder b;
  JointDesc ball;
  ball.type = JointType::kBall;
  ball.axis = glm::dvec3(kNaN, 0, 0);
  JointDesc hinge;
  hinge.type = JointType::kHinge;
  hinge.offset_translation = glm::dvec3(0, 1, 0);
  hinge.limits.twist_axis = glm::dvec3(0, kNaN, 0);
  b.add_joint(ball).add_joint(hinge).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain chain;
  ASSERT_TRUE(b.build(chain).ok());
  EXPECT_TRUE(so3::finite(chain.axis(0)));
  EXPECT_TRUE(so3::finite(chain.limits(1).twist_axis));
  // A huge but finite axis is a direction: normalised, not rejected as "infinite".
  ChainBuilder h;
  JointDesc big;
  big.type = JointType::kHinge;
  big.axis = glm::dvec3(0, 0, 1e300);
  h.add_joint(big).set_tip_offset(glm::dvec3(0, 1, 0));
  ASSERT_TRUE(h.build(chain).ok());
  EXPECT_EQ(chain.axis(0), glm::dvec3(0, 0, 1));
}

// pinv_max_halvings was unbounded: 1e7 took 79 s for one solve.
TEST(FuzzFindings, PinvMaxHalvingsBounded) {
  SolverOptions o;
  o.pinv_max_halvings = 10000000;
  EXPECT_TRUE(contains(o.validate(), "pinv_max_halvings must be in [0, 60], got 10000000"));
  o.pinv_max_halvings = kMaxPinvHalvings;
  EXPECT_TRUE(o.validate().empty());
  o.pinv_max_halvings = -1;
  EXPECT_TRUE(contains(o.validate(), "pinv_max_halvings"));
}

// Found by the fuzzer (a timeout): bfgs_max_line_search_steps was unbounded, and 227380621 of
// them kept one BFGS solve running for over 30 s.
TEST(FuzzFindings, BfgsLineSearchStepsBounded) {
  SolverOptions o;
  o.bfgs_max_line_search_steps = 227380621;
  EXPECT_TRUE(contains(o.validate(), "bfgs_max_line_search_steps must be in [1, 100], got 227380621"));
  o.bfgs_max_line_search_steps = kMaxBfgsLineSearchSteps;
  EXPECT_TRUE(o.validate().empty());
  o.bfgs_max_line_search_steps = 0;
  EXPECT_TRUE(contains(o.validate(), "bfgs_max_line_search_steps"));
}

// The aim-at angle of a one-joint chain's tip, computed here from the definition (goal.hpp) in
// plain GLM, independently of the core's FK: joint rotation `q`, then the tip at q * tip_offset.
double aim_at_angle_one_joint(const glm::dquat& q, const glm::dvec3& tip_offset, double chain_length,
                              const Goal& g) {
  const glm::dvec3 to_point = g.target_position - q * tip_offset;
  if (!(glm::length(to_point) > kAimAtOnPoint * (chain_length + glm::length(g.target_position)))) return 0.0;
  const glm::dvec3 axis = glm::normalize(q * g.aim_axis);
  return std::atan2(glm::length(glm::cross(axis, to_point)), glm::dot(axis, to_point));
}

// The two reproducers: one joint at the base origin, an aim-at goal on the tip whose point lies on
// the sphere (ball) or circle (hinge) the tip moves on. Descent toward the point runs into the
// jump of the aim direction there; BFGS stopped about 1e-11 from the point, where the direction
// and so the angle were mostly rounding: the reported final_error and an independent FK of the
// returned pose disagreed by ~3.5e-6 rad.
struct AimAtReproducer {
  Chain chain;
  glm::dvec3 tip_offset;
  Goal goal;
  Eigen::VectorXd start;
  SolverOptions options;
  glm::dquat rotation(const Eigen::VectorXd& p) const {  // the joint's rotation for params p
    if (chain.joint_type(0) == JointType::kHinge) return glm::angleAxis(p[0], glm::dvec3(0, 0, 1));
    const glm::dvec3 r(p[0], p[1], p[2]);
    return glm::length(r) > 0.0 ? glm::angleAxis(glm::length(r), r / glm::length(r)) : glm::dquat(1, 0, 0, 0);
  }
};

AimAtReproducer aim_at_reproducer(JointType type) {
  AimAtReproducer r;
  JointDesc j;
  j.type = type;
  j.axis = glm::dvec3(0, 0, 1);
  if (type == JointType::kBall) {  // BFGS alone
    r.tip_offset = glm::dvec3(0, 1, 0);
    r.goal = Goal::aim_at(glm::dvec3(-0.69588683150423758, 0.26852934487031521, 0.66605818715973486),
                          glm::dvec3(0.0901971514738511, 0.090196078431375781, -0.99999796549490583));
    r.start = Eigen::Vector3d(-2.1453094482421875, 0, 0);
    r.options.max_iterations = 276;
    r.options.position_tolerance = 1e-3;
    r.options.stall_tolerance = 1e-224;
  } else {  // BFGS with restarts
    r.tip_offset = glm::dvec3(0.65096918587005348, 0, 0.65098039215686265);
    r.goal = Goal::aim_at(glm::dvec3(0.36451035100981977, 0.53934505185365167, 0.65098039215686265),
                          glm::dvec3(0.32549022412767603, 0.79607843137254908, 0), 1);
    r.start = Eigen::VectorXd::Constant(1, 2.7862745098039152);
    r.options.max_iterations = 243;
    r.options.orientation_tolerance = 1e-158;
    r.options.pinv_max_halvings = 28;
    r.options.pinv_singular_threshold = 1e-158;
    r.options.dls_min_damping = 1e-158;
    r.options.use_pole = true;
    r.options.pole_in_base = glm::dvec3(0.039712906390662384, 0.037043880246811156, 0.29965193003863366);
    r.options.max_restarts = 3;
    r.options.restart_seed = 2846468581u;
  }
  ChainBuilder b;
  b.add_joint(j).set_tip_offset(r.tip_offset);
  EXPECT_TRUE(b.build(r.chain).ok());
  return r;
}

// Nearer to its point than kAimAtOnPoint the effector sits on it (error 0 by definition); farther,
// the direction is well defined: either way the reported final_error is the returned pose's angle
// as recomputed here. Two FK implementations differ by ulps of the position (~2e-16 scale); at the
// on-point radius (1e-6 scale) that moves the angle by ~2e-10, so 1e-9 - the finding's gap was
// 3.5e-6. For every solver that takes aim-at goals, with and without restarts.
TEST(FuzzFindings, AimAtFinalErrorIsTheReturnedPosesError) {
  for (JointType type : {JointType::kBall, JointType::kHinge}) {
    const AimAtReproducer rep = aim_at_reproducer(type);
    ASSERT_TRUE(rep.chain.valid());
    const std::vector<Goal> goals{rep.goal};
    const double length = rep.chain.total_length();
    for (const SolverInfo& info : solver_table()) {
      if (!info.orientation_goals || info.joint_count != 0) continue;
      // Restarts, and few enough iterations that the first run ends short of the goal and the
      // restarts run (their best-pose bookkeeping is what the hinge reproducer found).
      for (const auto& [restarts, iterations] : {std::pair{0, 0}, {3, 0}, {3, 2}}) {
        SolverOptions o = rep.options;
        o.max_restarts = restarts;
        if (iterations > 0) o.max_iterations = iterations;
        Workspace ws(rep.chain, 1);
        Eigen::VectorXd p = rep.start;
        const SolveResult r = solve(info.kind, rep.chain, goals, o, ws, p);
        ASSERT_TRUE(r.usable()) << info.id << ": " << r.message.c_str();
        const double angle = aim_at_angle_one_joint(rep.rotation(p), rep.tip_offset, length, rep.goal);
        EXPECT_NEAR(r.final_error, angle, 1e-9 * (1.0 + angle))
            << info.id << ", " << restarts << " restarts, " << to_string(r.reason);
        EXPECT_EQ(r.final_orientation_error, r.final_error) << info.id;
        if (iterations > 0) {
          EXPECT_GT(r.restarts, 0) << info.id;
        }
      }
    }
    // The pose BFGS returned before: its tip ~1e-11 from the point, so on it, the goal met.
    Eigen::VectorXd stalled = type == JointType::kBall
                                  ? Eigen::VectorXd(Eigen::Vector3d(0.9823664623741053, -0.15848514398011418,
                                                                    0.85231089973264507))
                                  : Eigen::VectorXd::Constant(1, 7.2596558951786418);
    EXPECT_LT(glm::length(rep.goal.target_position - test::tip_of(rep.chain, stalled)), 1e-10);
    EXPECT_EQ(cost_of(rep.chain, goals, stalled), 0.0);
    EXPECT_EQ(aim_at_angle_one_joint(rep.rotation(stalled), rep.tip_offset, length, rep.goal), 0.0);
  }
}

// Found by the fuzzer: the reported final_error and an independent FK's disagreed (1e-3 against
// 2.5) on a pose whose effector lay on an aim-at goal's on-point radius (kinematics.hpp). Nearer,
// the goal is met (error 0); farther, its error is the angle: a jump, and a goal pulling the
// effector off the point pulls it to the jump, where descent stops. There the two FKs' rounding
// can fall on either side; the fuzzer now accepts either value within its rounding allowance.
// Pinned here: the solvers do stop on that radius (from inside), and the core reports the goal met.
TEST(FuzzFindings, AimAtDescentStopsOnTheOnPointRadius) {
  const Chain chain = test::make_hinge_chain(1);  // a hinge about +Z, the tip 1 m along +Y
  const double on_angle = 0.3, pull_angle = 1.2;
  auto tip_at = [](double a) { return glm::dvec3(-std::sin(a), std::cos(a), 0.0); };
  const glm::dvec3 point = tip_at(on_angle);
  // The bone's -X is the circle's tangent toward smaller angles: from just past the point toward
  // the pulling goal it aims away from the point (about 180 degrees off).
  const std::vector<Goal> goals{Goal::aim_at(point, glm::dvec3(-1, 0, 0)), Goal::position(tip_at(pull_angle))};
  const double on_point = kAimAtOnPoint * (chain.total_length() + glm::length(point));
  for (SolverKind kind : {SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS}) {
    SolverOptions o;
    o.warm_start = true;
    Workspace ws(chain, 2);
    Eigen::VectorXd p = Eigen::VectorXd::Constant(1, on_angle);
    const SolveResult r = solve(kind, chain, goals, o, ws, p);
    ASSERT_TRUE(r.usable()) << to_string(kind);
    const double distance = glm::length(point - test::tip_of(chain, p));
    EXPECT_LE(distance, on_point) << to_string(kind);
    EXPECT_GT(distance, 0.5 * on_point) << to_string(kind);
    EXPECT_NEAR(r.final_error, glm::length(tip_at(pull_angle) - test::tip_of(chain, p)), 1e-12) << to_string(kind);
    EXPECT_EQ(r.final_orientation_error, 0.0) << to_string(kind);
  }
}

// Found by the fuzzer once restarts were drawn: a result's iterations exceeded max_iterations.
// They count every run (options.hpp), each run bounded by max_iterations: the fuzzer's property
// was per solve; this pins the documented count.
TEST(FuzzFindings, IterationsCountEveryRestart) {
  const AimAtReproducer rep = aim_at_reproducer(JointType::kHinge);
  const std::vector<Goal> goals{rep.goal};
  SolverOptions o = rep.options;
  o.max_iterations = 2;
  Workspace ws(rep.chain, 1);
  for (SolverKind kind : {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS}) {
    Eigen::VectorXd once = rep.start, again = rep.start;
    o.max_restarts = 0;
    const SolveResult first = solve(kind, rep.chain, goals, o, ws, once);
    o.max_restarts = 3;
    const SolveResult r = solve(kind, rep.chain, goals, o, ws, again);
    EXPECT_EQ(first.iterations, 2) << to_string(kind);
    EXPECT_EQ(r.restarts, 3) << to_string(kind);
    EXPECT_GT(r.iterations, first.iterations) << to_string(kind);
    EXPECT_LE(r.iterations, o.max_iterations * (1 + r.restarts)) << to_string(kind);
  }
}

}  // namespace
}  // namespace ikchain
