// The dispatcher's promises, checked for every solver: each invalid input in turn gives
// kInvalidInput, an untouched pose and a message naming the field (ozz's JobValidity style).
#include "ikchain/solve.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "alloc_counter.hpp"
#include "ikchain/kinematics.hpp"
#include "test_util.hpp"

namespace ikchain {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

class SolveValidity : public ::testing::TestWithParam<SolverKind> {
 protected:
  Chain chain = test::make_hinge_chain(2);
  Workspace ws{chain, 2};
  SolverOptions options;
  std::vector<Goal> goals{Goal::position(glm::dvec3(0.5, 1.0, 0.3))};

  Eigen::VectorXd start_params() const {
    Eigen::VectorXd p(chain.dof_count());
    p << 0.3, -0.2;
    return p;
  }

  // Runs a solve expected to be rejected; the message must contain `needle`.
  void expect_invalid(const Chain& c, const std::vector<Goal>& g, const SolverOptions& o, Workspace& w,
                      Eigen::VectorXd params, const std::string& needle) {
    const Eigen::VectorXd before = params;
    const SolveResult r = solve(GetParam(), c, g, o, w, params);
    EXPECT_EQ(r.reason, TerminationReason::kInvalidInput) << to_string(r.reason);
    EXPECT_FALSE(r.usable());
    EXPECT_NE(std::string(r.message.c_str()).find(needle), std::string::npos)
        << "message: '" << r.message.c_str() << "' should name '" << needle << "'";
    ASSERT_EQ(params.size(), before.size());
    for (int i = 0; i < params.size(); ++i) {
      // Bitwise: NaN inputs must stay exactly as given too.
      EXPECT_TRUE(params[i] == before[i] || (std::isnan(params[i]) && std::isnan(before[i])));
    }
  }
};

TEST_P(SolveValidity, NonFiniteGoalPosition) {
  for (double bad : {kNaN, kInf, -kInf}) {
    std::vector<Goal> g{Goal::position(glm::dvec3(0.5, bad, 0.3))};
    expect_invalid(chain, g, options, ws, start_params(), "target_position");
  }
}

TEST_P(SolveValidity, NonFiniteOrientationAndAim) {
  std::vector<Goal> g{Goal::orientation(glm::dquat(kNaN, 0, 0, 0))};
  expect_invalid(chain, g, options, ws, start_params(), "target_orientation");
  std::vector<Goal> a{Goal::aim(glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0))};
  expect_invalid(chain, a, options, ws, start_params(), "aim_axis");
}

TEST_P(SolveValidity, ZeroJointsAndZeroLengthChain) {
  Chain empty;
  EXPECT_FALSE(ChainBuilder().build(empty).ok());
  expect_invalid(empty, goals, options, ws, start_params(), "chain is not built");

  ChainBuilder zero;
  zero.add_joint(JointDesc()).add_joint(JointDesc());  // every bone of length 0
  Chain zero_chain;
  EXPECT_NE(std::string(zero.build(zero_chain).message.c_str()).find("zero-length"), std::string::npos);
  expect_invalid(zero_chain, goals, options, ws, start_params(), "chain is not built");
}

TEST_P(SolveValidity, LimitsMinAboveMaxRejectedAtBuild) {
  ChainBuilder b;
  JointDesc j;
  j.type = JointType::kHinge;
  j.limits.has_hinge_limit = true;
  j.limits.hinge_min = 1.0;
  j.limits.hinge_max = -1.0;
  b.add_joint(j).set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  EXPECT_NE(std::string(b.build(c).message.c_str()).find("hinge_min"), std::string::npos);
  expect_invalid(c, goals, options, ws, start_params(), "chain is not built");
}

TEST_P(SolveValidity, BadOptionsNameTheField) {
  SolverOptions o;
  o.position_tolerance = -1;
  expect_invalid(chain, goals, o, ws, start_params(), "position_tolerance must be > 0, got -1");
  o = SolverOptions();
  o.max_iterations = 0;
  expect_invalid(chain, goals, o, ws, start_params(), "max_iterations");
  o = SolverOptions();
  o.orientation_tolerance = kNaN;
  expect_invalid(chain, goals, o, ws, start_params(), "orientation_tolerance");
  o = SolverOptions();
  o.bfgs_wolfe_c1 = 0.95;
  expect_invalid(chain, goals, o, ws, start_params(), "bfgs_wolfe_c1");
  o = SolverOptions();
  o.dls_max_damping = 1e-20;
  expect_invalid(chain, goals, o, ws, start_params(), "dls_max_damping");
}

TEST_P(SolveValidity, BadGoalsNameTheField) {
  std::vector<Goal> none;
  expect_invalid(chain, none, options, ws, start_params(), "at least one goal");
  std::vector<Goal> w{Goal::position(glm::dvec3(0, 1, 0), 0, 0.0)};
  expect_invalid(chain, w, options, ws, start_params(), "weight must be > 0");
  std::vector<Goal> e{Goal::position(glm::dvec3(0, 1, 0), 7)};
  expect_invalid(chain, e, options, ws, start_params(), "effector must be in 0..2, got 7");
}

