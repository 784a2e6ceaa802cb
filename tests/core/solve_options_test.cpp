// Options every solver honours: the time budget (SolverOptions::time_budget_usec) and the pole
// (use_pole / pole_in_base) as a preference that never costs accuracy.
#include <cmath>
#include <random>
#include <string>

#include "solver_test_util.hpp"

namespace ikchain {
namespace {

const SolverKind kIterativeSolvers[] = {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS,
                                        SolverKind::kBFGS, SolverKind::kFABRIK};

// A 100-joint chain and a goal none of the solvers meets in one iteration (a reachable target at a
// tolerance of 1e-14 L, so every solve runs until a budget or a stall stops it).
struct HardProblem {
  Chain chain = test::make_hinge_chain(100, 0.1);
  std::vector<Goal> goals;
  SolverOptions options;
  HardProblem() {
    std::mt19937 rng(7);
    goals = {Goal::position(test::tip_of(chain, test::random_params(chain, rng, 1.0)))};
    options.position_tolerance = 1e-14 * chain.total_length();
    options.max_iterations = 1000;
    options.stall_tolerance = 0.0;
    options.warm_start = false;
  }
};

// A fake clock (microseconds) that advances kTick on every reading: the solve "takes" kTick per
// budget check, so where it stops is exact, not timing noise.
constexpr double kTick = 10.0;
double fake_now = 0.0;
double fake_clock() { return fake_now += kTick; }

TEST(TimeBudget, TinyBudgetStopsBeforeTheFirstIteration) {
  HardProblem hp;
  hp.options.time_budget_usec = 1e-3;
  Workspace ws(hp.chain, 1);
  for (SolverKind kind : kIterativeSolvers) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(hp.chain.dof_count());
    const SolveResult r = test::run(kind, hp.chain, hp.goals, hp.options, ws, p);
    EXPECT_EQ(r.iterations, 0) << to_string(kind);  // checked before every iteration (issue 16, item 6)
    EXPECT_TRUE(r.budget_exhausted) << to_string(kind);
    EXPECT_EQ(r.reason, TerminationReason::kMaxIterations) << to_string(kind);
    EXPECT_TRUE(r.usable());
    EXPECT_LE(r.final_error, r.initial_error) << to_string(kind);
  }
}

// The budget is checked before every iteration, the first included, and within the long ones
// (see below): with every check costing kTick of fake time, a budget of B stops the solve at the
// ceil(B / kTick)-th check (or earlier, when the next stretch would end past the bound: see
// Deadline), after fewer iterations than checks - never more than 10 % + one check over the
// budget - and reports it.
TEST(TimeBudget, NeverOverrunsByMoreThanOneIteration) {
  HardProblem hp;
  Workspace ws(hp.chain, 1);
  ws.deadline.clock_us = &fake_clock;
  for (double budget : {25.0, 40.0, 100.0}) {
    hp.options.time_budget_usec = budget;
    int exhausted = 0;
    for (SolverKind kind : kIterativeSolvers) {
      fake_now = 0.0;
      Eigen::VectorXd p = Eigen::VectorXd::Zero(hp.chain.dof_count());
      const SolveResult r = test::run(kind, hp.chain, hp.goals, hp.options, ws, p);
      const double spent = fake_now - kTick;  // the arming reading is the start
      EXPECT_LE(spent, 1.1 * budget + kTick) << to_string(kind);
      if (r.budget_exhausted) {
        ++exhausted;
        // At the budget's end, or before it when the next stretch and the exit work, predicted from
        // the gaps between readings, would have ended past 1.1 x budget + 20 us (Deadline::foreseen:
        // the longest gap, or stretch_ratio set-up gaps if longer, then the longest gap; so at the
        // dispatcher's reading after its set-up, before the solver's first, which budget_readings
        // does not count, kFirstStretchRatio + 1 gaps: Deadline::spent_before_solver).
        const Deadline& d = ws.deadline;
        if (d.foreseen)
          EXPECT_GT(spent + (d.budget_readings == 0 ? (Deadline::kFirstStretchRatio + 1.0) * d.longest_gap_us
                                                    : std::max(d.longest_gap_us, d.stretch_ratio * d.setup_gap_us) +
                                                          d.longest_gap_us),
                    1.1 * budget + 20.0 - Deadline::kReserveUs) << to_string(kind);
        else
          EXPECT_GE(spent, budget) << to_string(kind);
        const int checks = static_cast<int>(std::ceil(budget / kTick));
        // Every solver checks more than once per iteration (issue 16, item 6): DLS and the
        // pseudo-inverse before each linearisation too (the pseudo-inverse also between the halvings
        // of one iteration, many FK passes each), BFGS before its O(n^2) inverse-Hessian passes,
        // CCD and FABRIK every Deadline::kJointsPerCheck joints of a sweep (100 here). So the checks
        // are spread over fewer iterations than checks (BFGS's first Gauss-Newton step alone reads
        // the clock once per row of J J^T, so it may stop inside it with none done).
        EXPECT_LE(r.iterations, checks - 1) << to_string(kind);
      } else {
        EXPECT_NE(r.reason, TerminationReason::kMaxIterations) << to_string(kind);
      }
    }
    if (budget <= 40.0) {
      EXPECT_EQ(exhausted, 5) << "budget " << budget;  // none is done in 4 iterations
    }
  }
}

// No budget (0): the same solves run past where any budget above would have stopped them.
TEST(TimeBudget, ZeroMeansNone) {
  HardProblem hp;
  hp.options.max_iterations = 60;
  Workspace ws(hp.chain, 1);
  for (SolverKind kind : kIterativeSolvers) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(hp.chain.dof_count());
    const SolveResult r = test::run(kind, hp.chain, hp.goals, hp.options, ws, p);
    EXPECT_FALSE(r.budget_exhausted) << to_string(kind);
    EXPECT_GT(r.iterations, 1) << to_string(kind);
  }
}

