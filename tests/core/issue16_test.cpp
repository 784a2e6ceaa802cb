// Regression tests of issue 16's core items, one per item, named after it. Each fails on b0e1161.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include "core/math/linalg.hpp"
#include "core/solvers/stuck.hpp"
#include "humanoid.hpp"
#include "joint_desc.hpp"  // bench/
#include "solver_test_util.hpp"
#include "telescope_arm.hpp"
#include "tree_test_util.hpp"

namespace ikchain {
namespace {

// Three hinges (z, y, z) of 0.5 m along +Y, the tip 0.3 m further, turned by `tip_rotation`.
Chain arm_with_tip_rotation(const glm::dquat& tip_rotation, Message* message = nullptr) {
  ChainBuilder b;
  for (int i = 0; i < 3; ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = i == 1 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 0.5, 0);
    b.add_joint(j);
  }
  b.set_tip_frame(glm::dvec3(0, 0.3, 0), tip_rotation);
  Chain c;
  const Message m = b.build(c).message;
  if (message) *message = m;
  return c;
}

glm::dquat tip_orientation(const Chain& chain, const Eigen::VectorXd& params) {
  Workspace ws(chain, 1);
  forward_kinematics(chain, params.data(), ws);
  return effector_orientation(chain, ws, chain.joint_count());
}

// The angle between two rotations (rad).
double angle_between(const glm::dquat& a, const glm::dquat& b) {
  return glm::length(so3::log(glm::normalize(a * glm::conjugate(b))));
}

// Item 2: a finite tip rotation of huge components (1e300) is the rotation it scales, not the zero
// quaternion (glm::length overflowed to inf, and q / inf = 0); a goal's target_orientation of huge
// components likewise is its rotation, not an invalid input.
TEST(Issue16, HugeTipRotationIsNormalisedNotZeroed) {
  const glm::dquat unit = glm::angleAxis(2.0, glm::normalize(glm::dvec3(1, 2, 3)));
  for (double scale : {1e300, 1e200, 1e160}) {  // squares overflow; (tiny ones are rejected, as rest rotations)
    Message m;
    const Chain huge = arm_with_tip_rotation(unit * scale, &m);
    ASSERT_TRUE(m.empty()) << scale << ": " << m.c_str();
    const glm::dquat stored = huge.tip_rotation();
    EXPECT_NEAR(stored.w, unit.w, 1e-15) << scale;
    EXPECT_NEAR(stored.x, unit.x, 1e-15) << scale;
    EXPECT_NEAR(stored.y, unit.y, 1e-15) << scale;
    EXPECT_NEAR(stored.z, unit.z, 1e-15) << scale;
  }
  // The round trip: an orientation goal made by FK of the unit-rotation chain, solved on the
  // huge-rotation chain, is met there by the same FK (the old zero tip rotation made DLS report
  // "converged" with error 0 while the tip frame was 2.12 rad off).
  const Chain reference = arm_with_tip_rotation(unit);
  const Chain huge = arm_with_tip_rotation(unit * 1e300);
  const Eigen::VectorXd goal_pose = (Eigen::VectorXd(3) << 0.4, -0.7, 1.1).finished();
  const glm::dquat target = tip_orientation(reference, goal_pose);
  Workspace ws(huge, 1);
  SolverOptions o = test::cold_start_options(huge);
  for (const glm::dquat& given : {target, target * 1e300}) {  // the goal's own huge quaternion too
    Eigen::VectorXd p = Eigen::VectorXd::Zero(3);
    const SolveResult r = test::run(SolverKind::kDLS, huge, {Goal::orientation(given)}, o, ws, p);
    ASSERT_TRUE(r.usable()) << r.message.c_str();
    EXPECT_EQ(r.reason, TerminationReason::kConverged);
    EXPECT_LE(angle_between(tip_orientation(reference, p), target), o.orientation_tolerance);
    EXPECT_LE(r.final_orientation_error, o.orientation_tolerance);
  }
  // The same goal from the rest pose reports the real start error, not 0.
  Eigen::VectorXd p = Eigen::VectorXd::Zero(3);
  o.max_iterations = 1;
  const SolveResult r = test::run(SolverKind::kDLS, huge, {Goal::orientation(target)}, o, ws, p);
  EXPECT_NEAR(r.initial_orientation_error, angle_between(tip_orientation(reference, Eigen::VectorXd::Zero(3)), target),
              1e-12);
}

// A ball shoulder, a slide along +Y (0..0.8 m) 0.5 m up, a hinge elbow 0.5 m further, the tip 0.5 m
// beyond: 0.5 + 0.8 + 0.5 reach from the shoulder at full slide... plus the first bone.
Chain telescope() { return test::telescope_arm(/*with_wrist=*/false); }

// Item 3: set_offsets measures bones as build() does (a slide's range counts), and takes the same
// +-kMaxMagnitude bound.
TEST(Issue16, SetOffsetsKeepsSlidesAndTheMagnitudeBound) {
  Chain c = telescope();
  const std::vector<double> built = c.bone_lengths();
  const double built_total = c.total_length();
  EXPECT_DOUBLE_EQ(built[1], 0.5 + 0.8);
  const glm::dvec3 same[3] = {glm::dvec3(0.0), glm::dvec3(0, 0.5, 0), glm::dvec3(0, 0.5, 0)};
  ASSERT_TRUE(c.set_offsets(same, 3, glm::dvec3(0, 0.5, 0)).empty());
  EXPECT_EQ(c.bone_lengths(), built);  // exactly: one definition
  EXPECT_EQ(c.total_length(), built_total);

  // A target 2.1 m up needs the slide (bones alone reach 1.5 m): reachable, and reached.
  Workspace ws(c, 1);
  const SolverOptions o = test::cold_start_options(c);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult r = test::run(SolverKind::kDLS, c, {Goal::position(glm::dvec3(0, 2.1, 0))}, o, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  EXPECT_LE(glm::length(test::tip_of(c, p) - glm::dvec3(0, 2.1, 0)), o.position_tolerance);

  // Beyond the bound: rejected with the field named, the chain unchanged.
  const glm::dvec3 huge[3] = {glm::dvec3(0.0), glm::dvec3(0, 1e60, 0), glm::dvec3(0, 0.5, 0)};
  Message m = c.set_offsets(huge, 3, glm::dvec3(0, 0.5, 0));
  EXPECT_NE(std::string(m.c_str()).find("joint 1: offset_translation"), std::string::npos) << m.c_str();
  m = c.set_offsets(same, 3, glm::dvec3(-1e51, 0, 0));
  EXPECT_NE(std::string(m.c_str()).find("tip_offset"), std::string::npos) << m.c_str();
  EXPECT_EQ(c.bone_lengths(), built);
  EXPECT_EQ(c.total_length(), built_total);
  EXPECT_EQ(c.offset_translation(1), glm::dvec3(0, 0.5, 0));
  // Just inside the bound is accepted, and solves give finite errors.
  const glm::dvec3 big[3] = {glm::dvec3(0.0), glm::dvec3(0, 1e50, 0), glm::dvec3(0, 0.5, 0)};
  ASSERT_TRUE(c.set_offsets(big, 3, glm::dvec3(0, 0.5, 0)).empty());
  p.setZero();
  const SolveResult far = test::run(SolverKind::kDLS, c, {Goal::position(glm::dvec3(0, 2.1, 0))}, o, ws, p);
  EXPECT_TRUE(std::isfinite(far.initial_error) && std::isfinite(far.final_error));
}

// A 7-DOF arm with limits on every joint (the restarts suite's kind of arm): a full-pose goal it
// cannot meet near the middle of its limits stalls; with restarts and a budget the budget ends the
// search.
Chain limited_arm() {
  ChainBuilder b;
  const glm::dvec3 axes[7] = {{0, 0, 1}, {0, 1, 0}, {0, 0, 1}, {0, 1, 0}, {0, 0, 1}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 7; ++i) {
    JointDesc j;
    j.type = JointType::kHinge;
    j.axis = axes[i];
    j.offset_translation = i == 0 ? glm::dvec3(0.0) : glm::dvec3(0, 0.3, 0);
    j.limits.has_hinge_limit = true;
    j.limits.hinge_min = -0.3;
    j.limits.hinge_max = 0.3;
    b.add_joint(j);
  }
  b.set_tip_offset(glm::dvec3(0, 0.1, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

// Item 4: budget_exhausted comes only with max_iterations or unreachable (result.hpp), also when the
// budget ends restarts after a stalled run.
TEST(Issue16, BudgetExhaustedNeverComesWithStalled) {
  const Chain c = limited_arm();
  Workspace ws(c, 2);
  // Far out of the limited workspace but within the reach sphere: not provably unreachable, so
  // restarts run; every run stalls on the limits.
  const std::vector<Goal> goals = {Goal::position(glm::dvec3(1.2, 0.9, 0.5)),
                                   Goal::orientation(glm::angleAxis(2.5, glm::dvec3(1, 0, 0)))};
  SolverOptions o = test::cold_start_options(c);
  o.max_restarts = 1000;
  static double now = 0.0;
  ws.deadline.clock_us = [] { return now += 1.0; };
  int budget_ended = 0;
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS, SolverKind::kCCD}) {
    for (double budget : {50.0, 200.0, 1000.0, 3000.0}) {
      o.time_budget_usec = budget;
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      ASSERT_TRUE(r.usable()) << r.message.c_str();
      EXPECT_NE(r.reason, TerminationReason::kConverged) << to_string(kind);
      if (r.budget_exhausted) {
        ++budget_ended;
        EXPECT_TRUE(r.reason == TerminationReason::kMaxIterations || r.reason == TerminationReason::kUnreachable)
            << to_string(kind) << " " << budget << ": " << to_string(r.reason);
      }
      // The budget stopped it (1000 restarts never finish in 3000 readings): it must say so.
      EXPECT_TRUE(r.budget_exhausted) << to_string(kind) << " " << budget << ": " << to_string(r.reason)
                                      << " restarts " << r.restarts;
    }
  }
  EXPECT_EQ(budget_ended, 16);
  ws.deadline.clock_us = nullptr;
}

// Item 5: "converged" and the reported error always agree with the error forward_kinematics() gives
// for the returned params. DLS's own single-goal measurement (a fused FK summing in another order,
// the distance recovered from a weighted cost) decided alone when within tolerance, so at a
// tolerance near rounding it could call a pose converged whose measured error was above it, and
// it reported its own number, not the measured one.
TEST(Issue16, ConvergedAgreesWithTheMeasuredError) {
  std::mt19937 rng(16);
  int converged = 0, checked = 0;
  for (int n : {3, 7, 12}) {
    const Chain c = test::make_hinge_chain(n, 0.37);
    Workspace ws(c, 1);
    for (int trial = 0; trial < 300; ++trial) {
      const glm::dvec3 target = test::tip_of(c, test::random_params(c, rng, 1.0));
      SolverOptions o = test::cold_start_options(c);
      o.max_iterations = 40;
      o.position_tolerance = std::uniform_real_distribution<double>(1e-15, 8e-15)(rng) * c.total_length();
      for (SolverKind kind : {SolverKind::kDLS, SolverKind::kJacobianPinv, SolverKind::kBFGS}) {
        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
        // Weighted, as a game's goals often are: the solver's own error is then a rescaled cost.
        const double weight = std::uniform_real_distribution<double>(0.1, 10.0)(rng);
        const SolveResult r = test::run(kind, c, {Goal::position(target, 0, weight)}, o, ws, p);
        ++checked;
        const double measured = glm::length(test::tip_of(c, p) - target);
        EXPECT_EQ(r.final_position_error, measured) << to_string(kind) << " n " << n << " trial " << trial;
        if (r.reason == TerminationReason::kConverged) {
          ++converged;
          EXPECT_LE(measured, o.position_tolerance) << to_string(kind) << " n " << n << " trial " << trial;
        } else {
          EXPECT_GT(measured, o.position_tolerance) << to_string(kind) << " n " << n << " trial " << trial;
        }
      }
    }
  }
  EXPECT_GT(converged, 0) << checked;  // the tolerance is met, so the claim is tested
}

// ------------------------------------------------------------------------------------ item 7
// The Jacobian of the multi-goal case the issue measured: the 7-joint benchmark chain with a
// position goal on each of effectors 2..7, at a near-straight pose (rank-deficient).
Eigen::MatrixXd multi_goal_jacobian(const Chain& c, const Eigen::VectorXd& q) {
  std::vector<Goal> goals;
  Workspace ws(c, 6);
  forward_kinematics(c, q.data(), ws);
  for (int k = 2; k <= 7; ++k) goals.push_back(Goal::position(glm::dvec3(0.0), k));
  compute_dof_axes(c, q.data(), ws);
  Eigen::MatrixXd J(18, c.dof_count());
  compute_jacobian(c, Span<const Goal>(goals), ws, J);
  return J;
}

// Item 7: the Jacobi eigen-decomposition stops once the off-diagonal part is below rounding
// relative to the matrix, rank-deficient or not (the old test, below rounding, ran all 60 sweeps
// on every rank-deficient matrix), and decomposes as accurately as before.
TEST(Issue16, JacobiStopsEarlyOnRankDeficientMatrices) {
  const Chain c = test::make_hinge_chain(7);
  std::mt19937 rng(7);
  int worst = 0;
  for (int trial = 0; trial < 50; ++trial) {
    // Near-straight poses (angles within 1e-3 rad): J nearly loses rank; straight: it does.
    const Eigen::VectorXd q = trial == 0 ? Eigen::VectorXd::Zero(7) : test::random_params(c, rng, trial < 25 ? 1e-3 : 3.0);
    const Eigen::MatrixXd J = multi_goal_jacobian(c, q);
    for (bool row_form : {false, true}) {  // J^T J (7 x 7) and J J^T (18 x 18, rank <= 7)
      const Eigen::MatrixXd A = row_form ? Eigen::MatrixXd(J * J.transpose()) : Eigen::MatrixXd(J.transpose() * J);
      const int k = static_cast<int>(A.rows());
      Eigen::MatrixXd D = A, V(k, k);
      const int sweeps = linalg::jacobi_eigen(D, V, k);
      worst = std::max(worst, sweeps);
      EXPECT_LE(sweeps, 12) << "trial " << trial << " k " << k;
      EXPECT_LE((V * D.diagonal().asDiagonal() * V.transpose() - A).norm(), 1e-13 * A.norm()) << trial;
      EXPECT_LE((V.transpose() * V - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-13) << trial;
      EXPECT_LE((D - Eigen::MatrixXd(D.diagonal().asDiagonal())).norm(), 8 * 2.3e-16 * A.norm()) << trial;
    }
  }
  EXPECT_LT(worst, linalg::kMaxJacobiSweeps);
  // The Cholesky of the same header solves an SPD system of that size exactly (to rounding).
  const Eigen::MatrixXd J = multi_goal_jacobian(c, test::random_params(c, rng, 2.0));
  Eigen::MatrixXd A = J * J.transpose() + 1e-3 * Eigen::MatrixXd::Identity(18, 18);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(18, -1.0, 2.0);
  Eigen::VectorXd b = A * x;
  Eigen::MatrixXd L = A;
  linalg::cholesky_factor(L, 18, 1e-300);
  linalg::cholesky_solve(L, b, 18);
  EXPECT_LE((b - x).norm(), 1e-8 * x.norm());
}

// ------------------------------------------------------------------------------------ item 6
// A fake clock advancing 1 us per reading, and the readings made after the deadline was found spent.
double g_fake_now = 0.0;
double fake_clock() { return g_fake_now += 1.0; }

const SolverKind kIterative[] = {SolverKind::kCCD, SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS,
                                 SolverKind::kFABRIK};

// Item 6: the budget is checked before every iteration, the first included: a budget found spent at
// the first check stops every solver before any iteration (the start pose comes back), and no solver
// reads the clock again once it found the budget spent (the exit work reads none).
TEST(Issue16, TimeBudgetCheckedBeforeTheFirstIteration) {
  const Chain c = test::make_hinge_chain(30, 0.1);
  std::mt19937 rng(61);
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng, 1.0)))};
  Workspace ws(c, 1);
  ws.deadline.clock_us = &fake_clock;
  SolverOptions o = test::cold_start_options(c);
  o.position_tolerance = 1e-14 * c.total_length();
  o.stall_tolerance = 0.0;
  o.max_iterations = 1000;
  for (SolverKind kind : kIterative) {
    for (double budget : {0.5, 1.0, 4.0}) {
      o.time_budget_usec = budget;
      g_fake_now = 0.0;
      Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = test::run(kind, c, goals, o, ws, p);
      EXPECT_TRUE(r.budget_exhausted) << to_string(kind) << " " << budget;
      EXPECT_EQ(r.reason, TerminationReason::kMaxIterations) << to_string(kind) << " " << budget;
      // Armed at 1: the deadline is 1 + budget, and the reading that found it spent is the last.
      EXPECT_EQ(g_fake_now, std::ceil(1.0 + budget)) << to_string(kind) << " " << budget;
      if (budget <= 1.0) {
        EXPECT_EQ(r.iterations, 0) << to_string(kind);
        EXPECT_EQ(p, Eigen::VectorXd::Zero(c.dof_count())) << to_string(kind);
        EXPECT_NEAR(r.final_error, r.initial_error, 1e-12 * r.initial_error) << to_string(kind);
      }
    }
  }
}

