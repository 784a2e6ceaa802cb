// Analytic two-bone IK (src/core/solvers/two_bone.cpp): exact round trips, pole alignment, out of
// reach, too close, zero-length bone, hinge elbow limits, input rules, no allocation.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/so3.hpp"
#include "humanoid.hpp"
#include "solver_test_util.hpp"

namespace ikchain {
namespace {

constexpr SolverKind kKind = SolverKind::kTwoBone;

// A shoulder (ball, with a rest rotation and an offset from the base) and an elbow (ball or a
// hinge about its local x), upper arm l1 and forearm l2 along +Y.
Chain arm(bool hinge_elbow, double l1 = 1.2, double l2 = 0.9, bool limit_elbow = false) {
  ChainBuilder b;
  JointDesc shoulder;
  shoulder.offset_translation = glm::dvec3(0.3, 1.5, -0.2);
  shoulder.rest_rotation = glm::angleAxis(0.4, glm::normalize(glm::dvec3(1, 0, 1)));
  b.add_joint(shoulder);
  JointDesc elbow;
  elbow.type = hinge_elbow ? JointType::kHinge : JointType::kBall;
  elbow.offset_translation = glm::dvec3(0, l1, 0);
  elbow.axis = glm::dvec3(1, 0, 0);
  elbow.limits.has_hinge_limit = limit_elbow;
  elbow.limits.hinge_min = 0.0;
  elbow.limits.hinge_max = 1.5;
  b.add_joint(elbow);
  b.set_tip_offset(glm::dvec3(0, l2, 0));
  Chain c;
  EXPECT_TRUE(b.build(c).ok());
  return c;
}

SolverOptions exact_options(const Chain& c) {
  SolverOptions o;
  o.position_tolerance = 1e-10 * c.total_length();
  return o;
}

TEST(TwoBone, ExactOnRandomReachableTargets) {
  std::mt19937 rng(1);
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    const SolverOptions o = exact_options(c);
    for (int t = 0; t < 1000; ++t) {
      const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
      // Alternate rest and random starts.
      Eigen::VectorXd p = (t % 2) ? test::random_params(c, rng) : Eigen::VectorXd::Zero(c.dof_count());
      const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
      EXPECT_LE(glm::length(test::tip_of(c, p) - g.target_position), 1e-12 * c.total_length());
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
      EXPECT_LE(r.iterations, 1);
    }
  }
}

// The elbow lies in the plane root-target-pole, on the pole's side.
TEST(TwoBone, PoleTargetAlignment) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    SolverOptions o = exact_options(c);
    o.use_pole = true;
    for (int t = 0; t < 300; ++t) {
      const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
      const glm::dvec3 root = c.root_in_base();
      const glm::dvec3 pole = root + 3.0 * glm::dvec3(u(rng), u(rng), u(rng));
      o.pole_in_base = pole;
      Eigen::VectorXd p = test::random_params(c, rng);
      const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
      EXPECT_EQ(r.reason, TerminationReason::kConverged);
      forward_kinematics(c, p.data(), ws);
      const glm::dvec3 dir = glm::normalize(g.target_position - root);
      const glm::dvec3 elbow = ws.joint_origins[1] - root;
      const glm::dvec3 pole_perp = (pole - root) - dir * glm::dot(pole - root, dir);
      if (glm::length(pole_perp) < 1e-3) continue;  // pole on the line: no plane to align with
      const glm::dvec3 normal = glm::normalize(glm::cross(dir, pole_perp));
      EXPECT_NEAR(glm::dot(elbow, normal), 0.0, 1e-9);
      const double elbow_off_line = glm::length(elbow - dir * glm::dot(elbow, dir));
      if (elbow_off_line > 1e-6) {
        EXPECT_GT(glm::dot(elbow, glm::normalize(pole_perp)), 0.0);
      }
    }
  }
}

