// The one stall rule and the one stuck -> escape mechanism every iterative solver shares
// (src/core/solvers/stuck.hpp): the rule's counting, the escape's best-pose promise, its budget
// and determinism, the creep and the full-turn wrap, the straight limb with a hinge on its limit
// that every solver must leave, and real arms' goals the limits trapped.
#include <algorithm>
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>

#include "core/solvers/stuck.hpp"
#include "joint_desc.hpp"  // bench/
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

const SolverKind kIterativeSolvers[] = {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS,
                                        SolverKind::kBFGS, SolverKind::kFABRIK};

// Iterations count when they lower the best cost by no more than the tolerance (relative to that
// best); kStallIterations of them in a row are a stall. A worse iteration counts too, and one that
// beats the best resets the count, so a non-monotone method is judged by the best it reached.
TEST(Stuck, StallRuleCountsIterationsWithoutProgressOnTheBest) {
  ASSERT_EQ(stuck::kStallIterations, 3);
  stuck::StallRule rule(1.0);
  EXPECT_FALSE(rule.stalled_after(1.0, 1e-10));        // 1: no change
  EXPECT_FALSE(rule.stalled_after(1.0 - 1e-11, 1e-10));  // 2: below the tolerance
  EXPECT_FALSE(rule.stalled_after(0.5, 1e-10));        // progress: count 0, best 0.5
  EXPECT_FALSE(rule.stalled_after(0.6, 1e-10));        // 1: worse than the best
  EXPECT_FALSE(rule.stalled_after(0.55, 1e-10));       // 2: better than the last, not than the best
  EXPECT_TRUE(rule.stalled_after(0.52, 1e-10));        // 3: stalled
  rule.reset(2.0);                                     // an escape: a new start
  EXPECT_FALSE(rule.stalled_after(2.0, 1e-10));
  EXPECT_FALSE(rule.stalled_after(NAN, 1e-10));        // NaN never improves
  EXPECT_TRUE(rule.stalled_after(2.0, 1e-10));
  // Tolerance 0: any decrease is progress.
  stuck::StallRule strict(1.0);
  for (int i = 1; i <= 10; ++i) EXPECT_FALSE(strict.stalled_after(1.0 - 1e-15 * i, 0.0));
}

// An iteration creeps when it lowers the best cost by less than kCreepGain of it; kStallIterations
// creeping iterations in a row are a creep (still progress: the stall rule has not fired), and one
// real gain, or a reset (an escape), starts the count again.
TEST(Stuck, StallRuleTellsACreepFromProgress) {
  ASSERT_EQ(stuck::kCreepGain, 1e-2);
  stuck::StallRule rule(1.0);
  EXPECT_FALSE(rule.stalled_after(0.995, 1e-10));  // 1: a 0.5 % gain creeps
  EXPECT_FALSE(rule.stalled_after(0.99, 1e-10));   // 2
  EXPECT_FALSE(rule.creeping());
  EXPECT_FALSE(rule.stalled_after(0.985, 1e-10));  // 3: a creep, not a stall
  EXPECT_TRUE(rule.creeping());
  EXPECT_FALSE(rule.stalled_after(0.9, 1e-10));    // an 8.6 % gain: progress again
  EXPECT_FALSE(rule.creeping());
  EXPECT_FALSE(rule.stalled_after(0.899, 1e-10));
  EXPECT_FALSE(rule.stalled_after(0.898, 1e-10));
  rule.reset(0.898);  // an escape
  EXPECT_FALSE(rule.stalled_after(0.897, 1e-10));
  EXPECT_FALSE(rule.creeping());
  // No gain at all is a stall and a creep at once: the stall rule decides.
  stuck::StallRule flat(1.0);
  for (int i = 0; i < 2; ++i) EXPECT_FALSE(flat.stalled_after(1.0, 1e-10));
  EXPECT_TRUE(flat.stalled_after(1.0, 1e-10));
  EXPECT_TRUE(flat.creeping());
}