// Item 6: the work after the reading that finds the budget spent is bounded, also inside one long
// iteration. A sweep of CCD or FABRIK over 200 joints costs 40-300 us (a joint's fit 0.2-1.5 us),
// far past the bound's 20 us of slack, so both read the clock every Deadline::kJointsPerCheck
// joints. On a fake clock (1 us a reading) a budget of 2.5 us passes the dispatcher's reading after
// its set-up (Deadline::spent_before_solver) and the check before the first sweep, and is found
// spent at the next reading: the sweep stops there, and at most
// kJointsPerCheck joints have moved (CCD: the last ones, tip first; FABRIK: the first ones, root
// first). A solver that finishes its sweep before looking at the clock moves 100-199 of them (as
// b0e1161 and main at 253026a did).
TEST(Issue16, TimeBudgetStopsALongSweepWithinKJointsPerCheck) {
  const int n = 200;
  const Chain c = test::make_hinge_chain(n, 0.01);
  std::mt19937 rng(6);
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng, 1.0)))};
  Workspace ws(c, 1);
  ws.deadline.clock_us = &fake_clock;
  SolverOptions o = test::sweep_options(c, 100);
  o.time_budget_usec = 2.5;
  for (SolverKind kind : {SolverKind::kCCD, SolverKind::kFABRIK}) {
    // The same solve without a budget moves most joints in its first sweep (CCD 199, FABRIK 100:
    // it leaves the twist hinges of this z/y chain alone).
    SolverOptions one = o;
    one.time_budget_usec = 0.0;
    one.max_iterations = 1;
    Eigen::VectorXd full = Eigen::VectorXd::Zero(n);
    test::run(kind, c, goals, one, ws, full);
    EXPECT_GE((full.array() != 0.0).count(), n / 2) << to_string(kind);

    g_fake_now = 0.0;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(n);
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_TRUE(r.budget_exhausted) << to_string(kind);
    EXPECT_EQ(r.iterations, 1) << to_string(kind);
    EXPECT_EQ(g_fake_now, 4.0) << to_string(kind);  // armed, after the set-up, before the sweep, spent within it
    const int moved = static_cast<int>((p.array() != 0.0).count());
    EXPECT_LE(moved, Deadline::kJointsPerCheck) << to_string(kind);
    EXPECT_LE(r.final_error, r.initial_error) << to_string(kind);
  }
}