TEST_P(SolveValidity, BadParamsAndWorkspace) {
  Eigen::VectorXd wrong_size(5);
  wrong_size.setZero();
  expect_invalid(chain, goals, options, ws, wrong_size, "params has 5 entries");
  Eigen::VectorXd nan_params = start_params();
  nan_params[1] = kNaN;
  expect_invalid(chain, goals, options, ws, nan_params, "NaN or inf");
  Workspace small(chain, 1);
  std::vector<Goal> two{goals[0], goals[0]};
  expect_invalid(chain, two, options, small, start_params(), "workspace was sized");
  const Chain other = test::make_hinge_chain(3);
  Eigen::VectorXd p3 = Eigen::VectorXd::Zero(3);
  expect_invalid(other, goals, options, ws, p3, "workspace was sized");
}

// A goal that is already met: converged with zero iterations and the pose untouched.
TEST_P(SolveValidity, AlreadyAtGoalReturnsConvergedUntouched) {
  Eigen::VectorXd p = start_params();
  std::vector<Goal> g{Goal::position(test::tip_of(chain, p))};
  const Eigen::VectorXd before = p;
  const SolveResult r = solve(GetParam(), chain, g, options, ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  EXPECT_TRUE(r.usable());
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(p, before);
  EXPECT_LE(r.final_error, options.position_tolerance);
  EXPECT_GE(r.elapsed_us, 0.0);
}

// A rejected solve allocates nothing either (the messages are fixed-size buffers).
TEST_P(SolveValidity, RejectionAllocatesNothing) {
  Eigen::VectorXd p = start_params();
  std::vector<Goal> g{Goal::position(glm::dvec3(kNaN, 0, 0))};
  solve(GetParam(), chain, g, options, ws, p);
  const std::size_t before = test::allocation_count();
  const SolveResult r = solve(GetParam(), chain, g, options, ws, p);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
}

// The errors a result reports are those of the start pose and of the returned params, measured
// by forward kinematics here, whichever of solve() or the solver measured them (DLS measures its
// own: solver_measures_start). Warm and rest starts, met and unmet goals, one and two goals.
TEST_P(SolveValidity, ReportedErrorsMatchForwardKinematics) {
  const bool two_goals_allowed = GetParam() != SolverKind::kTwoBone;
  const Chain c = two_goals_allowed ? test::make_ball_chain(4) : chain;
  Workspace w(c, 2);
  std::mt19937 rng(21);
  auto expect_errors = [&](const std::vector<Goal>& g, const Eigen::VectorXd& pose, double combined,
                           double position, double orientation, const char* which) {
    Workspace fk(c, 2);
    forward_kinematics(c, pose.data(), fk);
    const GoalErrors e = measure_goals(c, g, fk);
    const double scale = 1e-12 * (1.0 + e.combined);
    EXPECT_NEAR(combined, e.combined, scale) << which;
    EXPECT_NEAR(position, e.max_position, scale) << which;
    EXPECT_NEAR(orientation, e.max_orientation, scale) << which;
  };
  for (int trial = 0; trial < 6; ++trial) {
    SolverOptions o = options;
    o.warm_start = trial % 2 == 0;
    o.max_iterations = trial < 2 ? 1 : 100;  // stopped early (unmet) or run to convergence
    const Eigen::VectorXd start = test::random_params(c, rng, 1.0);
    std::vector<Goal> g{Goal::position(test::tip_of(c, test::random_params(c, rng)))};
    if (trial >= 4 && two_goals_allowed)
      g.push_back(Goal::orientation(glm::angleAxis(0.3, glm::dvec3(0, 0, 1)), 0, 0.5));
    Eigen::VectorXd p = start;
    const SolveResult r = solve(GetParam(), c, g, o, w, p);
    ASSERT_TRUE(r.usable()) << r.message.c_str();
    const Eigen::VectorXd expected_start = o.warm_start ? start : Eigen::VectorXd::Zero(c.dof_count());
    expect_errors(g, expected_start, r.initial_error, r.initial_position_error, r.initial_orientation_error,
                  "initial");
    expect_errors(g, p, r.final_error, r.final_position_error, r.final_orientation_error, "final");
  }
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, SolveValidity,
                         ::testing::Values(SolverKind::kTwoBone, SolverKind::kCCD, SolverKind::kJacobianPinv,
                                           SolverKind::kDLS, SolverKind::kBFGS, SolverKind::kFABRIK),
                         [](const ::testing::TestParamInfo<SolverKind>& info) {
                           return std::string(to_string(info.param));
                         });

TEST(Solve, UnknownSolverKindIsInvalidInput) {
  const Chain chain = test::make_hinge_chain(2);
  Workspace ws(chain, 1);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(2);
  std::vector<Goal> g{Goal::position(glm::dvec3(0.5, 1.0, 0.0))};
  const SolveResult r = solve(static_cast<SolverKind>(42), chain, g, SolverOptions(), ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("unknown"), std::string::npos);
  EXPECT_EQ(p, Eigen::VectorXd::Zero(2));
}

TEST(Solve, ReasonNamesAreStable) {
  // The Godot layer and scripts rely on these strings.
  EXPECT_STREQ(to_string(TerminationReason::kConverged), "converged");
  EXPECT_STREQ(to_string(TerminationReason::kMaxIterations), "max_iterations");
  EXPECT_STREQ(to_string(TerminationReason::kStalled), "stalled");
  EXPECT_STREQ(to_string(TerminationReason::kUnreachable), "unreachable");
  EXPECT_STREQ(to_string(TerminationReason::kInvalidInput), "invalid_input");
}

}  // namespace
}  // namespace ikchain