TEST(TwoBone, OutOfReachEndsStraightTowardTheTarget) {
  for (bool hinge : {false, true}) {
    const Chain c = arm(hinge);
    Workspace ws(c, 1);
    const double L = c.total_length();
    const glm::dvec3 dir = glm::normalize(glm::dvec3(0.3, -0.5, 0.81));
    Eigen::VectorXd p = Eigen::VectorXd::Constant(c.dof_count(), 0.4);  // bent start
    // Analytic: exact to 1e-12 L, where the iterative solvers are held to 1e-6 L.
    test::expect_ends_two_beyond_reach(kKind, c, dir, exact_options(c), ws, p, 1e-12);
    forward_kinematics(c, p.data(), ws);
    EXPECT_NEAR(glm::length(ws.joint_origins[1] - c.root_in_base()) + glm::length(ws.tip - ws.joint_origins[1]),
                glm::length(ws.tip - c.root_in_base()), 1e-12 * L);  // straight
  }
}

// |target - root| < |l1 - l2|: folded as far as possible, |l1 - l2| from the root toward the target.
TEST(TwoBone, TooCloseFoldsTowardTheTarget) {
  for (double l2 : {0.4, 1.7}) {
    const Chain c = arm(false, 1.0, l2);
    Workspace ws(c, 1);
    const glm::dvec3 dir = glm::normalize(glm::dvec3(1, 2, -0.5));
    const Goal g = Goal::position(c.root_in_base() + 0.3 * dir);
    Eigen::VectorXd p = Eigen::VectorXd::Constant(c.dof_count(), 0.2);
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    const glm::dvec3 tip = test::tip_of(c, p);
    EXPECT_NEAR(glm::length(tip - g.target_position), std::abs(1.0 - l2) - 0.3, 1e-12);
    EXPECT_NEAR(glm::dot(glm::normalize(tip - c.root_in_base()), dir), 1.0, 1e-12);
    EXPECT_EQ(r.reason, TerminationReason::kUnreachable);
  }
}

// A target exactly on the root with l1 == l2: the tip folds onto the root; no NaN.
TEST(TwoBone, TargetOnRootAndStraightStart) {
  const Chain c = arm(false, 1.0, 1.0);
  Workspace ws(c, 1);
  const Goal g = Goal::position(c.root_in_base());
  Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());  // straight
  const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
  EXPECT_TRUE(p.allFinite());
  EXPECT_EQ(r.reason, TerminationReason::kConverged);
  // Straight chain, target straight ahead but closer: bends and reaches it.
  forward_kinematics(c, Eigen::VectorXd::Zero(c.dof_count()).eval().data(), ws);
  const Goal ahead = Goal::position(c.root_in_base() + 0.5 * (ws.tip - c.root_in_base()));
  p.setZero();
  EXPECT_EQ(solve(kKind, c, Span<const Goal>(&ahead, 1), exact_options(c), ws, p).reason,
            TerminationReason::kConverged);
}

TEST(TwoBone, ZeroLengthBoneChain) {
  ChainBuilder b;
  JointDesc j;
  b.add_joint(j).add_joint(j);  // elbow at the shoulder: l1 = 0
  b.set_tip_offset(glm::dvec3(0, 1, 0));
  Chain c;
  ASSERT_TRUE(b.build(c).ok());
  Workspace ws(c, 1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 50; ++t) {
    const glm::dvec3 target(u(rng), u(rng), u(rng));
    const Goal g = Goal::position(target);
    Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());
    solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    EXPECT_TRUE(p.allFinite());
    // The tip can only be on the unit sphere: the closest point toward the target.
    EXPECT_NEAR(glm::length(test::tip_of(c, p) - target), std::abs(glm::length(target) - 1.0), 1e-12);
  }
}

// A hinge elbow limited to [0, 1.5]: never violated; targets made from feasible angles reached.
TEST(TwoBone, HingeElbowLimitsRespected) {
  const Chain c = arm(true, 1.2, 0.9, true);
  Workspace ws(c, 1);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 300; ++t) {
    const Goal g = Goal::position(test::tip_of(c, test::random_params(c, rng)));
    Eigen::VectorXd p = test::random_params(c, rng);
    const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), exact_options(c), ws, p);
    EXPECT_TRUE(within_limits(c, p.data()));
    EXPECT_EQ(r.reason, TerminationReason::kConverged);
    // Anywhere, including targets needing a bend beyond the limit: within limits, honest reason.
    const Goal any = Goal::position(c.root_in_base() + 2.0 * glm::dvec3(u(rng), u(rng), u(rng)));
    const SolveResult ra = solve(kKind, c, Span<const Goal>(&any, 1), exact_options(c), ws, p);
    EXPECT_TRUE(within_limits(c, p.data()));
    EXPECT_NEAR(ra.final_position_error, glm::length(test::tip_of(c, p) - any.target_position), 1e-12);
    if (ra.reason == TerminationReason::kConverged) {
      EXPECT_LE(ra.final_position_error, 1e-10 * c.total_length());
    }
  }
}