// A hinge resting on a bound of a range of a full turn (or more) moves across to the same angle at
// the other end (the pose, hence the tip, unchanged); off a bound, or with a range short of a full
// turn, it stays.
TEST(Stuck, WrapAcrossBoundKeepsThePoseOnTheOtherSideOfTheWall) {
  constexpr double kPi = 3.14159265358979323846;
  ChainBuilder b;
  JointDesc full, part;
  full.type = part.type = JointType::kHinge;
  full.axis = glm::dvec3(0, 0, 1);
  full.limits.has_hinge_limit = true;
  full.limits.hinge_min = -3.14159265359;  // a URDF's rounded pi, as the UR arms write it
  full.limits.hinge_max = 3.14159265359;
  part = full;
  part.offset_translation = glm::dvec3(0, 1, 0);
  part.axis = glm::dvec3(1, 0, 0);
  part.limits.hinge_min = -2.0;
  part.limits.hinge_max = 2.5;
  b.add_joint(full).add_joint(part).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  ASSERT_TRUE(b.build(c).ok());
  double q[2] = {-3.14159265359, -2.0};
  const glm::dvec3 before = test::tip_of(c, Eigen::Map<Eigen::VectorXd>(q, 2));
  EXPECT_TRUE(stuck::wrap_across_bound(c, 0, q));
  EXPECT_NEAR(q[0], -3.14159265359 + 2.0 * kPi, 1e-15);
  EXPECT_LE(q[0], c.limits(0).hinge_max);
  EXPECT_LT(glm::length(test::tip_of(c, Eigen::Map<Eigen::VectorXd>(q, 2)) - before), 1e-12);
  EXPECT_TRUE(stuck::wrap_across_bound(c, 0, q));  // and back from the upper bound
  EXPECT_NEAR(q[0], -3.14159265359, 1e-15);
  EXPECT_FALSE(stuck::wrap_across_bound(c, 1, q));  // on its bound, but 4.5 rad of range
  EXPECT_EQ(q[1], -2.0);
  q[0] = 1.0;
  EXPECT_FALSE(stuck::wrap_across_bound(c, 0, q));  // not on a bound
  EXPECT_EQ(q[0], 1.0);
}

// The escape keeps the best pose offered (the pose it leaves included) and gives it back only when
// it beats the pose the solve ends at; it moves the pose, within the limits, at most kMaxEscapes
// times, and never for goals that are provably out of reach.
TEST(Stuck, EscapeKeepsTheBestPoseAndHonoursItsBudget) {
  const Chain c = test::make_planar_limb(3, 2.6);
  Workspace ws(c, 1);
  SolverOptions o;
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(0, 2, 0))};
  stuck::Escapes escapes(c, Span<const Goal>(goals), o, ws);
  Eigen::VectorXd straight = Eigen::VectorXd::Zero(3);
  Eigen::VectorXd p = straight;
  for (int k = 1; k <= stuck::kMaxEscapes; ++k) {
    ASSERT_TRUE(escapes.escape(p.data(), 0.5)) << k;  // 0.5: the straight pose's cost (tip 1 away)
    EXPECT_EQ(escapes.used(), k);
    EXPECT_TRUE(within_limits(c, p.data(), 0.0)) << k;
    EXPECT_GT((p - straight).cwiseAbs().maxCoeff(), stuck::kMinEscapeAngle) << k;
    // The limited hinges were kicked into their range, not clipped back onto the bound.
    EXPECT_GT(p[1], 0.0) << k;
    EXPECT_GT(p[2], 0.0) << k;
  }
  const Eigen::VectorXd last = p;
  EXPECT_FALSE(escapes.escape(p.data(), 0.5));  // budget spent: params untouched
  EXPECT_EQ(p, last);
  // A worse end gives the best pose back; a better one is kept.
  EXPECT_FALSE(escapes.restore_best(p.data(), 0.25));
  EXPECT_EQ(p, last);
  EXPECT_TRUE(escapes.restore_best(p.data(), 0.75));
  EXPECT_EQ(p, straight);

  // Beyond the chain's reach the stuck pose is the best reach: no escape.
  const std::vector<Goal> far = {Goal::position(glm::dvec3(0, 5, 0))};
  stuck::Escapes none(c, Span<const Goal>(far), o, ws);
  p = straight;
  EXPECT_FALSE(none.escape(p.data(), 2.0));
  EXPECT_EQ(none.used(), 0);
  EXPECT_EQ(p, straight);
}