TEST(TimeBudget, NegativeBudgetIsInvalid) {
  HardProblem hp;
  hp.options.time_budget_usec = -1.0;
  Workspace ws(hp.chain, 1);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(hp.chain.dof_count());
  const SolveResult r = test::run(SolverKind::kDLS, hp.chain, hp.goals, hp.options, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("time_budget_usec"), std::string::npos) << r.message.c_str();
}

// ---------------------------------------------------------------------------------------------
// Pole.

// A leg hanging down -Y: hip (ball) at the origin, knee (hinge about x) 1 below, ankle (ball) 1
// below that, the foot 0.3 further. Straight at rest.
Chain leg(bool hinge_root = false, bool limited_hip = false) {
  ChainBuilder b;
  JointDesc hip;
  if (hinge_root) {
    hip.type = JointType::kHinge;
    hip.axis = glm::dvec3(1, 0, 0);
  }
  if (limited_hip) {
    // Hardly any twist about the thigh: the swivel (about the hip -> foot axis, close to the thigh)
    // is clipped, so it would move the foot and must be refused.
    hip.limits.has_twist_limit = true;
    hip.limits.twist_axis = glm::dvec3(0, -1, 0);
    hip.limits.twist_min = -0.01;
    hip.limits.twist_max = 0.01;
  }
  b.add_joint(hip);
  JointDesc knee;
  knee.type = JointType::kHinge;
  knee.axis = glm::dvec3(1, 0, 0);
  knee.offset_translation = glm::dvec3(0, -1, 0);
  b.add_joint(knee);
  JointDesc ankle;
  ankle.offset_translation = glm::dvec3(0, -1, 0);
  b.add_joint(ankle);
  b.set_tip_offset(glm::dvec3(0, -0.3, 0));
  Chain c;
  const Message m = b.build(c).message;
  EXPECT_TRUE(m.empty()) << m.c_str();
  return c;
}

// Unit direction of the knee's offset from the hip -> foot line.
glm::dvec3 knee_side(const Chain& c, const Eigen::VectorXd& p) {
  Workspace fk(c, 1);
  forward_kinematics(c, p.data(), fk);
  const glm::dvec3 axis = glm::normalize(fk.tip - fk.joint_origins[0]);
  const glm::dvec3 knee = fk.joint_origins[1] - fk.joint_origins[0];
  return glm::normalize(knee - axis * glm::dot(knee, axis));
}

// From the straight rest pose (a saddle: every solver must bend the knee some way), the knee ends
// on the pole's side, for poles in front, behind and to either side; the foot on its target.
TEST(Pole, LegWithHingeKneeBendsTowardThePoleEverySolver) {
  const Chain c = leg();
  Workspace ws(c, 1);
  const glm::dvec3 target(0.2, -1.6, 0.1);
  for (SolverKind kind : kIterativeSolvers) {
    for (const glm::dvec3& pole : {glm::dvec3(0, -1, 3), glm::dvec3(0, -1, -3), glm::dvec3(3, -1, 0),
                                   glm::dvec3(-3, -1, 0)}) {
      SolverOptions o;
      o.position_tolerance = 1e-6;
      o.max_iterations = 300;
      o.warm_start = false;
      o.use_pole = true;
      o.pole_in_base = pole;
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, {Goal::position(target)}, o, ws, p);
      EXPECT_EQ(r.reason, TerminationReason::kConverged) << to_string(kind);
      EXPECT_LE(glm::length(test::tip_of(c, p) - target), o.position_tolerance) << to_string(kind);
      // The pole's direction from the hip -> foot line.
      Workspace fk(c, 1);
      forward_kinematics(c, p.data(), fk);
      const glm::dvec3 axis = glm::normalize(fk.tip - fk.joint_origins[0]);
      const glm::dvec3 pole_side = glm::normalize(pole - axis * glm::dot(pole, axis));
      EXPECT_GT(glm::dot(knee_side(c, p), pole_side), 0.999) << to_string(kind) << " pole " << pole.x << ","
                                                              << pole.z;
    }
  }
}