TEST(TwoBone, RejectsWrongJointCountAndGoals) {
  Workspace ws;
  const Chain three = test::make_ball_chain(3);
  ws.reset(three, 2);
  Eigen::VectorXd p = Eigen::VectorXd::Constant(three.dof_count(), 0.1);
  const Eigen::VectorXd before = p;
  const Goal g = Goal::position(glm::dvec3(0, 1, 1));
  SolveResult r = solve(kKind, three, Span<const Goal>(&g, 1), SolverOptions(), ws, p);
  EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
  EXPECT_NE(std::string(r.message.c_str()).find("exactly 2 joints"), std::string::npos);
  EXPECT_EQ(p, before);

  const Chain c = arm(false);
  ws.reset(c, 2);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(c.dof_count(), 0.1);
  const Eigen::VectorXd q0 = q;
  const std::vector<std::vector<Goal>> bad = {
      {Goal::position(glm::dvec3(0, 1, 1)), Goal::position(glm::dvec3(0, 2, 1))},
      {Goal::orientation(glm::angleAxis(0.3, glm::dvec3(0, 0, 1)))},
      {Goal::position(glm::dvec3(0, 1, 1), 1)}};  // the elbow
  for (const std::vector<Goal>& goals : bad) {
    r = solve(kKind, c, goals, SolverOptions(), ws, q);
    EXPECT_EQ(r.reason, TerminationReason::kInvalidInput);
    EXPECT_NE(std::string(r.message.c_str()).find("position goal on the tip"), std::string::npos);
    EXPECT_EQ(q, q0);
  }
}

// ---------------------------------------------------------------------------------------------
// Issue 16, item 17: a pole on Godot's SkeletonProfileHumanoid (T-pose rests, arms from the upper
// arm, legs from the upper leg). The limb starts straight, so the elbow has no bend plane of its
// own; on b0e1161 the ball elbow bent toward the pole, which put the elbow on the far side of the
// root-tip line, and the root then turned the whole limb 180 deg about that line: joint positions
// right, knee cap and elbow point facing away from the pole, the upper bone twisted 180 deg.

struct HumanoidLimb {
  const char* upper;
  const char* lower;
  const char* end;
};
constexpr HumanoidLimb kHumanoidLimbs[] = {{"LeftUpperLeg", "LeftLowerLeg", "LeftFoot"},
                                           {"RightUpperLeg", "RightLowerLeg", "RightFoot"},
                                           {"LeftUpperArm", "LeftLowerArm", "LeftHand"},
                                           {"RightUpperArm", "RightLowerArm", "RightHand"}};

// How well the knee or elbow bends the anatomical way, as cosines: the bend plane's normal
// (u x v, u = the upper bone, v = the lower one) against the lower bone's +X, about which the
// humanoid's knees and elbows bend with a positive angle, and against the same axis as the upper
// bone carries it (its rest +X of the lower bone). Both are about 1 for a limb bent the anatomical
// way and about -1 when the upper bone is twisted 180 deg about the limb (the same joint positions,
// knee cap or elbow point turned away from the pole). Nothing to measure on a straight limb.
struct BendAlignment {
  double upper = 1.0, lower = 1.0;
};
BendAlignment bend_alignment(const Chain& c, const Workspace& ws) {
  const glm::dvec3 u = ws.joint_origins[1] - ws.joint_origins[0], v = ws.tip - ws.joint_origins[1];
  const glm::dvec3 normal = glm::cross(u, v);
  if (glm::length(normal) < 1e-6 * glm::length(u) * glm::length(v)) return {};
  const glm::dvec3 n = glm::normalize(normal), x(1, 0, 0);
  return {glm::dot(ws.joint_orientations[0] * (c.rest_rotation(1) * x), n), glm::dot(ws.joint_orientations[1] * x, n)};
}

