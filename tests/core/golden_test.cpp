// Golden iteration counts: a fixed, seeded set of chain and tree problems for every solver, with
// the exact iterations, escapes, restarts and termination reason each solve gives, and its final
// error within 1e-9 (absolute), recorded from the code as it was. It guards refactors that must not
// change behaviour (issue 14, item 5: joint traits, workspace roles, public headers): any change of
// a step, a test or a constant shows up here, long before a success-rate test would notice.
//
// Re-recording, after a deliberate solver change moves the numbers:
//   IKCHAIN_GOLDEN_PRINT=1 build/tests/core/core_tests --gtest_filter='Golden.*'
// prints each table (chains, then trees) as C++ rows; paste them over kChainGolden / kTreeGolden
// below and say in the commit which change moved which rows and why. The solves run with no time
// budget and no time cap (time_cap_usec = 0), so no clock decides anything.
//
// The numbers come from GCC on x86-64 with glibc's libm. The Windows suite (mingw-w64, run under
// wine) links mingw's own sin/cos/atan2, whose last bits differ: iteration counts there are not
// expected to match and the comparison is skipped (every other test still runs there).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "ikchain/solve.hpp"
#include "ikchain/tree_solve.hpp"
#include "humanoid.hpp"
#include "solver_test_util.hpp"
#include "telescope_arm.hpp"
#include "tree_test_util.hpp"