// A straight limb whose hinges start exactly on their limit 0 (range [0, 150 deg]) and a target on
// its own line, closer than full reach: a stationary point (J^T e = 0) that the limits also block
// on one side. Without restarts, every iterative solver escapes it and converges, with the limits
// respected, reporting its escapes, allocating nothing.
TEST(Stuck, StraightLimbWithHingesOnTheirLimitIsLeftByEverySolver) {
  constexpr double kMax = 150.0 * 3.14159265358979323846 / 180.0;
  for (int bones : {2, 3}) {
    const Chain c = test::make_planar_limb(bones, kMax);
    Workspace ws(c, 1);
    for (double along : {0.6, 0.9}) {
      const glm::dvec3 target(0, along * bones, 0);
      for (SolverKind kind : kIterativeSolvers) {
        SolverOptions o = test::sweep_options(c, 500);
        o.warm_start = false;
        ASSERT_EQ(o.max_restarts, 0);
        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
        const std::vector<Goal> goals = {Goal::position(target)};
        const std::size_t before = test::allocation_count();
        const SolveResult r = test::run(kind, c, goals, o, ws, p);
        const std::size_t allocations = test::allocation_count() - before;
        const std::string what = std::string(to_string(kind)) + " bones " + std::to_string(bones) + " at " +
                                 std::to_string(along);
        EXPECT_EQ(r.reason, TerminationReason::kConverged) << what;
        EXPECT_LE(glm::length(test::tip_of(c, p) - target), o.position_tolerance) << what;
        EXPECT_TRUE(within_limits(c, p.data(), 0.0)) << what;
        // A stationary point for the gradient methods; CCD's and FABRIK's joint-by-joint updates
        // leave the line of the 3-bone limb by themselves, so only the 2-bone one stops them.
        if (bones == 2 || (kind != SolverKind::kCCD && kind != SolverKind::kFABRIK)) {
          EXPECT_GE(r.escapes, 1) << what;
        }
        EXPECT_LE(r.escapes, stuck::kMaxEscapes) << what;
        EXPECT_EQ(r.restarts, 0) << what;
        EXPECT_EQ(allocations, 0u) << what;  // the escape works in the workspace
      }
    }
  }
}

// The leg of tests/godot/tests/test_features.gd's knee case, in the core: a ball hip, a hinge knee
// that folds one way only ([-2.6, 0] rad about x, the foot going forward) starting straight on its
// limit 0, and a foot target behind, below the hip and closer than the leg's length. The gradient
// asks the knee to bend the way its limit forbids, so the hip swings the straight leg toward the
// target, onto the stationary point (before the shared escape every solver but BFGS and FABRIK
// stopped there, 0.27 short). Without restarts every solver now folds the knee the way its limit
// allows, turning the hip around, and reaches the target.
TEST(Stuck, StraightLegWithKneeOnItsLimitReachesWithoutRestarts) {
  ChainBuilder b;
  JointDesc hip, knee;
  hip.type = JointType::kBall;
  knee.type = JointType::kHinge;
  knee.axis = glm::dvec3(1, 0, 0);
  knee.offset_translation = glm::dvec3(0, -0.45, 0);
  knee.limits.has_hinge_limit = true;
  knee.limits.hinge_min = -2.6;
  knee.limits.hinge_max = 0.0;
  b.add_joint(hip).add_joint(knee).set_tip_offset(glm::dvec3(0, -0.42, 0));
  Chain c;
  ASSERT_TRUE(b.build(c).ok());
  Workspace ws(c, 1);
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.0, -0.55, -0.25))};
  for (SolverKind kind : kIterativeSolvers) {
    SolverOptions o = test::sweep_options(c, 500);
    o.warm_start = false;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
    EXPECT_LE(glm::length(test::tip_of(c, p) - goals[0].target_position), o.position_tolerance) << to_string(kind);
    EXPECT_TRUE(within_limits(c, p.data(), 0.0)) << to_string(kind);
    EXPECT_LT(p[3], -0.1) << to_string(kind);  // the knee folded, within its range
    EXPECT_EQ(r.restarts, 0) << to_string(kind);
  }
}