constexpr double kDegree = so3::kPi / 180.0;

// The angle of the rotation taking q onto r (rad).
double rotation_angle_between(const glm::dquat& q, const glm::dquat& r) {
  return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(q, r))));
}

// The unit direction from the root-target line toward the pole.
glm::dvec3 pole_side(const glm::dvec3& root, const glm::dvec3& target, const glm::dvec3& pole) {
  const glm::dvec3 dir = glm::normalize(target - root);
  const glm::dvec3 off = (pole - root) - dir * glm::dot(pole - root, dir);
  return glm::normalize(off);
}

// Sampled natural poses (the upper bone swung up to 70 deg and twisted up to 30 deg from its rest,
// the knee or elbow bent 0.3-2.2 rad about +X), solved from the T-pose with the pole in front of
// the sampled knee: the tip reaches, and both bones' cap sides face the pole.
TEST(TwoBone, Item17HumanoidPoleKeepsKneeCapAndElbowFacingThePole) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0), bend(0.3, 2.2);
  for (const HumanoidLimb& limb : kHumanoidLimbs) {
    for (bool hinge : {false, true}) {
      const Chain c = test::humanoid::chain({limb.upper, limb.lower}, limb.end, hinge);
      Workspace ws(c, 1);
      SolverOptions o = exact_options(c);
      o.use_pole = true;
      double worst_upper = 1.0, worst_lower = 1.0;
      for (int t = 0; t < 200; ++t) {
        // The sampled pose: a swing (rotation vector perpendicular to the bone, +Y) and a twist.
        Eigen::VectorXd truth = Eigen::VectorXd::Zero(c.dof_count());
        const glm::dvec3 swing = glm::dvec3(u(rng), 0.0, u(rng));
        const glm::dvec3 rv = (70.0 * so3::kPi / 180.0) * std::abs(u(rng)) * glm::normalize(swing) +
                              glm::dvec3(0.0, (30.0 * so3::kPi / 180.0) * u(rng), 0.0);
        truth[0] = rv.x, truth[1] = rv.y, truth[2] = rv.z;
        if (hinge) {
          truth[3] = bend(rng);
        } else {
          truth[3] = bend(rng), truth[4] = 0.0, truth[5] = 0.0;
        }
        forward_kinematics(c, truth.data(), ws);
        const glm::dvec3 root = ws.joint_origins[0], knee = ws.joint_origins[1];
        const Goal g = Goal::position(ws.tip);
        o.pole_in_base = knee + 0.5 * pole_side(root, ws.tip, knee);

        Eigen::VectorXd p = Eigen::VectorXd::Zero(c.dof_count());  // the T-pose: a straight limb
        const SolveResult r = solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
        EXPECT_EQ(r.reason, TerminationReason::kConverged);
        forward_kinematics(c, p.data(), ws);
        EXPECT_LE(glm::length(ws.tip - g.target_position), 1e-9 * c.total_length());
        EXPECT_LE(glm::length(ws.joint_origins[1] - knee), 1e-9 * c.total_length());  // positions right
        const BendAlignment bent = bend_alignment(c, ws);
        worst_upper = std::min(worst_upper, bent.upper);
        worst_lower = std::min(worst_lower, bent.lower);
      }
      // Measured: a hinge elbow bends exactly the anatomical way (worst cosines 1.000); a ball elbow
      // has no axis of its own, and its bend plane follows the pole (worst 0.47-0.54, where
      // b0e1161 gave -0.91 to -1.00 on every limb: the 180 deg twist).
      const double least = hinge ? 0.99 : 0.3;
      EXPECT_GT(worst_upper, least) << limb.upper << (hinge ? " hinge" : " ball");
      EXPECT_GT(worst_lower, least) << limb.lower << (hinge ? " hinge" : " ball");
    }
  }
}