// Item 6, work per clock reading: the bound holds in CPU time only if no stretch of work between
// two clock readings (nor the exit work after the last) is long. The kernels charge their work to
// the deadline (Deadline::charge, approximate flops; deterministic), and on long chains with
// several goals - where one Gram product J J^T, an active-set pass that repeats it, the damping
// retries of one DLS step, or an escape's several linearisations outgrew the slack - no stretch
// may exceed Deadline::stretch_bound of the problem's size, wherever the budget runs out (a fake
// clock: the budget is spent after 1, 2, 3, 5, ... readings).
struct StretchCase {
  const char* name;
  Chain chain;
  std::vector<Goal> goals;
};
std::vector<StretchCase> long_chain_cases() {
  std::mt19937 rng(616);
  const test::LimitRanges ranges{0.3, 1.2, 0.4, 1.0, 0.3, 1.0};
  std::vector<StretchCase> cases;
  for (int variant = 0; variant < 3; ++variant) {
    StretchCase k;
    k.name = variant == 0 ? "200 hinges" : variant == 1 ? "200 balls (600 DOF)" : "150 limited, every third a ball";
    k.chain = variant == 0   ? test::make_hinge_chain(200, 0.01)
              : variant == 1 ? test::make_ball_chain(200, 0.01)
                             : test::limited_chain(150, test::LimitedJoints::kEveryThirdBall, ranges,
                                                   test::LimitDraws::kOwnFieldsOnly, rng);
    const Chain& c = k.chain;
    // Five goals (15 residual rows): positions on inner effectors, the tip's pose; unreachable together.
    Workspace ws(c, 1);
    for (int g = 0; g < 4; ++g) {
      const int e = (g + 1) * c.joint_count() / 5;
      forward_kinematics(c, test::random_params(c, rng, 1.0).data(), ws);
      k.goals.push_back(Goal::position(effector_position(c, ws, e), e));
    }
    k.goals.push_back(Goal::orientation(glm::angleAxis(1.0, glm::dvec3(0, 0, 1))));
    cases.push_back(k);
  }
  return cases;
}

TEST(Issue16, TimeBudgetWorkPerClockReadingIsBoundedOnLongChains) {
  double worst_ratio = 0.0;
  std::string worst;
  for (const StretchCase& k : long_chain_cases()) {
    const Chain& c = k.chain;
    const int rows = 3 * static_cast<int>(k.goals.size());
    const double bound = Deadline::stretch_bound(c.joint_count(), c.dof_count(), rows);
    Workspace ws(c, static_cast<int>(k.goals.size()));
    ws.deadline.clock_us = &fake_clock;
    SolverOptions o = test::cold_start_options(c);
    o.position_tolerance = 1e-300;  // never met: the budget stops every solve
    o.orientation_tolerance = 1e-300;
    o.stall_tolerance = 0.0;
    o.max_iterations = 100000;
    for (SolverKind kind : kIterative) {
      for (double budget : {1.0, 2.0, 3.0, 5.0, 8.0, 13.0, 21.0, 34.0, 55.0}) {
        o.time_budget_usec = budget;
        g_fake_now = 0.0;
        std::mt19937 start_rng(7);
        Eigen::VectorXd p = test::random_params(c, start_rng, 0.3);
        if (!validate_inputs(kind, c, Span<const Goal>(k.goals), o, ws, p).empty()) continue;  // CCD: 5 goals max
        test::run(kind, c, k.goals, o, ws, p);
        const double ratio = ws.deadline.longest_stretch / bound;
        EXPECT_LE(ratio, 1.0) << k.name << ", " << to_string(kind) << ", budget after " << budget << " readings: "
                              << ws.deadline.longest_stretch << " flops, bound " << bound;
        if (ratio > worst_ratio) {
          worst_ratio = ratio;
          worst = std::string(k.name) + ", " + to_string(kind) + ", budget " + std::to_string(budget);
        }
      }
    }
  }
  std::printf("longest stretch / bound: %.3f (%s)\n", worst_ratio, worst.c_str());
}

// Item 6, an escape on a short chain with several goals: 12 balls (36 DOF) with four position goals
// (12 rows). The escape's null-space projection diagonalises J J^T, 12 x 12: ~10k flops a sweep,
// eight sweeps, more than the stretch bound of the whole problem (65k flops). Its sweeps read the
// clock now, as the Jacobian solvers' own do; before, the whole decomposition was one stretch
// (budget_bench --seed 1 --case 195597: FABRIK 88 us CPU on a 39.8 us budget, a 55 us gap; now 45 us).
TEST(Issue16, TimeBudgetReadsTheClockInAnEscapesEigenDecomposition) {
  const Chain c = test::make_ball_chain(12, 0.1);
  std::mt19937 rng(195597);
  std::vector<Goal> goals;
  Workspace ws(c, 4);
  forward_kinematics(c, test::random_params(c, rng, 1.0).data(), ws);
  for (int g = 0; g < 4; ++g) {
    const int e = (g + 1) * c.joint_count() / 4;
    goals.push_back(Goal::position(effector_position(c, ws, e), e));  // of one pose: reachable
  }
  const double bound = Deadline::stretch_bound(c.joint_count(), c.dof_count(), 12);
  ws.deadline.clock_us = &fake_clock;
  SolverOptions o = test::cold_start_options(c);
  o.position_tolerance = 1e-300;  // never met: the solve stalls at rounding and escapes
  o.stall_tolerance = 0.5;  // CCD and FABRIK creep: an iteration gaining less than half is stuck
  o.max_iterations = 200;
  o.time_budget_usec = 1e9;  // read at every check, never spent
  for (SolverKind kind : kIterative) {
    g_fake_now = 0.0;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(kind, c, goals, o, ws, p);
    EXPECT_GT(r.escapes, 0) << to_string(kind) << " " << to_string(r.reason) << " it " << r.iterations << " err " << r.final_error;
    EXPECT_LE(ws.deadline.longest_stretch, bound) << to_string(kind) << ": " << ws.deadline.longest_stretch
                                                  << " flops between two clock readings";
  }
}

// Item 6, within one Jacobi sweep: seven goals make J J^T 21 x 21, a sweep ~55k flops (15-25 us),
// more than the budget's slack. The sweep reads the clock every 10000.0 flops
// (before: once per sweep; budget_bench --seed 1 --case 16222, the pseudo-inverse on 15 balls with
// seven goals and a 22.4 us budget, 48 us CPU; now 27 us): no stretch is longer than that plus one
// row's rotations, and a budget spent mid-sweep stops it there.
TEST(Issue16, TimeBudgetReadsTheClockWithinAJacobiSweep) {
  const int k = 21;
  std::mt19937 rng(16222);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd B(k, k);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) B(i, j) = u(rng);
  const Eigen::MatrixXd A = B * B.transpose();
  Deadline d;
  d.clock_us = &fake_clock;
  for (double budget : {1e9, 4.5}) {
    g_fake_now = 0.0;
    d.start(budget, d.now_us());  // armed at 1
    Eigen::MatrixXd D = A, V(k, k);
    const int sweeps = linalg::jacobi_eigen(D, V, k, &d);
    d.finish();
    EXPECT_LE(d.longest_stretch, linalg::kJacobiFlopsPerCheck + 12.0 * k * k) << budget;
    if (budget > 1e6) {
      EXPECT_GT(sweeps, 3);  // it ran to the end, reading the clock as it went
      EXPECT_GT(g_fake_now, 1.0 + 4 * sweeps);
      EXPECT_LE((V * D.diagonal().asDiagonal() * V.transpose() - A).norm(), 1e-12 * A.norm());
    } else {
      EXPECT_EQ(sweeps, -1);
      EXPECT_TRUE(d.hit);
      EXPECT_LE(g_fake_now, 6.0);  // within the first sweep: its start and a few readings after it
    }
  }
}

// Item 6, the Gram product of a long chain: on 200 ball joints (600 DOF) with five goals, J J^T
// alone is 135k flops (~50 us), and the active set forms it again per freeze pass. GoalModel forms
// it one goal's three rows at a time with a clock reading between; a budget found spent there (or
// in the eigen-decomposition) leaves no step, not one from a half-built or half-diagonalised matrix
// (before: the product was whole, and a step was taken on the matrix the eigen-solver left).
TEST(Issue16, TimeBudgetSplitsTheGramProductOfALongChain) {
  const StretchCase k = long_chain_cases()[1];
  const Chain& c = k.chain;
  ASSERT_EQ(c.dof_count(), 600);
  Workspace ws(c, static_cast<int>(k.goals.size()));
  ws.deadline.clock_us = &fake_clock;
  std::mt19937 rng(3);
  const Eigen::VectorXd p = test::random_params(c, rng, 0.5);
  jacobian::GoalModel model(c, Span<const Goal>(k.goals), ws);
  for (double budget : {1.5, 1000.0}) {
    g_fake_now = 0.0;
    ws.deadline.start(budget, ws.deadline.now_us());  // armed at 1: spent from 1 + budget on
    model.evaluate(p.data());
    model.accept();
    model.linearize(p.data());
    Eigen::VectorXd step = Eigen::VectorXd::Constant(c.dof_count(), 7.0);
    const double decrease = model.damped_step(1e-3, step.data());
    if (budget < 2.0) {
      EXPECT_TRUE(ws.deadline.hit);
      EXPECT_EQ(g_fake_now, 3.0);  // armed, the reading after the first goal's rows, the one after the second
      EXPECT_EQ(decrease, 0.0);
      EXPECT_EQ(step, Eigen::VectorXd::Zero(c.dof_count()));
    } else {  // the same product, split, gives the step: a reading per goal after the first, then the sweeps'
      EXPECT_FALSE(ws.deadline.hit);
      EXPECT_GE(g_fake_now, 1.0 + 4.0);
      EXPECT_GT(decrease, 0.0);
      EXPECT_GT(step.norm(), 0.0);
    }
  }
}

