// Cyclic coordinate descent (CCD).
//
// Sources: Wang & Chen, "A combined optimization method for solving the inverse kinematics problem
// of mechanical manipulators", IEEE Trans. Robotics and Automation 7(4), 1991 (the per-joint
// closed-form optimum for position and orientation targets); Kenwright, "Inverse kinematics - cyclic
// coordinate descent (CCD)", Journal of Graphics Tools 16(4), 2012 (tip-to-root sweeps, limits
// applied per joint).
//
// One iteration = one sweep over the joints from the tip to the root. Each joint in turn takes the
// rotation that best serves the goals of the effectors after it, every other joint held fixed:
//  - each goal becomes vector pairs (current a -> desired b, seen from the joint's origin):
//    a position goal the pair (effector - o_j -> target - o_j), weight w; an orientation goal the
//    three frame axes (Q e_i -> T e_i), weight w/2 each (sum_i |w x e_i|^2 = 2|w|^2, so this
//    matches the objective's 0.5 w |angle|^2 for small errors); an aim goal (aim axis -> aim
//    direction), weight w. The joint maximises sum_g w_g b_g . R a_g (Wang & Chen's objective).
//  - a ball joint with one pair (the usual single position goal) gets the minimal rotation turning
//    a onto b; with several pairs the optimal rotation is Horn's quaternion (Horn 1987, "Closed-
//    form solution of absolute orientation using unit quaternions": the top eigenvector of a 4x4
//    symmetric matrix), taking among equally good rotations the one closest to no rotation.
//  - a hinge gets the closed-form angle about its axis (geometric::HingeFit).
// The joint's limits are applied right after its update (project_joint_to_limits), and the
// effectors after it are moved by the rotation actually applied, so one sweep costs O(n * goals)
// without recomputing forward kinematics per joint.
//
// Multi-goal sets: every goal is served at once by the weighted per-joint optimum above (each
// joint only sees goals on effectors after it). Up to kMaxGoals goals; more are rejected.
//
// Two additions to the textbook loop:
//  - Out of reach (one tip position goal at least the chain's length away) the optimum is the
//    straight chain toward the target, which CCD approaches only slowly (the lecture's CCD stopped
//    at 3.37 for an optimum of 2). The first iteration therefore aims every bone at the target,
//    root to tip (geometric::aim_chain_at_points); later sweeps only refine it under limits.
//  - CCD's fixed points include saddles: a straight chain with the target straight ahead but closer
//    gives every joint a == b in direction, so no joint moves. A sweep that moves no joint while
//    the goals are not met curls every joint by Progress::kKickAngle (geometric::curl; at most Progress::kMaxKicks
//    times) and goes on.
// Termination: converged on tolerance; stalled after kStallIterations sweeps in a row that improve
// the cost by less than stall_tolerance (relative to the previous sweep's), or after a sweep that
// moved nothing (a fixed point); otherwise the iteration budget. The best pose seen is returned.
#include <cmath>

#include "core/kinematics.hpp"
#include "core/solvers/geometric_common.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {

namespace {

constexpr int kMaxGoals = kCcdMaxGoals;

// An effector a goal is attached to, tracked through the sweep.
struct Tracked {
  int effector = 0;  // 1..n
  glm::dvec3 position{0.0};
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0};
};

// Cyclic Jacobi eigen-decomposition of a symmetric 4x4 matrix, in place: on return a is diagonal
// (the eigenvalues) and the columns of v the eigenvectors. Golub & Van Loan, Matrix Computations,
// sec. 8.5 (cyclic Jacobi); quadratically convergent, a handful of sweeps at 4x4. Written out rather
// than Eigen::SelfAdjointEigenSolver, whose tridiagonalisation goes through dynamic-size blocks.
void jacobi_eigen4(double a[4][4], double v[4][4]) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v[r][c] = r == c ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 30; ++sweep) {
    double off = 0.0, total = 0.0;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        total += a[r][c] * a[r][c];
        if (r != c) off += a[r][c] * a[r][c];
      }
    if (off <= 1e-30 * total || off == 0.0) return;
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 4; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < 4; ++k) {  // A <- A J (columns p, q)
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 4; ++k) {  // A <- J^T A (rows p, q)
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 4; ++k) {  // V <- V J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
}

// Accumulates the vector pairs of one joint (see the file comment).
struct BallFit {
  int pairs = 0;
  glm::dvec3 first_a{0.0}, first_b{0.0};
  double m[3][3] = {{0.0}};  // sum w a b^T
  void add(const glm::dvec3& a, const glm::dvec3& b, double w) {
    if (pairs++ == 0) {
      first_a = a;
      first_b = b;
    }
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m[r][c] += w * a[r] * b[c];
  }
  glm::dquat rotation() const {
    if (pairs == 1) return geometric::rotation_between(first_a, first_b);
    // Horn 1987, eq. for N: rotation maximising sum w b . R a is N's top eigenvector (w, x, y, z).
    const double sxx = m[0][0], sxy = m[0][1], sxz = m[0][2];
    const double syx = m[1][0], syy = m[1][1], syz = m[1][2];
    const double szx = m[2][0], szy = m[2][1], szz = m[2][2];
    double a[4][4] = {{sxx + syy + szz, syz - szy, szx - sxz, sxy - syx},
                      {syz - szy, sxx - syy - szz, sxy + syx, szx + sxz},
                      {szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy},
                      {sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz}};
    double v[4][4];
    jacobi_eigen4(a, v);  // eigenvalues a[i][i], eigenvectors the columns of v
    double top = a[0][0], scale = 0.0;
    for (int i = 0; i < 4; ++i) {
      top = std::max(top, a[i][i]);
      scale = std::max(scale, std::abs(a[i][i]));
    }
    // Among rotations that are all optimal (degenerate top eigenvalue, e.g. pairs all parallel),
    // take the one closest to the identity: project (1, 0, 0, 0) on the top eigenspace.
    double q[4] = {0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < 4; ++i)
      if (a[i][i] >= top - 1e-9 * scale)
        for (int r = 0; r < 4; ++r) q[r] += v[r][i] * v[0][i];
    double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (norm < 1e-6) {
      for (int i = 0; i < 4; ++i)
        if (a[i][i] == top)
          for (int r = 0; r < 4; ++r) q[r] = v[r][i];
      norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    }
    if (!(norm > 0.0) || !std::isfinite(norm)) return geometric::kIdentity;
    for (double& x : q) x /= norm;
    return glm::dquat(q[0], q[1], q[2], q[3]);
  }
};

