// The solver table (solve.hpp): one row per SolverKind in enum order, ids equal to_string(), and
// every capability it claims (or denies) is what solve() does: a denied one is kInvalidInput with a
// message, a claimed one is accepted.
#include <string>

#include "joint_desc.hpp"  // bench/
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

Chain telescope() {
  ChainBuilder b;
  b.add_joint(JointDesc())
      .add_joint(bench::slide_joint(glm::dvec3(0, 1, 0), glm::dvec3(0, 1, 0), 0.0, 0.5))
      .set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

bool accepted(SolverKind kind, const Chain& c, const std::vector<Goal>& goals) {
  Workspace ws(c, static_cast<int>(goals.size()));
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
  const SolveResult r = test::run(kind, c, goals, SolverOptions(), ws, p);
  if (r.reason == TerminationReason::kInvalidInput) {
    EXPECT_FALSE(r.message.empty()) << to_string(kind);
  }
  return r.reason != TerminationReason::kInvalidInput;
}

TEST(SolverTable, OneRowPerKindInEnumOrder) {
  const Span<const SolverInfo> table = solver_table();
  ASSERT_EQ(table.size, kSolverKindCount);
  for (int k = 0; k < kSolverKindCount; ++k) {
    EXPECT_EQ(static_cast<int>(table[k].kind), k);
    EXPECT_EQ(std::string(table[k].id), to_string(static_cast<SolverKind>(k)));
    EXPECT_EQ(&solver_info(static_cast<SolverKind>(k)), &table[k]);
    EXPECT_GT(std::string(table[k].display_name).size(), 0u);
  }
}

TEST(SolverTable, CapabilitiesAreWhatSolveDoes) {
  const Chain two = test::make_ball_chain(2), three = test::make_ball_chain(3), slide = telescope();
  const Goal tip = Goal::position(glm::dvec3(0.5, 1.2, 0.3));
  const glm::dquat q = glm::angleAxis(0.4, glm::dvec3(1, 0, 0));
  for (const SolverInfo& info : solver_table()) {
    const Chain& c = info.joint_count == 2 ? two : three;
    EXPECT_TRUE(accepted(info.kind, c, {tip})) << info.id;
    if (info.joint_count == 2) {
      EXPECT_FALSE(accepted(info.kind, three, {tip})) << info.id;
    }
    EXPECT_EQ(accepted(info.kind, c, {tip, Goal::orientation(q)}), info.orientation_goals && info.several_goals)
        << info.id;
    EXPECT_EQ(accepted(info.kind, c, {Goal::aim_at(glm::dvec3(3, 0, 0), glm::dvec3(0, 1, 0))}), info.orientation_goals)
        << info.id;
    EXPECT_EQ(accepted(info.kind, c, {Goal::orientation(q, 1)}), info.intermediate_orientation_goals) << info.id;
    EXPECT_EQ(accepted(info.kind, c, {tip, Goal::position(glm::dvec3(0, 1, 0), 1)}), info.several_goals) << info.id;
    EXPECT_EQ(accepted(info.kind, slide, {tip}), info.prismatic_joints) << info.id;
  }
}

}  // namespace
}  // namespace ikchain