// Item 6, stretches that cannot be split finely (a tree DLS step on 200+ DOF, ~70 us; a BFGS
// line-search trial on 600 DOF, ~95 us) and the exit work after the last reading: a clock reading
// that finds the budget not yet spent must still stop the solve when the next stretch and the exit
// work, each as long as the longest gap between readings so far, would end past 1.1 x budget +
// 20 us. A fake clock that advances `tick` per reading makes every stretch `tick` long: the solve
// ends one tick (its exit work) after its last reading, and that must be within the bound, with
// budget_exhausted set. Before (main at bffd21a), the budget stopped a solve only at the first
// reading past it: 40 us stretches on a 100 us budget ended at 160 us, past the 130 us bound.
double g_long_tick = 0.0;
double long_stretch_clock() { return g_fake_now += g_long_tick; }

TEST(Issue16, TimeBudgetStopsBeforeAStretchThatWouldOverrun) {
  const Chain c = test::make_hinge_chain(40, 0.05);
  std::mt19937 rng(18);
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng, 1.0)))};
  Workspace ws(c, 1);
  ws.deadline.clock_us = &long_stretch_clock;
  SolverOptions o = test::cold_start_options(c);
  o.position_tolerance = 1e-300;  // never met: the budget stops every solve
  o.stall_tolerance = 0.0;
  o.max_iterations = 100000;
  const Tree tree = test::make_humanoid(true);
  TreeWorkspace tws(tree, 12);
  tws.deadline.clock_us = &long_stretch_clock;
  std::mt19937 tree_rng(5);
  const std::vector<TreeGoal> tree_goals = test::pose_goals_at(
      tree, test::random_tree_params(tree, tree_rng, 1.0, 0.2),
      {test::Humanoid::kLHand, test::Humanoid::kRHand, test::Humanoid::kLFoot, test::Humanoid::kRFoot}, 1);
  TreeProblem problem;
  problem.goals = Span<const TreeGoal>(tree_goals);
  int foreseen = 0, solves = 0;
  for (double tick : {25.0, 40.0}) {
    for (double budget : {60.0, 100.0, 170.0, 400.0}) {
      const double bound = Deadline::kBoundRatio * budget + Deadline::kBoundSlackUs;
      g_long_tick = tick;
      o.time_budget_usec = budget;
      for (SolverKind kind : kIterative) {
        g_fake_now = 0.0;
        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
        const SolveResult r = test::run(kind, c, goals, o, ws, p);
        // The last reading + one tick of exit work - the arming reading (at tick).
        const double ended = g_fake_now;
        EXPECT_TRUE(r.budget_exhausted) << to_string(kind) << " tick " << tick << " budget " << budget;
        EXPECT_EQ(r.reason, TerminationReason::kMaxIterations) << to_string(kind);
        EXPECT_LE(ended, bound) << to_string(kind) << " tick " << tick << " budget " << budget;
        EXPECT_LE(r.final_error, r.initial_error) << to_string(kind);
        foreseen += ws.deadline.foreseen;
        ++solves;
      }
      for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kCCD, SolverKind::kFABRIK}) {
        g_fake_now = 0.0;
        Eigen::VectorXd q = Eigen::VectorXd::Zero(tree.dof_count());
        SolverOptions to = o;
        to.orientation_tolerance = 1e-300;
        to.max_restarts = 0;
        const TreeSolveResult r = solve_tree(kind, tree, problem, to, tws, q);
        const double ended = g_fake_now;  // as above
        EXPECT_TRUE(r.summary.budget_exhausted) << "tree " << to_string(kind) << " tick " << tick << " budget " << budget;
        EXPECT_LE(ended, bound) << "tree " << to_string(kind) << " tick " << tick << " budget " << budget;
        foreseen += tws.deadline.foreseen;
        ++solves;
      }
    }
  }
  // Most stop before the budget's end (those whose last reading before it is far enough from the bound
  // stop there as before).
  EXPECT_GE(foreseen, solves / 2);
}

// Item 6, the fuzzer's invariant (tests/fuzz/solve_fuzz.cpp): a budget found spent before its end
// (Deadline::foreseen) was found so at the solve's last clock reading, last_reading_us. The
// dispatcher's look after its set-up (Deadline::spent_before_solver) keeps last_reading_us at
// start() when it passes, so the solver's first gap spans the whole set-up; when it finds the
// budget spent it is the last reading, and says so (before: it stayed at start(), the fuzzer's
// finding in CI at 36919f5: "the clock was read again after the budget was found spent").
double g_set_now = 0.0;
double set_clock() { return g_set_now; }
TEST(Issue16, DeadlineFoundSpentBeforeTheSolverRecordsThatReading) {
  Deadline d;
  d.clock_us = &set_clock;
  // Budget 30 us: the bound is 1.1 x 30 + 20 = 53 us. A 5 us set-up passes (5 + 4 x 5 + 1 <= 53) and
  // leaves the last reading at the start; the solver's first reading at 10 measures 10 from there.
  d.start(30.0, 0.0);
  g_set_now = 5.0;
  EXPECT_FALSE(d.spent_before_solver());
  EXPECT_EQ(d.last_reading_us, 0.0);
  g_set_now = 10.0;
  EXPECT_FALSE(d.spent());  // 10 + 4 x 10 + 1 <= 53
  EXPECT_EQ(d.setup_gap_us, 10.0);
  EXPECT_EQ(d.last_reading_us, 10.0);
  // A 12 us set-up does not (12 + 4 x 12 + 1 > 53): spent there, foreseen, and that is the last reading.
  d.start(30.0, 0.0);
  g_set_now = 12.0;
  EXPECT_TRUE(d.spent_before_solver());
  EXPECT_TRUE(d.hit);
  EXPECT_TRUE(d.foreseen);
  EXPECT_EQ(d.last_reading_us, 12.0);
  g_set_now = 20.0;
  EXPECT_TRUE(d.spent());  // spent stays spent, without reading the clock again
  EXPECT_EQ(d.last_reading_us, 12.0);
}

// Item 6, the first iteration's stretches (h21budget): the set-up gap predicts the solve's longest
// stretch as Deadline::stretch_ratio set-up gaps, the solver's own ratio (a DLS step is ~5.5 set-ups
// on 100-600 DOF, a FABRIK sweep's stretch ~2.5), and that floor holds at every reading until a
// longer gap is seen. Before, the second reading predicted two gaps of the linearisation only, and
// DLS's step after it ran past the bound on 20-30 us budgets on long chains (budget_bench).
TEST(Issue16, DeadlineSetUpPredictsTheLongestStretchUntilOneIsSeen) {
  Deadline d;
  d.clock_us = &set_clock;
  // Budget 100 us: spent at 100, the bound at 130. A 10 us set-up predicts 55 us stretches.
  d.start(100.0, 0.0, 0.0, 5.5);
  g_set_now = 10.0;
  EXPECT_FALSE(d.spent());  // 10 + 55 + 10 + 1 <= 130
  for (double t = 22.0; t <= 58.0; t += 12.0) {
    g_set_now = t;
    EXPECT_FALSE(d.spent()) << t;  // t + 55 + 12 + 1 <= 130
  }
  g_set_now = 70.0;
  EXPECT_TRUE(d.spent());  // 70 + 55 + 12 + 1 > 130, though 70 + 2 x 12 + 1 is not
  EXPECT_TRUE(d.foreseen);
  // Without a ratio (the trees) the first reading predicts kFirstStretchRatio set-ups, the later ones
  // two longest gaps: the same readings go on to the budget's end.
  d.start(100.0, 0.0);
  for (double t = 10.0; t <= 94.0; t += 12.0) {
    g_set_now = t;
    EXPECT_FALSE(d.spent()) << t;  // 94 + 2 x 12 + 1 <= 130
  }
  g_set_now = 106.0;
  EXPECT_TRUE(d.spent());
  EXPECT_FALSE(d.foreseen);  // the budget's own end
  // A gap longer than the prediction takes over: 40 us after a 10 us set-up at 5.5 x.
  d.start(1000.0, 0.0, 0.0, 5.5);
  g_set_now = 10.0;
  EXPECT_FALSE(d.spent());
  g_set_now = 80.0;
  EXPECT_FALSE(d.spent());
  EXPECT_EQ(d.longest_gap_us, 70.0);
}

// The same through solve(), on a 200-joint chain with a clock of 10 us per reading. DLS measures its
// start itself: its first reading is one tick after the start, a 10 us set-up, and its step is
// predicted at 55 us: on a 40 us budget (bound 64 us) 10 + 55 + 10 + 1 ends past it, so DLS stops
// at its first reading, before it moves (at the old 3 set-ups it went on); on 60 us (bound 86 us) it
// goes on. FABRIK's set-up spans the dispatcher's look, 20 us, and its stretch is predicted at
// 2.5 set-ups: on 70 us (bound 97 us) 20 + 50 + 20 + 1 fits, and it sweeps (at 3 it stopped there).
double g_tick_now = 0.0;
double tick_clock() { return g_tick_now += 10.0; }
TEST(Issue16, TimeBudgetFirstReadingStopsWhenTheSolversFirstStretchEndsPastTheBound) {
  std::mt19937 rng(21);
  const Chain c = test::make_ball_chain(200, 0.01);
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng, 1.0)))};
  Workspace ws(c, 1);
  ws.deadline.clock_us = &tick_clock;
  SolverOptions o = test::cold_start_options(c);
  o.position_tolerance = 1e-300;
  o.stall_tolerance = 0.0;
  o.max_iterations = 1000;
  struct Case {
    SolverKind kind;
    double budget;
    bool stops_first;
  };
  for (const Case& k : {Case{SolverKind::kDLS, 40.0, true}, Case{SolverKind::kFABRIK, 70.0, false},
                        Case{SolverKind::kDLS, 60.0, false}}) {
    o.time_budget_usec = k.budget;
    g_tick_now = 0.0;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    const SolveResult r = test::run(k.kind, c, goals, o, ws, p);
    const std::string what = std::string(to_string(k.kind)) + ", budget " + std::to_string(k.budget);
    EXPECT_TRUE(r.budget_exhausted) << what;
    EXPECT_EQ(ws.deadline.setup_gap_us, k.kind == SolverKind::kDLS ? 10.0 : 20.0) << what;
    if (k.stops_first) {
      EXPECT_EQ(ws.deadline.budget_readings, 1u) << what;
      EXPECT_TRUE(ws.deadline.foreseen) << what;
      EXPECT_EQ(r.iterations, 0) << what;
      EXPECT_EQ(r.final_error, r.initial_error) << what;
    } else {
      EXPECT_GT(ws.deadline.budget_readings, 1u) << what;
      EXPECT_GT(r.iterations, 0) << what;
    }
    EXPECT_LE(ws.deadline.last_reading_us, ws.deadline.bound_end_us) << what;
  }
}