// A constrained local minimum, the shape of the UR10's failures without restarts (elbow and wrist
// on their bounds): a planar limb of three hinges about z, each limited to [-2.5, 2.5] rad, the
// last two on their lower bound, the target (0.3, 1, 0) 0.44 away. The gradient pushes both pinned
// hinges further out and the first is at its best angle, so every step stands still and no
// null-space move helps (the bounds, not J, hold the pose): before the escape moved the pinned
// hinges to the middle of their range, pinv, DLS, BFGS and FABRIK all stopped there. Now they
// reach the target without restarts.
TEST(Stuck, HingesPinnedOnTheirBoundsAreMovedOffThem) {
  const Chain c = test::make_planar_limb(std::vector<JointLimits>(3, test::hinge_range(-2.5, 2.5)));
  ASSERT_EQ(c.joint_count(), 3);
  Workspace ws(c, 1);
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.3, 1.0, 0.0))};
  Eigen::VectorXd pinned(3);
  pinned << -0.933, -2.5, -2.5;
  EXPECT_GT(glm::length(test::tip_of(c, pinned) - goals[0].target_position), 0.44);

  // The move itself: each pinned hinge goes to the middle of its range, the free one stays.
  SolverOptions o = test::sweep_options(c, 200);
  {
    stuck::Escapes escapes(c, Span<const Goal>(goals), o, ws);
    Eigen::VectorXd p = pinned;
    ASSERT_TRUE(escapes.escape(p.data(), 0.1));
    EXPECT_DOUBLE_EQ(p[0], pinned[0]);
    EXPECT_EQ(p[1], 0.0);
    EXPECT_EQ(p[2], 0.0);
  }
  for (SolverKind kind : {SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kFABRIK}) {
    o.warm_start = true;
    Eigen::VectorXd p = pinned;
    const std::size_t before = test::allocation_count();
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_EQ(test::allocation_count() - before, 0u) << to_string(kind);
    EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
    EXPECT_LE(glm::length(test::tip_of(c, p) - goals[0].target_position), o.position_tolerance) << to_string(kind);
    EXPECT_TRUE(within_limits(c, p.data(), 0.0)) << to_string(kind);
    EXPECT_GE(r.escapes, 1) << to_string(kind);
    EXPECT_EQ(r.restarts, 0) << to_string(kind);
  }
}

// The best pose across escapes: on the straight limb, where every solver escapes at once, the
// final error never grows with the iteration budget (each budget's run is a prefix of the next
// one's, and what it returns is the best it saw) and never exceeds the straight start's.
TEST(Stuck, MoreIterationsNeverReturnAWorsePose) {
  const Chain c = test::make_planar_limb(2, 2.6);
  Workspace ws(c, 1);
  const glm::dvec3 target(0, 1.2, 0);
  for (SolverKind kind : kIterativeSolvers) {
    double previous = 2.0 - 1.2;  // the straight start's distance
    int escaped = 0;
    for (int budget = 1; budget <= 40; ++budget) {
      SolverOptions o = test::sweep_options(c, budget);
      o.warm_start = false;
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, {Goal::position(target)}, o, ws, p);
      EXPECT_LE(r.final_position_error, previous + 1e-15) << to_string(kind) << " budget " << budget;
      previous = r.final_position_error;
      escaped += r.escapes > 0;
    }
    EXPECT_GT(escaped, 0) << to_string(kind);  // the runs did escape
    EXPECT_LE(previous, 1e-5 * 2.0) << to_string(kind);
  }
}