namespace ikchain {
namespace {

struct Golden {
  const char* name;
  int reason;  // TerminationReason
  int iterations;
  int escapes;
  int restarts;
  double final_error;
};

// Recorded with IKCHAIN_GOLDEN_PRINT=1 (see the top of the file).
// {problem/solver, reason, iterations, escapes, restarts, final_error}
// clang-format off
const Golden kChainGolden[] = {
    {"hinge10_pos0/ccd", 0, 34, 0, 0, 7.8656680474247249e-06},
    {"hinge10_pos0/jacobian_pinv", 0, 7, 0, 0, 1.3059255452405102e-06},
    {"hinge10_pos0/dls", 0, 6, 0, 0, 5.5566534333221876e-08},
    {"hinge10_pos0/bfgs", 0, 8, 0, 0, 5.5050632574487445e-06},
    {"hinge10_pos0/fabrik", 0, 13, 0, 0, 3.7359508212965362e-06},
    {"hinge10_pos1/ccd", 0, 8, 0, 0, 3.3478454607794631e-06},
    {"hinge10_pos1/jacobian_pinv", 0, 9, 0, 0, 9.2966144699133496e-10},
    {"hinge10_pos1/dls", 0, 9, 0, 0, 5.6944552018027655e-08},
    {"hinge10_pos1/bfgs", 0, 5, 0, 0, 1.0290645561433144e-08},
    {"hinge10_pos1/fabrik", 0, 10, 0, 0, 8.5536059463926149e-06},
    {"hinge10_pos2/ccd", 0, 6, 0, 0, 8.7089414329312256e-06},
    {"hinge10_pos2/jacobian_pinv", 0, 6, 0, 0, 4.5715307460566167e-07},
    {"hinge10_pos2/dls", 0, 6, 0, 0, 6.398055869087942e-06},
    {"hinge10_pos2/bfgs", 0, 6, 0, 0, 5.4975880566048726e-07},
    {"hinge10_pos2/fabrik", 0, 14, 0, 0, 3.0731635337704305e-06},
    {"hinge10_aim_at/ccd", 2, 92, 0, 0, 0.22552373235202086},
    {"hinge10_aim_at/jacobian_pinv", 1, 100, 0, 0, 0.21554689334753965},
    {"hinge10_aim_at/dls", 1, 100, 0, 0, 0.21442386724102641},
    {"hinge10_aim_at/bfgs", 3, 31, 0, 0, 0.21442359597300459},
    {"hinge10_aim_at/fabrik", 2, 19, 0, 0, 2.8084730206520678},
    {"hinge10_far/ccd", 2, 2, 0, 0, 4.7585269500626906},
    {"hinge10_far/jacobian_pinv", 2, 99, 0, 0, 4.4808211077698896},
    {"hinge10_far/dls", 1, 100, 0, 0, 4.479159315797415},
    {"hinge10_far/bfgs", 2, 38, 0, 0, 4.4791312096193057},
    {"hinge10_far/fabrik", 2, 2, 0, 0, 4.7585269500626906},
    {"mixed7_pos/ccd", 0, 36, 0, 0, 8.4639281090868511e-06},
    {"mixed7_pos/jacobian_pinv", 0, 6, 0, 0, 3.1219008747570947e-09},
    {"mixed7_pos/dls", 0, 6, 0, 0, 3.3081375184927748e-08},
    {"mixed7_pos/bfgs", 0, 6, 0, 0, 3.2879285407361159e-11},
    {"mixed7_pos/fabrik", 0, 12, 0, 0, 6.029447981876672e-06},
    {"mixed7_pose/ccd", 1, 100, 0, 0, 0.0092878019998255817},
    {"mixed7_pose/jacobian_pinv", 0, 6, 0, 0, 4.7663429116505644e-06},
    {"mixed7_pose/dls", 0, 6, 0, 0, 1.1388348836545337e-06},
    {"mixed7_pose/bfgs", 0, 8, 0, 0, 3.1840342356076057e-06},
    {"mixed7_pose/fabrik", 2, 32, 5, 0, 0.0075371843511563815},
    {"mixed7_restarts/ccd", 0, 6, 0, 0, 5.5432797669881402e-07},
    {"mixed7_restarts/jacobian_pinv", 0, 8, 0, 0, 1.0944692080466981e-10},
    {"mixed7_restarts/dls", 0, 7, 0, 0, 2.2954353504749112e-06},
    {"mixed7_restarts/bfgs", 0, 6, 0, 0, 2.6607987122106434e-07},
    {"mixed7_restarts/fabrik", 0, 114, 10, 2, 1.7053173885142045e-06},
    {"balls5_pose/ccd", 1, 100, 0, 0, 0.010647951865377439},
    {"balls5_pose/jacobian_pinv", 0, 6, 0, 0, 1.26572114655192e-08},
    {"balls5_pose/dls", 0, 6, 0, 0, 5.2934680483124855e-09},
    {"balls5_pose/bfgs", 0, 6, 0, 0, 5.4150821922172681e-10},
    {"balls5_pose/fabrik", 0, 60, 2, 0, 1.0615327702051007e-05},
    {"balls5_mid/ccd", 1, 100, 0, 0, 0.012311268959184673},
    {"balls5_mid/jacobian_pinv", 0, 6, 0, 0, 7.2789720449039044e-09},
    {"balls5_mid/dls", 0, 6, 0, 0, 8.685601884121794e-06},
    {"balls5_mid/bfgs", 0, 5, 0, 0, 4.4743864527254036e-07},
    {"balls5_mid/fabrik", 0, 29, 1, 0, 9.9240664368866557e-06},
    {"arm_reach/two_bone", 0, 1, 0, 0, 7.8504622934188758e-17},
    {"arm_reach/ccd", 0, 1, 0, 0, 1.4946834900704541e-16},
    {"arm_reach/jacobian_pinv", 0, 7, 0, 0, 3.7830276826077701e-06},
    {"arm_reach/dls", 0, 7, 0, 0, 3.0117869634991857e-06},
    {"arm_reach/bfgs", 0, 5, 0, 0, 4.2071783018783897e-09},
    {"arm_reach/fabrik", 0, 4, 0, 0, 1.9631673023545877e-07},
    {"arm_pole/two_bone", 0, 1, 0, 0, 1.2412670766236366e-16},
    {"arm_pole/ccd", 0, 1, 0, 0, 1.3947004136484323e-16},
    {"arm_pole/jacobian_pinv", 0, 7, 0, 0, 3.7830276825973741e-06},
    {"arm_pole/dls", 0, 7, 0, 0, 3.0117869634877338e-06},
    {"arm_pole/bfgs", 0, 5, 0, 0, 4.2071783474006675e-09},
    {"arm_pole/fabrik", 0, 4, 0, 0, 1.9631673014597517e-07},
    {"arm_far/two_bone", 3, 1, 0, 0, 0.40138781886599739},
    {"arm_far/ccd", 3, 2, 0, 0, 0.40138781886599739},
    {"arm_far/jacobian_pinv", 3, 2, 0, 0, 0.4013878188659985},
    {"arm_far/dls", 2, 5, 0, 0, 0.40140131726341732},
    {"arm_far/bfgs", 3, 6, 0, 0, 0.40138782716924287},
    {"arm_far/fabrik", 3, 2, 0, 0, 0.40138781886599739},
    {"leg_cold_aim/ccd", 2, 53, 0, 0, 0.63096395452482812},
    {"leg_cold_aim/jacobian_pinv", 2, 5, 0, 0, 0.63097057656280331},
    {"leg_cold_aim/dls", 2, 5, 0, 0, 0.63101021521253253},
    {"leg_cold_aim/bfgs", 2, 6, 0, 0, 0.63101607293567907},
    {"leg_cold_aim/fabrik", 2, 3, 0, 0, 0.65192024052026487},
    {"telescope_pose/jacobian_pinv", 0, 4, 0, 0, 8.1261589343729316e-09},
    {"telescope_pose/dls", 0, 4, 0, 0, 1.2173643758500259e-08},
    {"telescope_pose/bfgs", 0, 4, 0, 0, 8.1261631450683171e-09},
};
const Golden kTreeGolden[] = {
    {"fixed_hands_feet_pos/ccd", 1, 60, 0, 0, 0.0012364263377061609},
    {"fixed_hands_feet_pos/dls", 0, 9, 0, 0, 5.7740747970856658e-06},
    {"fixed_hands_feet_pos/bfgs", 0, 11, 0, 0, 2.5888335739898561e-09},
    {"fixed_hands_feet_pos/fabrik", 1, 60, 0, 0, 0.047439302257434472},
    {"fixed_five_6d/ccd", 1, 60, 0, 0, 0.060711237147392828},
    {"fixed_five_6d/dls", 0, 11, 0, 0, 2.0472971665781869e-07},
    {"fixed_five_6d/bfgs", 0, 9, 0, 0, 9.9129687339528297e-06},
    {"fixed_five_6d/fabrik", 1, 60, 1, 0, 0.61505846379062201},
    {"fixed_levels/ccd", 1, 60, 0, 0, 0.94908882842592635},
    {"fixed_levels/dls", 1, 60, 0, 0, 1.2624961689321144},
    {"fixed_levels/bfgs", 1, 60, 1, 0, 0.83801145535738575},
    {"fixed_levels/fabrik", 1, 60, 0, 0, 1.6388672465918184},
    {"fixed_posture/dls", 1, 60, 0, 0, 0.89322043749544078},
    {"floating_hands_feet_pos/ccd", 0, 51, 0, 0, 1.1535768936192165e-05},
    {"floating_hands_feet_pos/dls", 0, 10, 0, 0, 1.4835183287006941e-06},
    {"floating_hands_feet_pos/bfgs", 0, 8, 0, 0, 6.3021255620601108e-11},
    {"floating_hands_feet_pos/fabrik", 1, 60, 0, 0, 0.050393122371858744},
    {"floating_five_6d/ccd", 1, 60, 0, 0, 0.044209335111888758},
    {"floating_five_6d/dls", 0, 6, 0, 0, 3.9043444593428294e-06},
    {"floating_five_6d/bfgs", 0, 6, 0, 0, 1.555284884065775e-06},
    {"floating_five_6d/fabrik", 1, 60, 0, 0, 0.40514438207198622},
    {"floating_levels/ccd", 1, 60, 0, 0, 0.79847943341558159},
    {"floating_levels/dls", 1, 60, 1, 0, 0.7161162597628925},
    {"floating_levels/bfgs", 1, 60, 0, 0, 0.75071755093396175},
    {"floating_levels/fabrik", 1, 60, 1, 0, 1.0112710169653443},
    {"floating_posture/dls", 1, 60, 0, 0, 0.71656195940176592},
    {"nolimits_hands_feet_pos/ccd", 0, 54, 0, 0, 3.2639778429230947e-06},
    {"nolimits_hands_feet_pos/dls", 0, 9, 0, 0, 1.5341865307894727e-07},
    {"nolimits_hands_feet_pos/bfgs", 0, 11, 0, 0, 3.5263139736121928e-06},
    {"nolimits_hands_feet_pos/fabrik", 0, 47, 0, 0, 1.0052732888228708e-05},
    {"nolimits_five_6d/ccd", 1, 60, 0, 0, 0.022027875443504315},
    {"nolimits_five_6d/dls", 0, 9, 0, 0, 5.004529375044496e-06},
    {"nolimits_five_6d/bfgs", 0, 16, 0, 0, 4.1928359469444938e-07},
    {"nolimits_five_6d/fabrik", 1, 60, 0, 0, 2.1022613103430122e-05},
    {"nolimits_levels/ccd", 1, 60, 0, 0, 1.0321802888769798},
    {"nolimits_levels/dls", 1, 60, 0, 0, 0.98147446241506164},
    {"nolimits_levels/bfgs", 1, 60, 0, 0, 1.0921448494608672},
    {"nolimits_levels/fabrik", 1, 60, 0, 0, 1.0494091056548756},
    {"nolimits_posture/dls", 1, 60, 0, 0, 0.98100817454756428},
    {"telescope_tree/dls", 0, 5, 0, 0, 4.7415410503480834e-08},
    {"telescope_tree/bfgs", 0, 5, 0, 0, 5.8421249721833215e-06},
};
// clang-format on

bool printing() {
  const char* v = std::getenv("IKCHAIN_GOLDEN_PRINT");
  return v != nullptr && *v != '\0' && std::string(v) != "0";
}

// Compares the observed rows with the table, or prints them.
void check(const char* table_name, const std::vector<std::string>& names, const std::vector<Golden>& got,
           const Golden* table, size_t table_size) {
  if (printing()) {
    std::printf("// %s: %zu rows\n", table_name, got.size());
    for (size_t i = 0; i < got.size(); ++i)
      std::printf("{\"%s\", %d, %d, %d, %d, %.17g},\n", names[i].c_str(), got[i].reason, got[i].iterations,
                  got[i].escapes, got[i].restarts, got[i].final_error);
    return;
  }
#ifdef _WIN32
  GTEST_SKIP() << "recorded against glibc's libm (see the top of golden_test.cpp)";
#endif
  ASSERT_EQ(got.size(), table_size) << table_name << ": the problem set changed; re-record (top of golden_test.cpp)";
  for (size_t i = 0; i < got.size(); ++i) {
    const Golden& want = table[i];
    SCOPED_TRACE(names[i]);
    EXPECT_EQ(names[i], want.name);
    EXPECT_EQ(got[i].reason, want.reason) << to_string(static_cast<TerminationReason>(got[i].reason));
    EXPECT_EQ(got[i].iterations, want.iterations);
    EXPECT_EQ(got[i].escapes, want.escapes);
    EXPECT_EQ(got[i].restarts, want.restarts);
    EXPECT_NEAR(got[i].final_error, want.final_error, 1e-9);
  }
}

SolverOptions base_options() {
  SolverOptions o;
  o.time_cap_usec = 0.0;  // no clock: the counts are the algorithm's alone
  return o;
}

// ---------------------------------------------------------------------------------------------
// Chains.

struct ChainProblem {
  std::string name;
  Chain chain;
  std::vector<Goal> goals;
  Eigen::VectorXd start;
  SolverOptions options;
};

using test::telescope_arm;

glm::dquat tip_orientation_at(const Chain& chain, const Eigen::VectorXd& params) {
  Workspace ws(chain, 1);
  forward_kinematics(chain, params.data(), ws);
  return effector_orientation(chain, ws, chain.joint_count());
}

// Every chain problem: a reachable position, a 6-D pose, an out-of-reach target, warm and cold
// starts, limits, a pole, restarts; each built from its own seed.
std::vector<ChainProblem> chain_problems() {
  std::vector<ChainProblem> out;
  std::mt19937 rng(20261126);
  const Chain hinges = test::make_hinge_chain(10);
  const test::LimitRanges ranges{0.3, 1.2, 0.3, 1.0, 0.3, 1.0};
  const Chain mixed = test::limited_chain(7, test::LimitedJoints::kEveryThirdBall, ranges, test::LimitDraws::kOwnFieldsOnly, rng);
  const Chain balls = test::limited_chain(5, test::LimitedJoints::kAllBalls, ranges, test::LimitDraws::kOwnFieldsOnly, rng);
  const Chain arm = test::humanoid::chain({"LeftUpperArm", "LeftLowerArm"}, "LeftHand", true, 0.0, 2.6);
  const Chain leg = test::humanoid::chain({"Hips", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot"}, "LeftToes", true, 0.0, 2.8);
  const Chain telescope = telescope_arm();
  auto add = [&](const std::string& name, const Chain& c, std::vector<Goal> goals, Eigen::VectorXd start,
                 SolverOptions o) { out.push_back({name, c, std::move(goals), std::move(start), o}); };
  auto zeros = [](const Chain& c) { return Eigen::VectorXd::Zero(c.dof_count()); };
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd q = test::random_params(hinges, rng, 1.5);
    const Eigen::VectorXd warm = test::random_params(hinges, rng, 0.5);
    add("hinge10_pos" + std::to_string(k), hinges, {Goal::position(test::effector_of(hinges, q, 0))},
        k == 2 ? warm : zeros(hinges), base_options());
  }
  add("hinge10_aim_at", hinges,
      {Goal::position(glm::dvec3(1.5, 6.0, 0.5), 6), Goal::aim_at(glm::dvec3(4.0, 3.0, 2.0), glm::dvec3(0, 1, 0))},
      zeros(hinges), base_options());
  add("hinge10_far", hinges, {Goal::position(glm::dvec3(3.0, 14.0, 2.0))}, zeros(hinges), base_options());
  {
    Eigen::VectorXd q = test::random_params(mixed, rng, 1.0);
    project_to_limits(mixed, q.data());
    add("mixed7_pos", mixed, {Goal::position(test::effector_of(mixed, q, 0))}, zeros(mixed), base_options());
    add("mixed7_pose", mixed,
        {Goal::position(test::effector_of(mixed, q, 0)), Goal::orientation(tip_orientation_at(mixed, q))},
        zeros(mixed), base_options());
    SolverOptions restarts = base_options();
    restarts.max_restarts = 3;
    restarts.max_iterations = 40;
    add("mixed7_restarts", mixed, {Goal::position(glm::dvec3(2.5, 1.0, -2.0))}, zeros(mixed), restarts);
  }
  {
    Eigen::VectorXd q = test::random_params(balls, rng, 1.2);
    project_to_limits(balls, q.data());
    add("balls5_pose", balls,
        {Goal::position(test::effector_of(balls, q, 0)), Goal::orientation(tip_orientation_at(balls, q))},
        zeros(balls), base_options());
    add("balls5_mid", balls,
        {Goal::position(test::effector_of(balls, q, 3), 3), Goal::position(test::effector_of(balls, q, 0))},
        zeros(balls), base_options());
  }
  {
    SolverOptions pole = base_options();
    pole.use_pole = true;
    pole.pole_in_base = glm::dvec3(0.0, 0.2, 0.5);
    add("arm_reach", arm, {Goal::position(glm::dvec3(0.1, 0.35, 0.2))}, zeros(arm), base_options());
    add("arm_pole", arm, {Goal::position(glm::dvec3(0.1, 0.35, 0.2))}, zeros(arm), pole);
    add("arm_far", arm, {Goal::position(glm::dvec3(0.0, 0.9, 0.3))}, zeros(arm), base_options());
    SolverOptions cold = base_options();
    cold.warm_start = false;
    Eigen::VectorXd start = zeros(leg);
    start.setConstant(0.3);
    add("leg_cold_aim", leg,
        {Goal::position(glm::dvec3(0.15, -0.6, 0.25), 3), Goal::aim(glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1))},
        start, cold);
  }
  {
    Eigen::VectorXd q = zeros(telescope);
    q << 0.3, -0.2, 0.1, 0.5, 0.9, -0.4, 0.2, 0.1;
    add("telescope_pose", telescope,
        {Goal::position(test::effector_of(telescope, q, 0)), Goal::orientation(tip_orientation_at(telescope, q))},
        zeros(telescope), base_options());
  }
  return out;
}

bool takes(const SolverInfo& info, const ChainProblem& p) {
  if (info.joint_count != 0 && info.joint_count != p.chain.joint_count()) return false;
  if (!info.prismatic_joints && p.chain.first_prismatic() >= 0) return false;
  if (!info.several_goals && p.goals.size() > 1) return false;
  for (const Goal& g : p.goals) {
    if (g.kind != GoalKind::kPosition && !info.orientation_goals) return false;
    if (g.kind != GoalKind::kPosition && g.effector != 0 && g.effector != p.chain.joint_count() &&
        !info.intermediate_orientation_goals)
      return false;
  }
  if (info.kind == SolverKind::kCCD && p.goals.size() > static_cast<size_t>(kCcdMaxGoals)) return false;
  return true;
}

TEST(Golden, ChainIterationCountsReasonsAndErrors) {
  std::vector<std::string> names;
  std::vector<Golden> got;
  for (const ChainProblem& p : chain_problems()) {
    for (const SolverInfo& info : solver_table()) {
      if (!takes(info, p)) continue;
      Workspace ws(p.chain, static_cast<int>(p.goals.size()));
      Eigen::VectorXd params = p.start;
      const SolveResult r = solve(info.kind, p.chain, Span<const Goal>(p.goals), p.options, ws, params);
      ASSERT_TRUE(r.usable()) << p.name << " " << info.id << ": " << r.message.c_str();
      names.push_back(p.name + "/" + info.id);
      got.push_back({nullptr, static_cast<int>(r.reason), r.iterations, r.escapes, r.restarts, r.final_error});
    }
  }
  check("kChainGolden", names, got, kChainGolden, sizeof(kChainGolden) / sizeof(kChainGolden[0]));
}

// ---------------------------------------------------------------------------------------------
// Trees: the humanoid of tree_test_util.hpp, fixed and floating root.

struct TreeCase {
  std::string name;
  const Tree* tree;
  std::vector<TreeGoal> goals;
  std::vector<double> posture;
  Eigen::VectorXd start;
  SolverOptions options;
  bool dls_only;  // a posture: only the DLS has one (the others ignore it or refuse it)
  bool jacobian_only = false;  // a slide: DLS and BFGS only (CCD and FABRIK turn joints only)
};

TEST(Golden, TreeIterationCountsReasonsAndErrors) {
  using H = test::Humanoid;
  const Tree fixed = test::make_humanoid(false);
  const Tree floating = test::make_humanoid(true);
  const Tree free_body = test::make_humanoid(true, false);
  std::mt19937 rng(1126);
  std::vector<TreeCase> cases;
  for (const Tree* t : {&fixed, &floating, &free_body}) {
    const std::string root = t == &fixed ? "fixed" : t == &floating ? "floating" : "nolimits";
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(t->dof_count());
    const Eigen::VectorXd q = test::random_tree_params(*t, rng, 1.0, 0.15);
    SolverOptions o = base_options();
    o.max_iterations = 60;
    cases.push_back({root + "_hands_feet_pos", t,
                     test::pose_goals_at(*t, q, {H::kLHand, H::kRHand, H::kLFoot, H::kRFoot}, 1, false), {}, zero, o,
                     false});
    cases.push_back({root + "_five_6d", t,
                     test::pose_goals_at(*t, q, {H::kHeadEffector, H::kLHand, H::kRHand, H::kLFoot, H::kRFoot}, 1),
                     {}, zero, o, false});
    // Feet at level 1, a hand beyond reach at level 2.
    std::vector<TreeGoal> levels = test::pose_goals_at(*t, q, {H::kLFoot, H::kRFoot}, 1);
    levels.push_back({Goal::position(glm::dvec3(1.6, 1.9, 0.8), H::kLHand), 2});
    levels.push_back({Goal::position(test::pose_goals_at(*t, q, {H::kRHand}, 2, false)[0].goal.target_position,
                                     H::kRHand), 2});
    cases.push_back({root + "_levels", t, levels, {}, zero, o, false});
    // The same with a posture (the random pose's neighbour) below every level, warm.
    const Eigen::VectorXd posture = test::random_tree_params(*t, rng, 0.4, 0.05);
    cases.push_back({root + "_posture", t, levels, std::vector<double>(posture.data(), posture.data() + posture.size()),
                     posture, o, true});
  }
  // The telescoping arm as a tree (a slide between two turning joints).
  Tree telescope;
  ASSERT_TRUE(tree_from_chain(telescope_arm(), telescope).ok());
  {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(telescope.dof_count());
    q << 0.3, -0.2, 0.1, 0.5, 0.9, -0.4, 0.2, 0.1;
    SolverOptions o = base_options();
    TreeCase c{"telescope_tree", &telescope, test::pose_goals_at(telescope, q, {telescope.effector_count() - 1}, 1),
               {}, Eigen::VectorXd::Zero(telescope.dof_count()), o, false};
    c.jacobian_only = true;
    cases.push_back(c);
  }
  std::vector<std::string> names;
  std::vector<Golden> got;
  for (const TreeCase& c : cases) {
    for (const SolverInfo& info : solver_table()) {
      if (!info.trees) continue;
      if (c.dls_only && info.kind != SolverKind::kDLS) continue;
      if (c.jacobian_only && info.kind != SolverKind::kDLS && info.kind != SolverKind::kBFGS) continue;
      TreeWorkspace ws(*c.tree, static_cast<int>(c.goals.size()));
      Eigen::VectorXd params = c.start;
      TreeProblem problem;
      problem.goals = Span<const TreeGoal>(c.goals);
      if (!c.posture.empty()) problem.posture = Span<const double>(c.posture);
      const TreeSolveResult r = solve_tree(info.kind, *c.tree, problem, c.options, ws, params);
      ASSERT_TRUE(r.usable()) << c.name << " " << info.id << ": " << r.summary.message.c_str();
      names.push_back(c.name + "/" + info.id);
      const SolveResult& s = r.summary;
      got.push_back({nullptr, static_cast<int>(s.reason), s.iterations, s.escapes, s.restarts, s.final_error});
    }
  }
  check("kTreeGolden", names, got, kTreeGolden, sizeof(kTreeGolden) / sizeof(kTreeGolden[0]));
}

}  // namespace
}  // namespace ikchain