// The pole never costs accuracy: where the swivel would be clipped by a limit (and so move the
// foot), the solver's own pose is returned unchanged.
TEST(Pole, RefusedWhenALimitWouldMoveTheGoal) {
  const Chain c = leg(false, true);
  Workspace ws(c, 1);
  const glm::dvec3 target(0.0, -1.6, 0.4);
  for (SolverKind kind : kIterativeSolvers) {
    SolverOptions o;
    o.position_tolerance = 1e-6;
    o.max_iterations = 300;
    o.warm_start = false;
    Eigen::VectorXd without = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r0 = test::run(kind, c, {Goal::position(target)}, o, ws, without);
    o.use_pole = true;
    o.pole_in_base = glm::dvec3(3, -1, 0);  // to the side: a quarter turn about the thigh
    Eigen::VectorXd with = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r1 = test::run(kind, c, {Goal::position(target)}, o, ws, with);
    EXPECT_EQ(r0.reason, r1.reason) << to_string(kind);
    EXPECT_LE(r1.final_position_error, r0.final_position_error + 1e-12) << to_string(kind);
    EXPECT_EQ(with, without) << to_string(kind);
  }
}

// A hinge root cannot swivel: the pole changes nothing (documented in solve.cpp).
TEST(Pole, HingeRootIgnoresThePole) {
  const Chain c = leg(true);
  Workspace ws(c, 1);
  const glm::dvec3 target(0.0, -1.5, 0.5);
  for (SolverKind kind : kIterativeSolvers) {
    SolverOptions o;
    o.warm_start = false;
    Eigen::VectorXd without = Eigen::VectorXd::Zero(c.dof_count());
    test::run(kind, c, {Goal::position(target)}, o, ws, without);
    o.use_pole = true;
    o.pole_in_base = glm::dvec3(3, -1, 0);
    Eigen::VectorXd with = Eigen::VectorXd::Zero(c.dof_count());
    test::run(kind, c, {Goal::position(target)}, o, ws, with);
    EXPECT_EQ(with, without) << to_string(kind);
  }
}

// With a tip orientation goal the chain swivels about root -> wrist and the wrist turns back:
// the full pose stays met and the elbow (joint 1) goes to the pole's side, either side.
TEST(Pole, FullPoseGoalKeepsTheToolFrame) {
  const Chain c = test::make_ball_chain(4, 0.5);
  Workspace ws(c, 2);
  std::mt19937 rng(13);
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kJacobianPinv}) {
    for (int t = 0; t < 10; ++t) {
      const Eigen::VectorXd truth = test::random_params(c, rng, 1.0);
      Workspace fk(c, 1);
      forward_kinematics(c, truth.data(), fk);
      const std::vector<Goal> goals = {Goal::position(fk.tip), Goal::orientation(fk.joint_orientations[3])};
      const glm::dvec3 wrist = fk.joint_origins[3];
      const glm::dvec3 axis = glm::normalize(wrist);
      const glm::dvec3 side = glm::normalize(glm::cross(axis, glm::dvec3(0.3, 0.1, 1.0)));
      for (double sign : {1.0, -1.0}) {
        SolverOptions o;
        o.position_tolerance = 1e-6;
        o.orientation_tolerance = 1e-6;
        o.max_iterations = 300;
        o.warm_start = false;
        o.use_pole = true;
        o.pole_in_base = 0.5 * wrist + 3.0 * sign * side;
        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
        const SolveResult r = test::run(kind, c, goals, o, ws, p);
        if (r.reason != TerminationReason::kConverged) continue;
        forward_kinematics(c, p.data(), fk);
        const glm::dvec3 w = glm::normalize(fk.joint_origins[3]);
        glm::dvec3 middle = fk.joint_origins[1] + fk.joint_origins[2];
        middle -= w * glm::dot(middle, w);
        const glm::dvec3 pole_perp = o.pole_in_base - w * glm::dot(o.pole_in_base, w);
        EXPECT_GT(glm::dot(glm::normalize(middle), glm::normalize(pole_perp)), 0.999) << to_string(kind);
        EXPECT_LE(r.final_position_error, o.position_tolerance);
        EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
      }
    }
  }
}

TEST(Pole, NonFinitePoleIsInvalid) {
  const Chain c = leg();
  Workspace ws(c, 1);
  SolverOptions o;
  o.use_pole = true;
  o.pole_in_base = glm::dvec3(0, NAN, 0);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult r = test::run(SolverKind::kDLS, c, {Goal::position(glm::dvec3(0, -1.5, 0.5))}, o, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("pole_in_base"), std::string::npos) << r.message.c_str();
}

TEST(Pole, SolveAllocatesNothing) {
  const Chain c = leg();
  SolverOptions o;
  o.use_pole = true;
  o.pole_in_base = glm::dvec3(0, -1, 3);
  o.time_budget_usec = 1e6;
  for (SolverKind kind : kIterativeSolvers)
    test::expect_solves_allocate_nothing(kind, c, {Goal::position(glm::dvec3(0.2, -1.6, 0.1))}, o);
}

}  // namespace
}  // namespace ikchain