// Reachable goals that no pose meets (a planar chain, a target off its plane): every solver gets
// stuck again after each escape, spends its budget of escapes (without restarts; with them a run
// may stop early, see kEscapeGain), reports them, and ends stalled at the in-plane best (FABRIK
// near it: its hinge conversion has fixed points of its own); the same call gives the same pose,
// iterations and escapes. Beyond reach (the lecture's precision case) nothing escapes.
TEST(Stuck, EscapesAreBoundedReportedAndDeterministic) {
  const Chain c = test::make_planar_limb(2);
  Workspace ws(c, 1);
  for (SolverKind kind : kIterativeSolvers) {
    SolverOptions o = test::sweep_options(c, 2000);
    Eigen::VectorXd first = Eigen::VectorXd::Constant(c.dof_count(), 0.3);
    Eigen::VectorXd second = first;
    const std::vector<Goal> goals = {Goal::position(glm::dvec3(0.5, 1.0, 1.0))};
    const SolveResult r1 = test::run(kind, c, goals, o, ws, first);
    const SolveResult r2 = test::run(kind, c, goals, o, ws, second);
    EXPECT_EQ(r1.reason, TerminationReason::kStalled) << to_string(kind);
    // Every escape leads nowhere and, with no restart to take over, the whole budget is spent
    // (even by FABRIK, whose cost is not monotone: an escape that led only to a slightly lower
    // minimum stops a run only when restarts follow, stuck::kEscapeGain).
    // The Newton-like solvers' run is a query (started far from its goals, no restart follows:
    // Escapes::cold_query), which has the far escapes too.
    const bool query = kind == SolverKind::kJacobianPinv || kind == SolverKind::kDLS || kind == SolverKind::kBFGS;
    EXPECT_EQ(r1.escapes, stuck::kMaxEscapes + (query ? stuck::kFarEscapes : 0)) << to_string(kind);
    EXPECT_NEAR(r1.final_position_error, 1.0, kind == SolverKind::kFABRIK ? 2e-2 : 1e-4) << to_string(kind);
    EXPECT_EQ(first, second) << to_string(kind);
    EXPECT_EQ(r1.iterations, r2.iterations) << to_string(kind);
    EXPECT_EQ(r1.escapes, r2.escapes) << to_string(kind);
    // Restarts are the outer layer: each run has its own budget of escapes, and they add up; each
    // run escapes at least once. FABRIK's runs each find a slightly lower minimum after their first
    // escape and leave the rest to the restarts (stuck::kEscapeGain).
    o.max_restarts = 2;
    Eigen::VectorXd p = Eigen::VectorXd::Constant(c.dof_count(), 0.3);
    const SolveResult rr = test::run(kind, c, goals, o, ws, p);
    EXPECT_EQ(rr.restarts, 2) << to_string(kind);
    EXPECT_GE(rr.escapes, 3) << to_string(kind);
    EXPECT_LE(rr.escapes, 3 * stuck::kMaxEscapes) << to_string(kind);
    if (kind == SolverKind::kFABRIK) {
      EXPECT_LT(rr.escapes, 3 * stuck::kMaxEscapes);
    }
  }
  const Chain straight = test::make_hinge_chain(10);
  Workspace ws10(straight, 1);
  for (SolverKind kind : kIterativeSolvers) {
    SolverOptions o = test::sweep_options(straight, 500);
    Eigen::VectorXd p = Eigen::VectorXd::Constant(straight.dof_count(), 0.35);
    const SolveResult r = test::run(kind, straight, {Goal::position(glm::dvec3(0, 12, 0))}, o, ws10, p);
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable) << to_string(kind);
    EXPECT_EQ(r.escapes, 0) << to_string(kind);
  }
}

// Issue 16, item 20: a query's descent crosses a full-turn bound. A planar arm of two unit bones
// about z: the shoulder's range [-pi, pi] (a UR joint), the elbow held near 0.5 rad by its range
// [0.4, 0.6]. From a shoulder at -2.5 the target (shoulder 2.9) lies 0.88 rad away through the wall
// at -pi (5.4 rad the other way round), so the descent runs into -pi and the gradient presses the
// shoulder against it. A query (started 0.86 of L away, no restart to follow) crosses to +pi, the
// same pose, at once and descends on without an escape. With a restart to follow there is no
// crossing inside the run (the restarts wrap), and the run escapes to leave the wall (its
// off-the-bounds move wraps the hinge); so does a tracking frame started within 25 % of L (a
// shoulder at -3.05, the target's at 3.10).
TEST(Stuck, AQueryCrossesAFullTurnBoundInsteadOfEscaping) {
  const Chain c = test::make_planar_limb({test::hinge_range(-3.14159265359, 3.14159265359),  // as URDFs write pi
                                          test::hinge_range(0.4, 0.6)});
  ASSERT_EQ(c.joint_count(), 2);
  Workspace ws(c, 1);
  struct Case {
    const char* what;
    double start, solution;  // the shoulder's
    int max_restarts;
    bool escapes;
  };
  for (const Case& k : {Case{"query", -2.5, 2.9, 0, false}, Case{"query with restarts", -2.5, 2.9, 1, true},
                        Case{"tracking frame", -3.05, 3.10, 0, true}}) {
    Eigen::VectorXd solution(2);
    solution << k.solution, 0.5;
    const std::vector<Goal> goals = {Goal::position(test::tip_of(c, solution))};
    for (SolverKind kind : {SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS}) {
      const std::string what = std::string(k.what) + " " + to_string(kind);
      SolverOptions o;
      o.warm_start = true;
      o.max_restarts = k.max_restarts;
      Eigen::VectorXd p(2);
      p << k.start, 0.5;
      const std::size_t before = test::allocation_count();
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      EXPECT_EQ(test::allocation_count() - before, 0u) << what;
      EXPECT_EQ(r.reason, TerminationReason::kConverged) << what;
      EXPECT_NEAR(p[0], k.solution, 1e-4) << what;
      EXPECT_EQ(r.restarts, 0) << what;
      if (k.escapes) {
        EXPECT_GE(r.escapes, 1) << what;
      } else {
        EXPECT_EQ(r.escapes, 0) << what;
      }
    }
  }
}