// Adds goal g's pairs seen from `origin` to a fit (BallFit or HingeFit through `add`).
template <typename AddPair>
void goal_pairs(const Goal& g, const Tracked& t, const glm::dvec3& origin, AddPair&& add) {
  switch (g.kind) {
    case GoalKind::kPosition:
      add(t.position - origin, g.target_position - origin, g.weight);
      break;
    case GoalKind::kOrientation: {
      const glm::dquat target = glm::normalize(g.target_orientation);
      for (int i = 0; i < 3; ++i) {
        glm::dvec3 e(0.0);
        e[i] = 1.0;
        add(t.orientation * e, target * e, 0.5 * g.weight);
      }
      break;
    }
    case GoalKind::kAim:
      add(glm::normalize(t.orientation * g.aim_axis), glm::normalize(g.aim_direction), g.weight);
      break;
  }
}

// One tip-to-root sweep. ws holds forward kinematics of params on entry (the origins and frames
// before joint j do not change while joints >= j move). Returns the largest rotation applied (rad).
double sweep(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
             Tracked* tracked, double* params) {
  const int n = chain.joint_count();
  for (int g = 0; g < goals.size; ++g) {
    tracked[g].effector = resolve_effector(chain, goals[g].effector);
    tracked[g].position = effector_position(chain, ws, goals[g].effector);
    tracked[g].orientation = effector_orientation(chain, ws, goals[g].effector);
  }
  double largest = 0.0;
  for (int j = n - 1; j >= 0; --j) {
    const glm::dvec3 origin = ws.joint_origins[j];
    const glm::dquat& pre = ws.joint_pre_rotations[j];
    glm::dquat applied = geometric::kIdentity;
    if (chain.joint_type(j) == JointType::kBall) {
      BallFit fit;
      for (int g = 0; g < goals.size; ++g)
        if (tracked[g].effector > j)
          goal_pairs(goals[g], tracked[g], origin,
                     [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(a, b, w); });
      if (fit.pairs == 0) continue;
      applied = geometric::turn_ball(chain, j, pre, fit.rotation(), options.max_step_angle, params);
      largest = std::max(largest, glm::length(so3::log(applied)));
    } else {
      const glm::dvec3 axis = geometric::hinge_axis_world(chain, j, pre);
      geometric::HingeFit fit;
      bool any = false;
      for (int g = 0; g < goals.size; ++g)
        if (tracked[g].effector > j) {
          any = true;
          goal_pairs(goals[g], tracked[g], origin,
                     [&](const glm::dvec3& a, const glm::dvec3& b, double w) { fit.add(axis, a, b, w); });
        }
      if (!any) continue;
      const double angle = geometric::turn_hinge(chain, j, fit.angle(), options.max_step_angle, params);
      applied = glm::angleAxis(angle, axis);
      largest = std::max(largest, std::abs(angle));
    }
    for (int g = 0; g < goals.size; ++g) {
      if (tracked[g].effector <= j) continue;
      tracked[g].position = origin + applied * (tracked[g].position - origin);
      tracked[g].orientation = glm::normalize(applied * tracked[g].orientation);
    }
  }
  return largest;
}

}  // namespace

SolverStatus solve_ccd(const Chain& chain, Span<const Goal> goals, const SolverOptions& options, Workspace& ws,
                       double* params) {
  SolverStatus status;
  if (goals.size > kMaxGoals) {
    status.reason = TerminationReason::kInvalidInput;
    status.message = Message::format("ccd supports at most %d goals, got %d", kMaxGoals, goals.size);
    return status;
  }
  Tracked tracked[kMaxGoals];
  const int n = chain.joint_count();
  // One tip position goal at or beyond full reach: straighten toward it first (see above).
  geometric::Progress progress(chain, goals, options, ws, params, geometric::kStallIterations);
  status.reason = TerminationReason::kMaxIterations;
  while (status.iterations < options.max_iterations) {
    double moved = INFINITY;
    if (status.iterations == 0 && progress.out_of_reach()) {
      for (int k = 1; k <= n; ++k) ws.points_b[k] = goals[0].target_position;
      geometric::aim_chain_at_points(chain, ws, ws.points_b.data(), options.max_step_angle, params);
    } else {
      moved = sweep(chain, goals, options, ws, tracked, params);
    }
    ++status.iterations;
    if (progress.stop_after_iteration(params, moved, status.reason)) break;
  }
  progress.finish(status.reason, params);
  return status;
}

}  // namespace ikchain