// Item 6, the exit work of a solve the budget stops before it moves: on long chains with a small
// budget the set-up alone (the start pose's FK and measure, a solver's first evaluation) can use the
// budget, and the exit work then decides whether the solve ends within 1.1 x budget + 20 us
// (budget_bench: 20-30 us budgets on 150-600 DOF were over it). The start pose comes back, and it
// was measured at the start: no FK pass may follow the reading that found the budget spent (the
// exit stretch, Deadline::exit_stretch, stays below one FK pass's charge), and the errors reported
// are the start's, on a warm start projected onto the limits too. Before (main at ca9203f): the
// restarts' FK pass and the final one, two passes of 200 ball joints (24k flops, 10-16 us there).
TEST(Issue16, TimeBudgetSpentInTheSetUpLeavesNoFkPassToTheExit) {
  std::mt19937 rng(19);
  const test::LimitRanges ranges{0.3, 1.2, 0.4, 1.0, 0.3, 1.0};
  const Chain balls = test::make_ball_chain(200, 0.01);
  const Chain limited = test::limited_chain(150, test::LimitedJoints::kEveryThirdBall, ranges,
                                            test::LimitDraws::kOwnFieldsOnly, rng);
  for (const Chain* c : {&balls, &limited}) {
    const double one_pass = Deadline::kFlopsPerJoint * c->joint_count();
    const std::vector<Goal> goals = {Goal::position(test::tip_of(*c, test::random_params(*c, rng, 1.0)))};
    Workspace ws(*c, 1);
    ws.deadline.clock_us = &fake_clock;
    SolverOptions o = test::cold_start_options(*c);
    o.position_tolerance = 1e-300;
    o.stall_tolerance = 0.0;
    o.max_iterations = 1000;
    o.max_restarts = 100;
    o.time_budget_usec = 0.5;  // armed at 1, spent at the first reading (2)
    for (bool warm : {false, true}) {
      o.warm_start = warm;
      const Eigen::VectorXd caller = test::random_params(*c, rng, 2.0);  // outside some limits
      Eigen::VectorXd start = warm ? caller : Eigen::VectorXd::Zero(c->dof_count());
      project_to_limits(*c, start.data());
      for (SolverKind kind : kIterative) {
        g_fake_now = 0.0;
        Eigen::VectorXd p = caller;
        const SolveResult r = test::run(kind, *c, goals, o, ws, p);
        const std::string what = std::string(to_string(kind)) + (warm ? " warm, " : " cold, ") +
                                 std::to_string(c->joint_count()) + " joints";
        EXPECT_TRUE(r.budget_exhausted) << what;
        EXPECT_EQ(r.reason, TerminationReason::kMaxIterations) << what;
        EXPECT_EQ(r.iterations, 0) << what;
        EXPECT_EQ(r.restarts, 0) << what;
        EXPECT_EQ(p, start) << what;
        EXPECT_EQ(r.final_error, r.initial_error) << what;
        EXPECT_EQ(g_fake_now, 2.0) << what;  // armed, then the reading that found it spent
        EXPECT_LT(ws.deadline.exit_stretch, one_pass) << what << ": " << ws.deadline.exit_stretch << " flops";
        // Honest: the errors reported are those of the pose returned.
        forward_kinematics(*c, p.data(), ws);
        EXPECT_NEAR(r.final_position_error, measure_goals(*c, Span<const Goal>(goals), ws).max_position,
                    1e-12 * c->total_length()) << what;
      }
    }
  }
  // Trees: the humanoid, every tree solver.
  const Tree humanoid = test::make_humanoid(true);
  for (const Tree* tree : {&humanoid}) {
    TreeWorkspace tws(*tree, 12);
    tws.deadline.clock_us = &fake_clock;
    std::mt19937 tree_rng(5);
    const std::vector<TreeGoal> tree_goals = test::pose_goals_at(
        *tree, test::random_tree_params(*tree, tree_rng, 1.0, 0.2),
        {test::Humanoid::kLHand, test::Humanoid::kRHand, test::Humanoid::kLFoot, test::Humanoid::kRFoot}, 1);
    TreeProblem problem;
    problem.goals = Span<const TreeGoal>(tree_goals);
    SolverOptions o;
    o.position_tolerance = o.orientation_tolerance = 1e-300;
    o.time_budget_usec = 0.5;
    for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kCCD, SolverKind::kFABRIK}) {
      g_fake_now = 0.0;
      Eigen::VectorXd q = test::random_tree_params(*tree, tree_rng, 0.3, 0.1);
      const Eigen::VectorXd start = q;
      const TreeSolveResult r = solve_tree(kind, *tree, problem, o, tws, q);
      EXPECT_TRUE(r.summary.budget_exhausted) << "tree " << to_string(kind);
      EXPECT_EQ(r.summary.iterations, 0) << "tree " << to_string(kind);
      EXPECT_EQ(q, start) << "tree " << to_string(kind);
      EXPECT_EQ(r.summary.final_error, r.summary.initial_error) << "tree " << to_string(kind);
      EXPECT_LT(tws.deadline.exit_stretch, Deadline::kFlopsPerJoint * tree->joint_count()) << "tree " << to_string(kind);
      tree_forward_kinematics(*tree, q.data(), tws);
      double worst_position = 0.0;
      for (const TreeGoal& g : tree_goals)
        if (g.goal.kind == GoalKind::kPosition)
          worst_position = std::max(worst_position, glm::length(tree_goal_error(*tree, tws, g.goal)));
      EXPECT_EQ(r.summary.final_position_error, worst_position) << "tree " << to_string(kind);
      for (int g = 0; g < problem.goals.size; ++g)
        EXPECT_EQ(r.goal_error[g], glm::length(tree_goal_error(*tree, tws, tree_goals[g].goal))) << "tree " << to_string(kind);
    }
  }
}

// Item 6's CPU-time bound (1.1 x budget + 20 us) is a measured number, so it lives in a benchmark,
// not a timed test (one here failed under CI's load at 1.25 x): scripts/bench --robots-only prints
// the worst ratio of CPU time to budget over every budget-bound solve. What a test can assert
// exactly - no iteration starts after the clock says the budget is spent, and budget_exhausted
// only with max_iterations or unreachable - is checked on a fake clock above and by the fuzzer.

// ------------------------------------------------------------------------------------ item 8
// Item 8: a misconfigured solve (the pseudo-inverse on 200 bones, 1,000 iterations and 1,000
// restarts toward a tolerance it cannot meet: seconds on b0e1161) is stopped by the default safety
// cap, documented in options.hpp and docs/solvers.md.
TEST(Issue16, DefaultTimeCapStopsAMisconfiguredSolve) {
  EXPECT_EQ(SolverOptions().time_cap_usec, kDefaultTimeCapUsec);
  EXPECT_EQ(SolverOptions().time_budget_usec, 0.0);  // the budget itself stays the caller's choice
  const Chain c = test::make_ball_chain(200, 0.01);
  std::mt19937 rng(8);
  const std::vector<Goal> goals = {Goal::position(test::tip_of(c, test::random_params(c, rng, 0.5)))};
  Workspace ws(c, 1);
  SolverOptions o;
  o.max_iterations = 1000;
  o.max_restarts = 1000;
  o.position_tolerance = 1e-300;  // never met: every run goes on until it stalls, then restarts
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const double t0 = Deadline::thread_cpu_now_us();
  const SolveResult r = test::run(SolverKind::kJacobianPinv, c, goals, o, ws, p);
  const double cpu = Deadline::thread_cpu_now_us() - t0;
  EXPECT_TRUE(r.budget_exhausted);
  EXPECT_EQ(r.reason, TerminationReason::kMaxIterations);
  EXPECT_LT(r.restarts, 1000);
  // Stopped by the cap, not after its seconds: 10x the cap tells the two apart. The tight bound
  // (1.1 x + 20 us) is a measured number, printed by scripts/bench --budget; asserted here it failed
  // under wine, whose thread CPU clock ticks in 10-16 ms (60,000 us read for a 50 ms cap).
  EXPECT_LE(cpu, 10.0 * kDefaultTimeCapUsec);
  EXPECT_LE(r.final_error, r.initial_error);
  // The cap is an option like the budget: 0 turns it off, and it is validated.
  o.time_cap_usec = -1.0;
  const SolveResult bad = test::run(SolverKind::kJacobianPinv, c, goals, o, ws, p);
  EXPECT_EQ(bad.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(bad.message.c_str()).find("time_cap_usec"), std::string::npos);
}


// ------------------------------------------------------------------------------------ item 13
// The angle of the rotation taking q onto r (rad).
double rotation_angle(const glm::dquat& q, const glm::dquat& r) {
  return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(q, r))));
}

// Frames per run of the straight-leg tracking runs (the first from the straight rest pose).
constexpr int kStraightLegFrames = 121;
struct StraightLegTracking {
  double worst_error = 0.0, worst_excess = -INFINITY;
  std::vector<int> iterations;  // of every frame of every run, run by run
};