// A fixed pole while the target moves smoothly from the T-pose (100 runs of 120 frames, warm
// start): the first frame, which bends the straight limb to 0.85 of its length, turns each bone by
// the ~32 deg that takes (on b0e1161: 180 deg about the limb, the upper bone twisted, for the ball
// elbow); no later frame turns a bone by more than a few times the target's own turn seen from the
// root; the knee or elbow bends the anatomical way throughout.
TEST(TwoBone, Item17HumanoidFixedPoleTracksWithoutAFlip) {
  std::mt19937 rng(170);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const HumanoidLimb& limb : kHumanoidLimbs) {
    for (bool hinge : {false, true}) {
      const Chain c = test::humanoid::chain({limb.upper, limb.lower}, limb.end, hinge);
      Workspace ws(c, 1);
      SolverOptions o = exact_options(c);
      o.use_pole = true;
      Eigen::VectorXd rest = Eigen::VectorXd::Zero(c.dof_count());
      forward_kinematics(c, rest.data(), ws);
      const glm::dvec3 root = ws.joint_origins[0], tip0 = ws.tip;
      const double L = c.total_length();
      // The pole in front of the knee cap / behind the elbow point as the rest pose shows it (the
      // lower bone's local -Z: its +X bends it toward +Z).
      o.pole_in_base = ws.joint_origins[1] + L * (ws.joint_orientations[1] * glm::dvec3(0, 0, -1));
      double worst_first = 0.0, worst_later = 0.0, worst_target_step = 0.0, worst_bend = 1.0;
      for (int run = 0; run < 100; ++run) {
        const glm::dvec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
        Eigen::VectorXd p = rest;
        forward_kinematics(c, p.data(), ws);
        glm::dquat last0 = ws.joint_orientations[0], last1 = ws.joint_orientations[1];
        glm::dvec3 last_target = tip0;
        for (int f = 1; f <= 120; ++f) {
          // 0.15 L toward the root, then 0.15-0.4 L, wandering up to 0.3 L sideways.
          const double s = (f - 1) / 119.0;
          const glm::dvec3 pull = (root - tip0) * (0.15 + 0.25 * std::sin(0.5 * so3::kPi * s));
          const glm::dvec3 target =
              tip0 + pull + 0.15 * L * (std::sin(2.0 * so3::kPi * s) * a + (1.0 - std::cos(2.0 * so3::kPi * s)) * b);
          const Goal g = Goal::position(target);
          solve(kKind, c, Span<const Goal>(&g, 1), o, ws, p);
          forward_kinematics(c, p.data(), ws);
          const double turn = std::max(rotation_angle_between(last0, ws.joint_orientations[0]),
                                       rotation_angle_between(last1, ws.joint_orientations[1]));
          if (f == 1) {
            worst_first = std::max(worst_first, turn);
          } else {
            worst_later = std::max(worst_later, turn);
            worst_target_step = std::max(worst_target_step, glm::length(target - last_target) / L);
          }
          const BendAlignment bent = bend_alignment(c, ws);
          worst_bend = std::min({worst_bend, bent.upper, bent.lower});
          last0 = ws.joint_orientations[0], last1 = ws.joint_orientations[1];
          last_target = target;
        }
      }
      // Measured: first 31.8 deg, later <= 7.1 deg with the target moving <= 0.017 L a frame, worst
      // bend cosine >= 0.99; b0e1161: first frame 180 deg (ball elbow), bend cosines -1.
      EXPECT_LT(worst_first, 40.0 * kDegree) << limb.upper << (hinge ? " hinge" : " ball");
      EXPECT_LT(worst_target_step, 0.02);  // the premise: a smooth target
      EXPECT_LT(worst_later, 10.0 * kDegree) << limb.upper << (hinge ? " hinge" : " ball");
      EXPECT_GT(worst_bend, 0.0) << limb.upper << (hinge ? " hinge" : " ball");
    }
  }
}

TEST(TwoBone, DeterministicAndAllocatesNothing) {
  const Chain c = arm(true);
  Workspace ws(c, 1);
  SolverOptions o = exact_options(c);
  o.warm_start = false;
  const Goal g = Goal::position(c.root_in_base() + glm::dvec3(0.5, 0.8, 0.9));
  std::mt19937 rng(5);
  Eigen::VectorXd a = test::random_params(c, rng), b = test::random_params(c, rng);
  solve(kKind, c, Span<const Goal>(&g, 1), o, ws, a);
  const std::size_t before = test::allocation_count();
  solve(kKind, c, Span<const Goal>(&g, 1), o, ws, b);
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace ikchain