// Real arms' position goals that the limits trapped before the creep rule, the full-turn wrap, the
// third escape's farther off-the-bounds move and the escapes' full budget without restarts (each
// listed solver ran out of iterations or stalled there): the left arm of Baxter and a UR10 (their
// URDFs' joint origins and limits, as tools/urdf_chain.py folds them; scripts/bench's
// robots_bench goals of those indices), each goal the tip of a joint vector within the limits,
// every solve from the middle of the limits with max_iterations 100 and no restart. Each now
// converges within the limits: on Baxter escaping at least once; on the UR10, whose traps were
// its +-pi walls, without an escape (a query's descent crosses them: issue 16, item 20). The tip
// is checked by a forward kinematics of 4x4 transforms (test::hinge_tool_frame_by_matrices), not
// the library's.
using ArmJoint = bench::UrdfHinge;

Chain arm_chain(const std::vector<ArmJoint>& joints, const glm::dvec3& tool) {
  Chain c;
  EXPECT_TRUE(bench::urdf_hinge_builder(joints, tool).build(c).ok());
  return c;
}

struct TrappedGoal {
  std::vector<double> truth;             // joints whose tip is the goal
  std::vector<SolverKind> used_to_fail;  // solvers trapped there before
};

TEST(Stuck, RealArmPositionGoalsHeldByTheLimitsConvergeWithoutRestarts) {
  const double h = 0.7071067811882787, h2 = 0.7071067811848163, a = 0.5000000000024483, a2 = 0.4999999999975517;
  const std::vector<ArmJoint> baxter = {
      {0.055695, 0.0, 0.011038, 1, 0, 0, 0, 0, 0, 1, -1.70167993878, 1.70167993878},
      {0.069, 0.0, 0.27035, h, -h2, 0, 0, 0, 0, 1, -2.147, 1.047},
      {0.102, 0.0, 0.0, a, 0.5, a2, 0.5, 0, 0, 1, -3.05417993878, 3.05417993878},
      {0.069, 0.0, 0.26242, a, -0.5, -0.5, -a2, 0, 0, 1, -0.05, 2.618},
      {0.10359, 0.0, 0.0, a, 0.5, a2, 0.5, 0, 0, 1, -3.059, 3.059},
      {0.01, 0.0, 0.2707, a, -0.5, -0.5, -a2, 0, 0, 1, -1.57079632679, 2.094},
      {0.115975, 0.0, 0.0, a, 0.5, a2, 0.5, 0, 0, 1, -3.059, 3.059}};
  const double pi = 3.14159265359;
  const std::vector<ArmJoint> ur10 = {{0.0, 0.0, 0.1273, 1, 0, 0, 0, 0, 0, 1, -pi, pi},
                                      {0.0, 0.220941, 0.0, h, 0, h2, 0, 0, 1, 0, -pi, pi},
                                      {0.0, -0.1719, 0.612, 1, 0, 0, 0, 0, 1, 0, -pi, pi},
                                      {0.0, 0.0, 0.5723, h, 0, h2, 0, 0, 1, 0, -pi, pi},
                                      {0.0, 0.1149, 0.0, 1, 0, 0, 0, 0, 0, 1, -pi, pi},
                                      {0.0, 0.0, 0.1157, 1, 0, 0, 0, 0, 1, 0, -pi, pi}};
  const SolverKind pinv = SolverKind::kJacobianPinv, dls = SolverKind::kDLS, bfgs = SolverKind::kBFGS;
  struct Arm {
    const char* name;
    const std::vector<ArmJoint>* joints;
    glm::dvec3 tool;
    std::vector<TrappedGoal> goals;
    bool full_turn;  // every hinge spans [-pi, pi]: the trapped solvers no longer escape
  };
  const std::vector<Arm> arms = {
      {"baxter_left", &baxter, glm::dvec3(0, 0, 0.27125),
       {{{0.56421780222397988, -2.0680227589033175, 2.1204598581899781, 0.36621006852676652, 0.84759449356379202,
          0.0093909481400979988, -1.674247784004965},
         {dls}},  // a creep with joint 0 on its bound
        {{-0.53503519804560895, -0.12734383526533, 2.0622755928093479, 2.1268362727127736, 0.97156464288687783,
          1.4401233248373164, 2.8900911335029482},
         {pinv, bfgs}},
        {{0.29960255569657912, 0.3189784908360016, 2.9650315909127469, 2.3236609456464716, 0.022682835748581098,
          0.66835988395224533, 1.7269304472909051},
         {pinv, dls}},
        {{-1.5103252856591047, -0.056478858157023915, 2.7603312588340154, 2.532936300051897, 2.1439485311627733,
          0.65600324501456742, -2.6777278029702942},
         {dls}}},
       false},
      {"ur10", &ur10, glm::dvec3(0, 0.0922, 0),  // tool0 (its rotation does not move the tip)
       {{{0.29606653905167724, -1.8404017556883048, -2.1197645924758048, -2.8932712287841187, 2.5678666302623876,
          0.075276036582132111},
         {dls}},  // a creep along the +-pi walls
        {{0.52515747069519714, 2.2542530834001413, 1.8270233788244603, 2.8876413136062071, -2.7837771775831519,
          0.1535923517291331},
         {pinv}},
        {{1.9961051755698325, -1.1734976511576602, 3.1113369110856226, -1.5297430085362973, -2.9534534897992888,
          0.59894120432056708},
         {}},  // BFGS was trapped here; with Fletcher & Xu's Gauss-Newton steps it converges unescaped
        {{0.51719579538997706, 2.2512291294455036, 2.1401776530079957, -1.6031767864644881, 0.83526819470096569,
          -2.8688845489907115},
         {pinv, bfgs}}},
       true}};
  for (const Arm& arm : arms) {
    const Chain c = arm_chain(*arm.joints, arm.tool);
    const int n = c.dof_count();
    Workspace ws(c, 1);
    Eigen::VectorXd middle(n);
    for (int i = 0; i < n; ++i) middle[i] = 0.5 * ((*arm.joints)[i].lower + (*arm.joints)[i].upper);
    for (size_t g = 0; g < arm.goals.size(); ++g) {
      const TrappedGoal& goal = arm.goals[g];
      const glm::dvec3 target(test::hinge_tool_frame_by_matrices(c, goal.truth.data())[3]);
      for (SolverKind kind : {pinv, dls, bfgs}) {
        SolverOptions o;
        o.position_tolerance = 1e-5 * c.total_length();
        o.max_iterations = 100;
        o.warm_start = true;
        ASSERT_EQ(o.max_restarts, 0);
        Eigen::VectorXd p = middle;
        const SolveResult r = test::run(kind, c, {Goal::position(target)}, o, ws, p);
        const std::string what = std::string(arm.name) + " goal " + std::to_string(g) + " " + to_string(kind);
        EXPECT_EQ(r.reason, TerminationReason::kConverged) << what;
        EXPECT_EQ(r.restarts, 0) << what;
        EXPECT_TRUE(within_limits(c, p.data(), 0.0)) << what;
        const glm::dvec3 reached(test::hinge_tool_frame_by_matrices(c, p.data())[3]);
        EXPECT_LE(glm::length(reached - target), o.position_tolerance) << what;
        if (std::find(goal.used_to_fail.begin(), goal.used_to_fail.end(), kind) != goal.used_to_fail.end()) {
          if (arm.full_turn) {
            EXPECT_EQ(r.escapes, 0) << what;
          } else {
            EXPECT_GE(r.escapes, 1) << what;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace ikchain