// Item 13: FABRIK on a humanoid leg (SkeletonProfileHumanoid rests: a ball hip, a knee hinge about
// its own +X in [0, 150 deg], 0.375 m bones), straight at rest with the knee on its limit 0,
// tracking a foot target with the node's defaults (64 iterations, 1e-4 m, warm, no restarts). The
// target follows the foot of a smooth path between two random poses (hip turned up to 0.6 rad
// about each axis, knee bent 10-40 deg: a walking foot, near full reach, far to the side of the
// straight leg), 120 frames, the first solve from the straight rest pose. Every frame must end
// within 1 mm, and no frame may turn a joint by more than the target's own motion asks - its turn
// seen from the hip plus the knee bend its distance needs (law of cosines) - plus 6 deg (the ball
// hip's swivel about the hip-foot line is free; measured: worst 4.0 deg over the 100 runs).
// b0e1161: FABRIK swung the straight leg toward the target slower with every sweep, the knee
// clipped on its limit, and ended 0.18-0.21 m off in 18 of 100 runs, turning joints by up to
// 174 deg in one frame once it bent.
StraightLegTracking track_from_a_straight_leg(SolverKind kind) {
  namespace h = test::humanoid;
  StraightLegTracking out;
  const Chain leg = h::chain({"LeftUpperLeg", "LeftLowerLeg"}, "LeftFoot", true, 0.0, 150.0 * so3::kPi / 180.0);
  const double bone = 0.375, deg = so3::kPi / 180.0;
  SolverOptions o;  // the IKChain node's defaults
  o.max_iterations = 64;
  o.position_tolerance = 1e-4;
  Workspace ws(leg, 1), path_ws(leg, 1);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  double& worst_error = out.worst_error;
  double& worst_excess = out.worst_excess;
  for (int run = 0; run < 100; ++run) {
    Eigen::VectorXd a(4), b(4);
    a << 0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng), (10.0 + 30.0 * u01(rng)) * deg;
    b << 0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng), (10.0 + 30.0 * u01(rng)) * deg;
    Eigen::VectorXd p = Eigen::VectorXd::Zero(leg.dof_count());  // straight, the knee on its limit
    forward_kinematics(leg, p.data(), ws);
    EXPECT_TRUE(hinge_blocked(leg, 1, p.data(), -1.0));
    const glm::dvec3 hip = ws.joint_origins[0];
    glm::dquat last[2];
    glm::dvec3 last_target(0.0);
    double last_bend = 0.0;
    for (int f = 0; f < kStraightLegFrames; ++f) {
      const double s = 0.5 - 0.5 * std::cos(so3::kPi * f / (kStraightLegFrames - 1));
      const Eigen::VectorXd q = a + (b - a) * s;
      forward_kinematics(leg, q.data(), path_ws);
      const glm::dvec3 target = path_ws.tip;
      const Goal g = Goal::position(target);
      const SolveResult r = solve(kind, leg, Span<const Goal>(&g, 1), o, ws, p);
      out.iterations.push_back(r.iterations);
      EXPECT_TRUE(r.usable());
      EXPECT_EQ(r.restarts, 0);
      forward_kinematics(leg, p.data(), ws);
      const double error = glm::length(ws.tip - target);
      worst_error = std::max(worst_error, error);
      EXPECT_LE(error, 1e-3) << "run " << run << " frame " << f << ": " << to_string(r.reason);
      const double bend = 2.0 * std::acos(std::min(1.0, glm::length(target - hip) / (2.0 * bone)));
      if (f > 0) {
        const double turn = std::max(rotation_angle(last[0], ws.joint_orientations[0]),
                                     rotation_angle(last[1], ws.joint_orientations[1]));
        const double target_turn =
            std::acos(std::clamp(glm::dot(glm::normalize(target - hip), glm::normalize(last_target - hip)), -1.0, 1.0));
        const double excess = turn - (target_turn + std::abs(bend - last_bend));
        worst_excess = std::max(worst_excess, excess);
        EXPECT_LE(excess, 6.0 * deg) << "run " << run << " frame " << f << ": turn " << turn / deg << " deg";
      }
      last[0] = ws.joint_orientations[0];
      last[1] = ws.joint_orientations[1];
      last_target = target;
      last_bend = bend;
    }
  }
  return out;
}

// The mean iterations a frame, over every frame and over the runs' first frames (the straight rest).
struct StraightLegIterations {
  double mean = 0.0, first_frame_mean = 0.0;
};
StraightLegIterations straight_leg_iterations(const StraightLegTracking& t) {
  StraightLegIterations out;
  int first_frames = 0;
  for (size_t i = 0; i < t.iterations.size(); ++i) {
    out.mean += t.iterations[i];
    if (i % size_t(kStraightLegFrames) == 0) {
      out.first_frame_mean += t.iterations[i];
      ++first_frames;
    }
  }
  out.mean /= std::max<size_t>(t.iterations.size(), 1);
  out.first_frame_mean /= std::max(first_frames, 1);
  return out;
}

TEST(Issue16, FabrikBendsAStraightLegWhileTracking) {
  const StraightLegTracking t = track_from_a_straight_leg(SolverKind::kFABRIK);
  const StraightLegIterations it = straight_leg_iterations(t);
  std::printf("[ item 13 ] worst error %.3g m, worst joint turn beyond the target's motion %.2f deg, "
              "iterations a frame: mean %.1f, on first frames %.1f\n",
              t.worst_error, t.worst_excess / (so3::kPi / 180.0), it.mean, it.first_frame_mean);
  // Measured: 1.0 and 2.3 (the forward stage places the knee by the law of cosines in its
  // current plane: fabrik.cpp, keep_bend_plane); bffd21a: 9.9 and 32.0 (the runs' first frames
  // swung the straight leg far to the side).
  EXPECT_LE(it.mean, 12.0);
  EXPECT_LE(it.first_frame_mean, 40.0);
}

// Item 13's sibling: CCD on the same runs: every frame within 1 mm and no jump, as FABRIK, in few
// iterations - a mean of at most 8 a frame and at most 16 on a run's first frame (FABRIK: 9.9 and
// 32; DLS, the pseudo-inverse and BFGS: 1.0-1.1 and 5.6-11.7). Measured: 1.0 and 1.0, worst foot
// error 0.099 mm: the knee, a hinge right after the free ball hip, takes the angle that puts the
// foot at the target's distance from the hip (ccd.cpp, triangle_turn), and the hip then turns the
// foot onto the target. bffd21a: a mean of 31.0 iterations a frame (median 27), 62.5 on first
// frames (the cap is 64), frames ending up to 14 mm off: from a straight leg CCD needed the
// straight-knee escape, and near straight each sweep bent the knee by a small part of what the
// distance needed (linear convergence).
TEST(Issue16, CcdBendsAStraightLegInFewIterations) {
  const StraightLegTracking t = track_from_a_straight_leg(SolverKind::kCCD);
  const StraightLegIterations it = straight_leg_iterations(t);
  std::printf("[ item 13, CCD ] worst error %.3g m, iterations a frame: mean %.1f, on first frames %.1f\n",
              t.worst_error, it.mean, it.first_frame_mean);
  EXPECT_LE(it.mean, 8.0);
  EXPECT_LE(it.first_frame_mean, 16.0);
}

// ------------------------------------------------------------------------------------ item 14
// The humanoid's spine and left arm as one chain (Spine, Chest, UpperChest with 35 deg cones, the
// collarbone with a 20 deg cone, a free shoulder, an elbow hinge in [0, 2.6] rad), the hand as tip.
Chain spine_arm_with_cones() {
  namespace h = test::humanoid;
  const char* names[] = {"Spine", "Chest", "UpperChest", "LeftShoulder", "LeftUpperArm", "LeftLowerArm"};
  ChainBuilder b;
  for (int i = 0; i < 6; ++i) {
    const h::Bone& bone = h::bone(names[i]);
    JointDesc j;
    j.offset_translation = bone.position;
    j.rest_rotation = glm::normalize(bone.rotation);
    if (i < 4) {
      j.limits.has_cone_limit = true;
      j.limits.cone_angle = (i < 3 ? 35.0 : 20.0) * so3::kPi / 180.0;
    }
    if (i == 5) {
      j.type = JointType::kHinge;
      j.axis = glm::dvec3(1, 0, 0);
      j.limits.has_hinge_limit = true;
      j.limits.hinge_min = 0.0;
      j.limits.hinge_max = 2.6;
    }
    b.add_joint(j);
  }
  b.set_tip_offset(h::bone("LeftHand").position);
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

// Item 14: a hand target moving beyond what the spine's cones allow, though within the bones'
// reach, tracked as a game does (warm, no restarts, 64 iterations). Past the boundary the limits
// hold the pose. A creep along the limits with no escape left now stops (as stalled) instead of
// crawling on to max_iterations (before: max_iterations on most of those frames, where 500
// iterations gave the same pose), the result says the limits hold it (joints_at_limit), and the
// pose follows the target without a jump.
TEST(Issue16, OutOfReachBecauseOfTheLimitsStopsAsStalledAndMovesSmoothly) {
  const Chain chain = spine_arm_with_cones();
  Workspace ws(chain, 1);
  Eigen::VectorXd rest = Eigen::VectorXd::Zero(chain.dof_count());
  forward_kinematics(chain, rest.data(), ws);
  const glm::dvec3 start = ws.tip;                      // the hand at rest: reached
  const glm::dvec3 beyond(0.5883, -0.3672, -0.3304);   // down, left and behind (base space, m)
  ASSERT_LT(glm::length(beyond - chain.root_in_base()), stuck::reach_of(chain, chain.joint_count()));
  constexpr int kFrames = 100;
  const double target_step = glm::length(beyond - start) / kFrames;
  for (SolverKind kind : {SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kJacobianPinv}) {
    SCOPED_TRACE(to_string(kind));
    Eigen::VectorXd params = rest;
    SolverOptions o;
    o.max_iterations = 64;
    o.position_tolerance = 1e-4;
    std::vector<glm::dvec3> before(chain.joint_count() + 1);
    int frames_past = 0, stalled_past = 0;
    for (int f = 0; f <= kFrames; ++f) {
      const double s = static_cast<double>(f) / kFrames;
      const Goal g = Goal::position(start + (beyond - start) * s);
      const SolveResult r = solve(kind, chain, Span<const Goal>(&g, 1), o, ws, params);
      ASSERT_TRUE(r.usable());
      EXPECT_NE(r.reason, TerminationReason::kUnreachable) << "frame " << f;  // within the bones' reach
      forward_kinematics(chain, params.data(), ws);
      double moved = 0.0;  // the farthest any joint origin or the hand moved since the last frame
      for (int i = 1; i <= chain.joint_count(); ++i) {
        const glm::dvec3 now = i < chain.joint_count() ? ws.joint_origins[i] : ws.tip;
        if (f > 0) moved = std::max(moved, glm::length(now - before[i]));
        before[i] = now;
      }
      if (s < 0.85) continue;  // the last 15 frames lie 2 to 13 cm past the boundary
      ++frames_past;
      stalled_past += r.reason == TerminationReason::kStalled;
      EXPECT_GT(r.final_position_error, 0.02) << "frame " << f;  // really held short of the target
      EXPECT_GE(r.joints_at_limit, 1) << "frame " << f;
      EXPECT_LE(moved, 3.0 * target_step) << "frame " << f;
    }
    // Some frames still spend the budget on the escapes (5 of them, ~10 iterations each: each
    // finds nothing lower; the escapes cannot tell this minimum from the real arms' ones the third
    // escape leaves, Stuck.RealArmPositionGoalsHeldByTheLimitsConvergeWithoutRestarts).
    EXPECT_GE(4 * stalled_past, 3 * frames_past) << stalled_past << " of " << frames_past;
  }
  // A free pose reached rests on no limit.
  Eigen::VectorXd params = rest;
  const Goal g = Goal::position(start + glm::dvec3(0.0, 0.05, 0.05));
  const SolveResult r = solve(SolverKind::kDLS, chain, Span<const Goal>(&g, 1), SolverOptions(), ws, params);
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  EXPECT_EQ(r.joints_at_limit, 0);
}


// ------------------------------------------------------------------------------------ item 15
// A leg: a free ball hip, a 0.45 m thigh, a knee hinge in [0, 2.6] rad, a 0.42 m shin; R = 0.87 m.
Chain straight_leg() {
  Chain c;
  EXPECT_TRUE(bench::straight_leg_builder(0.45, 0.42).build(c).ok());
  return c;
}

// Item 15: soft reach. A foot target moving 2 mm a frame down through the leg's full reach: the
// knee snaps its last degrees straight within a few frames without it (the bend goes as
// sqrt(R - d)); with soft_reach = 5 % of the leg the knee straightens smoothly (no frame turns it
// by more than 2 deg, never a re-bend), never quite straight, the foot on the pulled target, whose
// pull SolveResult::soft_pull reports exactly.
TEST(Issue16, SoftReachStraightensTheKneeWithoutASnap) {
  const Chain leg = straight_leg();
  const double reach = 0.87, soft = 0.05 * reach;
  Workspace ws(leg, 1);
  for (SolverKind kind : {SolverKind::kTwoBone, SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kFABRIK}) {
    for (double soft_reach : {0.0, soft}) {
      SCOPED_TRACE(std::string(to_string(kind)) + (soft_reach > 0.0 ? " soft" : " hard"));
      SolverOptions o;
      o.soft_reach = soft_reach;
      o.max_iterations = 200;
      Eigen::VectorXd params = Eigen::VectorXd::Zero(leg.dof_count());
      params[3] = 1.0;  // start bent
      double largest_turn = 0.0, previous_knee = 0.0;
      bool rebent = false;
      for (int f = 0; f <= 125; ++f) {
        const glm::dvec3 target(0.0, -0.70 - 0.002 * f, 0.05);
        const Goal g = Goal::position(target);
        const SolveResult r = solve(kind, leg, Span<const Goal>(&g, 1), o, ws, params);
        ASSERT_TRUE(r.usable());
        const double knee = params[3];
        if (f > 0) {
          largest_turn = std::max(largest_turn, std::abs(knee - previous_knee));
          rebent = rebent || knee > previous_knee + 1e-6;
        }
        previous_knee = knee;
        // The pulled target, by the formula of options.hpp.
        const double d = glm::length(target);
        const double start = reach - soft_reach;
        const double pulled = soft_reach > 0.0 && d > start ? start + soft_reach * (1.0 - std::exp(-(d - start) / soft_reach)) : d;
        EXPECT_NEAR(r.soft_pull, d - pulled, 1e-12) << "frame " << f;
        if (soft_reach > 0.0) {
          EXPECT_EQ(r.reason, TerminationReason::kConverged) << "frame " << f << ": " << to_string(r.reason);
          EXPECT_NEAR(glm::length(test::tip_of(leg, params) - target * (pulled / d)), 0.0, 2e-5) << "frame " << f;
          EXPECT_GT(knee, 1e-3) << "frame " << f;  // never quite straight
        }
      }
      if (soft_reach > 0.0) {
        EXPECT_LE(largest_turn, 2.0 * so3::kPi / 180.0);
        EXPECT_FALSE(rebent);
      } else {
        EXPECT_GE(largest_turn, 4.0 * so3::kPi / 180.0);  // the snap soft reach removes
      }
    }
  }
  SolverOptions bad;
  bad.soft_reach = -1.0;
  EXPECT_NE(std::string(bad.validate().c_str()).find("soft_reach"), std::string::npos);
}

// Item 20: position goals without restarts on a 10-DOF humanoid torso + arm - iCub's torso (pitch,
// roll, yaw) and left arm (shoulder pitch, roll, yaw, elbow, wrist prosup, pitch, yaw) to the hand's
// DH frame, as tools/urdf_chain.py folds example-robot-data's icub.urdf (scripts/bench's
// icub_torso_arm). Every solve from the middle of the limits, max_iterations 100, no restart, as
// the robots bench. The trapped goals (bench goals 41 ... 1920) held the pseudo-inverse or BFGS
// at a pose with the torso roll and shoulder pitch on their bounds, the elbow branch wrong: every
// local escape led back (7 and 9 of the bench's 2,000 failed). Now the far escape leaves it. Then a
// seeded sample of 2,000 goals: >= 99.9 % converge with each of the three Newton-like solvers
// (on 253026a: pinv 1985, DLS 1999, BFGS 1987; now 2000 each).
// The robots bench's start (the middle of every hinge's limits) and options (1e-5 L, 1e-4 rad, no
// restart), counts not times: no time cap, so a loaded machine cannot cut a solve short.
SolverOptions robots_bench_options(const Chain& c, int max_iterations) {
  SolverOptions o = test::arm_options(c);
  o.max_iterations = max_iterations;
  o.warm_start = true;
  EXPECT_EQ(o.max_restarts, 0);
  return o;
}

Chain icub_torso_arm() {
  const double a = 0.49999816339744835, b = 0.49999999999662686, c = 0.5000018366025516;
  const std::vector<bench::UrdfHinge> joints = {
      {0.0, 0.0, 0.0, 9.381839456086127e-07, 0.7071080798588512, -9.381873917569988e-07, 0.7071054825106139, 0, 1,
       6.12323e-17, -0.383972, 1.46608},                                                    // torso_pitch
      {0.032, 0.0, 0.0, a, b, -c, -b, 0, 1, 6.12323e-17, -0.680678, 0.680678},              // torso_roll
      {0.0, -0.0055, 0.0, a, -b, c, -b, 0, -1, 6.12323e-17, -1.02974, 1.02974},             // torso_yaw
      {0.00525, 0.1433, -0.11026, 0.5609838376701609, 0.4304594025809017, 0.43046098374948, 0.5609858982826409, 0,
       -1, 5.55112e-17, -1.65806, 0.0872665},                                               // l_shoulder_pitch
      {0.0, 0.0, 0.0, a, b, -c, -b, 0, 1, 6.12323e-17, 0.0, 2.80649},                       // l_shoulder_roll
      {0.0, 0.0, 0.0, 0.7933524085796444, 0.0, 0.0, 0.6087626432369819, 0, 6.12323e-17, 1, -0.645772,
       1.74533},                                                                            // l_shoulder_yaw
      {0.015, 0.0, 0.15228, 1, 0, 0, 0, 0, 1, 6.12323e-17, 0.0959931, 1.85005},             // l_elbow
      {-0.015, 0.0, 0.0, a, b, -c, -b, 0, 1, 6.12323e-17, -0.872665, 0.872665},             // l_wrist_prosup
      {0.0, 0.1373, 0.0, a, b, c, b, 0, 1, 6.12323e-17, -1.13446, 0.174533},                // l_wrist_pitch
      {0.0, 0.0, 0.0, 1, 0, 0, 0, 0, 0, 1, -0.436332, 0.436332}};                            // l_wrist_yaw
  Chain chain;  // the tip: l_hand_dh_frame
  EXPECT_TRUE(bench::urdf_hinge_builder(joints, glm::dvec3(0.0625, 0.0, -0.016)).build(chain).ok());
  return chain;
}

TEST(Issue16, TorsoArmPositionGoalsWithoutRestarts) {
  const Chain c = icub_torso_arm();
  const int n = c.dof_count();
  ASSERT_EQ(n, 10);
  Workspace ws(c, 1);
  const Eigen::VectorXd middle = test::middle_of_limits(c);
  const SolverOptions o = robots_bench_options(c, 100);
  // Converged, within the limits, the tip (by 4x4 transforms, not the library's FK) on the target.
  auto reaches = [&](SolverKind kind, const glm::dvec3& target) {
    Eigen::VectorXd p = middle;
    const SolveResult r = test::run(kind, c, {Goal::position(target)}, o, ws, p);
    const glm::dvec3 reached(test::hinge_tool_frame_by_matrices(c, p.data())[3]);
    return r.reason == TerminationReason::kConverged && r.restarts == 0 && within_limits(c, p.data(), 0.0) &&
           glm::length(reached - target) <= o.position_tolerance;
  };
  const std::vector<std::vector<double>> trapped = {
      {0.07181200439487645, -0.50280903500740115, 0.56022887232740937, -0.092507302093024935, 2.5689658286488495,
       -0.13625300196092138, 0.72276489826568469, -0.86248260491296491, -0.49247157154971832, 0.11650176748751856},
      {1.4531954557267595, -0.33539586464158483, -0.98751612521741716, -0.84044579976653289, 2.6788936231583524,
       -0.14680430095073016, 0.80265284464964992, 0.093276663920899616, -0.17584687748256767, 0.20837087828666107},
      {-0.18739416711886081, -0.6511758384940427, 0.3138749475304623, -0.36791728852599648, 2.5624443315488499,
       0.57255743541146797, 0.27763552772198841, -0.31346636511518133, -1.1185693294132528, -0.40841111981605477},
      {1.2801894412729362, 0.34247851680084829, -0.90690482247814075, -0.11352729897822078, 0.40595803347944937,
       0.77110650596110863, 0.098245128229731027, -0.44384143383509922, -0.17979035054010928, 0.29555844601785536},
      {-0.37402009225729521, -0.57424181171267985, 0.19294870722410362, -0.12878142888008015, 2.6178702495619803,
       -0.44172826452067515, 0.77222527096097937, 0.33955311688156198, -0.75778242114936256, -0.30828892637111177},
      {0.40841363329465685, -0.66120253277158847, -0.61962338514186577, -0.39734243352638421, 2.4413969971238894,
       -0.075289430992899531, 0.65517998346589712, -0.62415139274305131, -0.18852065159555986, -0.3189726809636807},
      {0.1445846960379511, -0.47292606596432507, 0.9207061962640386, -0.59626806522177733, 0.26197817955503305,
       1.3295888722886686, 1.6988701788437004, -0.58497284069460509, 0.087997819613495842, -0.25447273120247926},
      {1.3555685719249246, -0.38807563418765822, 0.9577060659470289, -0.19167322611271431, 2.1263237412326217,
       -0.18688911651214346, 0.87673687624268792, 0.86839049585628936, -0.3142320698679385, 0.40136256192832193},
      {0.14988509102700598, -0.62023115788313776, -0.31293762995648011, -0.63688189099857695, 2.0981928527227152,
       -0.30845348851552395, 1.1027896134950594, -0.65033353081433332, -0.26490819856875103, -0.34446589176262388},
      {0.34240311854378014, -0.55471846358958199, -0.86880626404578332, -1.2948198917224751, 2.4998044269829363,
       -0.21627385672305965, 1.4661855258345051, 0.77074497481039161, -0.9589189808274865, -0.087242960777547507}};
  const SolverKind kinds[] = {SolverKind::kJacobianPinv, SolverKind::kDLS, SolverKind::kBFGS};
  for (SolverKind kind : kinds) {
    for (size_t g = 0; g < trapped.size(); ++g) {
      const glm::dvec3 target(test::hinge_tool_frame_by_matrices(c, trapped[g].data())[3]);
      EXPECT_TRUE(reaches(kind, target)) << "trapped goal " << g << " " << to_string(kind);
    }
  }
  // The seeded sample: joint vectors uniform within the limits (mt19937 words mapped by hand, so
  // every standard library draws the same goals).
  constexpr int kGoals = 2000;
  std::mt19937 rng(20261126u);
  std::vector<glm::dvec3> targets;
  Eigen::VectorXd q(n);
  for (int t = 0; t < kGoals; ++t) {
    for (int i = 0; i < n; ++i)
      q[i] = c.limits(i).hinge_min + (c.limits(i).hinge_max - c.limits(i).hinge_min) * (rng() * 0x1p-32);
    targets.push_back(glm::dvec3(test::hinge_tool_frame_by_matrices(c, q.data())[3]));
  }
  for (SolverKind kind : kinds) {
    int reached = 0;
    for (const glm::dvec3& target : targets) reached += reaches(kind, target);
    std::printf("  %-13s %d of %d position goals without restarts\n", to_string(kind), reached, kGoals);
    EXPECT_GE(reached, kGoals - kGoals / 1000) << to_string(kind);  // >= 99.9 %
  }
}

// Item 20: full-pose goals without restarts on a UR5 and a UR10 (scripts/bench's ur5 and ur10:
// example-robot-data's ur5_robot.urdf, the e-series' ranges: +-2 pi, the elbow +-pi, and
// ur10_joint_limited_robot.urdf, +-pi; base_link -> tool0), as the robots bench solves them: from
// the middle of the limits, Goal::pose with the chain's length, no restart, success by 4x4
// transforms within 1e-5 L and 1e-4 rad and within the limits, max_iterations 300 (room for the
// far escapes). On the bench's 2,000 goals per arm (pseudo-inverse / DLS / BFGS): with up to 3 far
// escapes UR5 40 / 41 / 55 failures; with 16 (stuck::kFarEscapes) UR5 4 / 4 / 28, UR10 10 / 32 / 34;
// with BFGS's Gauss-Newton steps after a fast step (Fletcher & Xu, bfgs.cpp) BFGS UR5 3, UR10 14
// (`robots_bench --iterations 300`, docs/robots-bench.md). On these tests' own seeded goals,
// reached of 2,000: UR5 2000 / 1995 / 1979 before the hybrid, 2000 / 1995 / 1996 after; UR10
// 1981 / 1977 / 1964 before, 1981 / 1977 / 1983 after. The bounds, 10 / 10 / 10 and 25 / 30 / 25
// failures, fail BFGS before the hybrid on both arms.
Chain ur_arm(double base, double shoulder, double upper_arm_offset, double upper_arm, double forearm,
             double wrist_1, double wrist_2, double tool, double elbow_range, double range) {
  const double c = 0.7071067811882787, s = 0.7071067811848163;
  const std::vector<bench::UrdfHinge> joints = {
      {0.0, 0.0, base, 1, 0, 0, 0, 0, 0, 1, -range, range},                 // shoulder_pan
      {0.0, shoulder, 0.0, c, 0, s, 0, 0, 1, 0, -range, range},             // shoulder_lift
      {0.0, upper_arm_offset, upper_arm, 1, 0, 0, 0, 0, 1, 0, -elbow_range, elbow_range},  // elbow
      {0.0, 0.0, forearm, c, 0, s, 0, 0, 1, 0, -range, range},              // wrist_1
      {0.0, wrist_1, 0.0, 1, 0, 0, 0, 0, 0, 1, -range, range},              // wrist_2
      {0.0, 0.0, wrist_2, 1, 0, 0, 0, 0, 1, 0, -range, range}};             // wrist_3
  Chain chain;  // the tip: tool0
  EXPECT_TRUE(bench::urdf_hinge_builder(joints, glm::dvec3(0.0, tool, 0.0))
                  .set_tip_rotation(glm::dquat(c, -s, 0.0, 0.0))
                  .build(chain)
                  .ok());
  return chain;
}

Chain ur5() {
  const double kTurn = 6.28318530718, kHalf = 3.14159265359;
  return ur_arm(0.089159, 0.13585, -0.1197, 0.425, 0.39225, 0.093, 0.09465, 0.0823, kHalf, kTurn);
}

Chain ur10() {
  const double kHalf = 3.14159265359;
  return ur_arm(0.1273, 0.220941, -0.1719, 0.612, 0.5723, 0.1149, 0.1157, 0.0922, kHalf, kHalf);
}

struct FailureBound {
  SolverKind kind;
  int max_failures;
};

// Of 2,000 seeded full poses (joint vectors uniform within the limits, mt19937 words mapped by
// hand), how many each solver reaches without restarts; expects at most `max_failures` misses.
void expect_full_poses_reached(const Chain& c, std::initializer_list<FailureBound> bounds) {
  const int n = c.dof_count();
  Workspace ws(c, 2);
  const Eigen::VectorXd middle = test::middle_of_limits(c);
  const SolverOptions o = robots_bench_options(c, 300);
  constexpr int kGoals = 2000;
  std::mt19937 rng(20261126u);
  std::vector<glm::dmat4> targets;
  Eigen::VectorXd q(n);
  for (int t = 0; t < kGoals; ++t) {
    for (int i = 0; i < n; ++i)
      q[i] = c.limits(i).hinge_min + (c.limits(i).hinge_max - c.limits(i).hinge_min) * (rng() * 0x1p-32);
    targets.push_back(test::hinge_tool_frame_by_matrices(c, q.data()));
  }
  for (const FailureBound& k : bounds) {
    int reached = 0;
    for (const glm::dmat4& target : targets) {
      const glm::dquat orientation = glm::quat_cast(glm::dmat3(target));
      const auto goals = pose_goals(c, glm::dvec3(target[3]), orientation);
      Eigen::VectorXd p = middle;
      const SolveResult r = test::run(k.kind, c, {goals[0], goals[1]}, o, ws, p);
      const glm::dmat4 tool = test::hinge_tool_frame_by_matrices(c, p.data());
      const glm::dquat d = glm::conjugate(orientation) * glm::quat_cast(glm::dmat3(tool));
      const double angle = 2.0 * std::atan2(glm::length(glm::dvec3(d.x, d.y, d.z)), std::abs(d.w));
      reached += r.reason == TerminationReason::kConverged && r.restarts == 0 && within_limits(c, p.data(), 0.0) &&
                 glm::length(glm::dvec3(tool[3]) - glm::dvec3(target[3])) <= o.position_tolerance &&
                 angle <= o.orientation_tolerance;
    }
    std::printf("  %-13s %d of %d full-pose goals without restarts\n", to_string(k.kind), reached, kGoals);
    EXPECT_GE(reached, kGoals - k.max_failures) << to_string(k.kind);
  }
}

TEST(Issue16, Ur5FullPoseGoalsWithoutRestarts) {
  const Chain c = ur5();
  ASSERT_EQ(c.dof_count(), 6);
  expect_full_poses_reached(c, {{SolverKind::kJacobianPinv, 10}, {SolverKind::kDLS, 10}, {SolverKind::kBFGS, 10}});
}

TEST(Issue16, Ur10FullPoseGoalsWithoutRestarts) {
  const Chain c = ur10();
  ASSERT_EQ(c.dof_count(), 6);
  // DLS 0: a query's descent crosses the +-pi bounds (stuck::Escapes::cross_full_turn_bounds); before
  // that 23 goals failed.
  expect_full_poses_reached(c, {{SolverKind::kJacobianPinv, 25}, {SolverKind::kDLS, 0}, {SolverKind::kBFGS, 25}});
}

}  // namespace
}  // namespace ikchain
