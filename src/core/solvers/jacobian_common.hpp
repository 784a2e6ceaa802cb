// Shared machinery of the Jacobian-family solvers (jacobian_pinv.cpp, dls.cpp): the least-squares
// "models" they step on, and the small dense linear algebra both need.
//
// A model owns the problem's shape: it evaluates the weighted residual e (desired - current) of a
// pose, linearises at the accepted pose (J = d current / d params) and turns the linearisation
// into steps. Both solvers work with the SVD of J through the eigen-decomposition of its small
// Gram matrix (J J^T when there are fewer residual rows m than DOFs n, J^T J otherwise):
//   J J^T = V diag(lambda) V^T,   t = V^T e,
//   pseudo-inverse step   h = J^T V diag(f) t,  f_i = 1/lambda_i (0 below the singular threshold)
//   damped step (DLS/LM)  h = J^T V diag(f) t,  f_i = 1/(lambda_i + mu)
// (Golub & Van Loan, "Matrix Computations", 4th ed., sec. 5.5.4 for the pseudo-inverse, sec. 8.5.2
// for the cyclic Jacobi eigenvalue method used here, core/math/linalg.hpp; Buss, "Introduction to Inverse Kinematics with
// Jacobian Transpose, Pseudoinverse and Damped Least Squares methods" (2004), sec. 4-5.)
//
// Two models with the same interface:
//  - SinglePositionModel: one position goal, the common case and the benchmark's. FK, Jacobian and
//    the 3x3 J J^T are fused into two O(n) passes over the chain, with fixed-size 3x3 algebra; no
//    n x n matrix and nothing dynamic. Tested to agree with GoalModel (jacobian_pinv_test.cpp).
//  - GoalModel: any goals, through the generic kinematics.hpp machinery and workspace buffers.
// Neither allocates: every buffer is the workspace's (see the buffer map at GoalModel).
#pragma once
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "core/kinematics_internal.hpp"
#include "core/math/linalg.hpp"
#include "core/quat_ops.hpp"
#include "ikchain/so3.hpp"
#include "core/solvers/solvers.hpp"

namespace ikchain {
namespace jacobian {

// The small dense algebra (Jacobi eigen-decomposition, the 3x3 LDL^T solve) is core/math/linalg.hpp's.
using linalg::jacobi_eigen;
using linalg::solve_spd3;

// Gram eigenvalues below this are rank deficiency. Forming J J^T squares J's condition number, so
// its eigenvalues carry absolute rounding noise ~ eps * lambda_max: a singular value cannot be
// resolved below sqrt(noise), whatever pinv_singular_threshold asks for.
inline double gram_rank_floor(double singular_threshold, double lambda_max) {
  return std::max(singular_threshold * singular_threshold, 1e-13 * lambda_max);
}

// Pseudo-inverse filter factor for one Gram eigenvalue.
inline double pinv_factor(double lambda, double floor) { return lambda > floor ? 1.0 / lambda : 0.0; }

// Number of leading params that move any of the goals' effectors (joints before the farthest
// effector); the rest are left alone by every step and by the escapes (stuck.hpp).
inline int active_dof_count(const Chain& chain, Span<const Goal> goals) {
  int k = 0;
  for (int i = 0; i < goals.size; ++i) k = std::max(k, resolve_effector(chain, goals[i].effector));
  return k >= chain.joint_count() ? chain.dof_count() : chain.dof_offset(k);
}

// Scalar quaternion arithmetic shared with forward_kinematics (core/quat_ops.hpp).
using namespace quat_ops;

// ------------------------------------------------------------------------------------------------
// One position goal: fused FK + Jacobian + 3x3 Gram matrix, O(n) per iteration.
class SinglePositionModel {
 public:
  SinglePositionModel(const Chain& chain, const Goal& goal, Workspace& ws)
      : chain_(chain),
        ws_(ws),
        effector_(resolve_effector(chain, goal.effector)),
        active_dofs_(effector_ >= chain.joint_count() ? chain.dof_count() : chain.dof_offset(effector_)),
        target_(goal.target_position),
        sqrt_weight_(std::sqrt(goal.weight)) {
    for (int i = 0; i < effector_; ++i) all_hinges_ = all_hinges_ && chain.joint_type(i) == JointType::kHinge;
  }

  int active_dofs() const { return active_dofs_; }
  // The second-order correction's formula is exact for hinges only; measured on ball chains it
  // costs iterations, so it is used only when every joint moving the effector is a hinge.
  bool has_acceleration() const { return all_hinges_; }

  // Forward kinematics of joints 0..effector-1: joint origins and base-frame DOF axes into the
  // workspace's trial buffers (the same values forward_kinematics + compute_dof_axes give), the
  // weighted residual into the trial slot; accept() makes them the current pose's. Returns the
  // cost 0.5 * w * |target - effector|^2.
  double evaluate(const double* params) {
    glm::dvec3* const joint_origins = ws_.trial_joint_origins.data();
    glm::dvec3* const dof_axes = ws_.trial_dof_axes.data();
    // Plain scalar quaternion arithmetic: about half the instructions of the glm expressions.
    Quat q{1.0, 0.0, 0.0, 0.0};  // orientation Q_{i-1}
    glm::dvec3 origin(0.0);
    for (int i = 0; i < effector_; ++i) {
      origin += rotate_coded(q, chain_.offset_translation(i), Direction(chain_.offset_direction(i)));
      // Identity rest rotations (most rigs' hinge chains) skip a quaternion product.
      const Quat pre = chain_.rest_is_identity(i) ? q : multiply(q, from_glm(chain_.rest_rotation(i)));
      const int o = chain_.dof_offset(i);
      if (chain_.joint_type(i) == JointType::kHinge) {
        const glm::dvec3& axis = chain_.axis(i);
        const Direction dir = Direction(chain_.axis_direction(i));
        double s, c;
        so3::fast_sincos(0.5 * params[o], s, c);
        q = multiply_axis_angle(pre, axis, dir, c, s);
        dof_axes[o] = rotate_coded(pre, axis, dir);
      } else if (chain_.joint_type(i) == JointType::kPrismatic) {  // as forward_kinematics
        q = pre;
        dof_axes[o] = rotate(pre, chain_.axis(i));
        joint_origins[i] = origin;
        origin += dof_axes[o] * params[o];
        continue;
      } else {
        const glm::dvec3 r(params[o], params[o + 1], params[o + 2]);
        q = multiply(pre, from_glm(so3::exp(r)));
        const glm::dmat3 jl = so3::left_jacobian(r);
        for (int d = 0; d < 3; ++d) dof_axes[o + d] = rotate(pre, jl[d]);
      }
      // No per-joint renormalisation (as in forward_kinematics): products of unit quaternions
      // drift by ~1e-16 per joint, far below any tolerance even at 100 joints.
      joint_origins[i] = origin;
    }
    ws_.deadline.charge(Deadline::kFlopsPerJoint * effector_);
    if (effector_ < chain_.joint_count())
      effector_trial_ = origin + rotate_coded(q, chain_.offset_translation(effector_),
                                              Direction(chain_.offset_direction(effector_)));
    else
      effector_trial_ = origin + rotate_coded(q, chain_.tip_offset(), Direction(chain_.tip_direction()));
    return trial_residual();
  }

  // evaluate() for the start pose: at the rest pose (every param 0, a deterministic start) the
  // frames are the chain's, computed at build (Chain::rest_joint_origins), and only copied.
  double evaluate_start(const double* params) {
    for (int j = 0; j < chain_.dof_count(); ++j)
      if (params[j] != 0.0) return evaluate(params);
    std::copy(chain_.rest_joint_origins().begin(), chain_.rest_joint_origins().begin() + effector_,
              ws_.trial_joint_origins.begin());
    std::copy(chain_.rest_dof_axes().begin(), chain_.rest_dof_axes().begin() + active_dofs_,
              ws_.trial_dof_axes.begin());
    effector_trial_ = effector_ < chain_.joint_count() ? chain_.rest_joint_origins()[effector_] : chain_.rest_tip();
    return trial_residual();
  }

  // The last evaluate()d pose becomes the current one (its frames swap in: pointers, no copy).
  void accept() {
    ws_.joint_origins.swap(ws_.trial_joint_origins);
    ws_.dof_axes.swap(ws_.trial_dof_axes);
    e_ = e_trial_;
    effector_position_ = effector_trial_;
    distance_ = std::sqrt(2.0 * cost_trial_) / sqrt_weight_;
    cost_ = cost_trial_;
  }
  double cost() const { return cost_; }
  GoalErrors errors() const {
    GoalErrors out;
    out.cost = cost_;
    out.combined = std::sqrt(2.0 * cost_);
    out.max_position = distance_;
    return out;
  }
  bool converged(const SolverOptions& o) const { return distance_ <= o.position_tolerance; }
  double residual_norm() const { return e_.norm(); }

  // J at the accepted pose (trials evaluated since leave it alone): column j =
  // sqrt(w) * axis_j x (effector - o_joint(j)), stored in the top 3 rows of ws.jacobian, and the
  // Gram matrix J J^T (3x3) accumulated in the same pass.
  void linearize(const double* /*params*/) {
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
    double* col = ws_.jacobian.data();
    const Eigen::Index stride = ws_.jacobian.rows();
    const glm::dvec3* origins = ws_.joint_origins.data();
    const glm::dvec3* axes = ws_.dof_axes.data();
    // Column `dof` = c into J, and its outer product into J J^T.
    auto store = [&](int dof, const glm::dvec3& c) {
      double* cj = col + stride * dof;
      cj[0] = c.x;
      cj[1] = c.y;
      cj[2] = c.z;
      a00 += c.x * c.x;
      a01 += c.x * c.y;
      a02 += c.x * c.z;
      a11 += c.y * c.y;
      a12 += c.y * c.z;
      a22 += c.z * c.z;
    };
    auto column = [&](int dof, const glm::dvec3& arm) { store(dof, glm::cross(axes[dof], arm)); };
    // A slide moves the effector along its axis: column sqrt(w) * axis.
    auto slide_column = [&](int dof) { store(dof, axes[dof] * sqrt_weight_); };
    if (all_hinges_) {  // DOF i is joint i: no per-joint lookups
      for (int i = 0; i < effector_; ++i) column(i, (effector_position_ - origins[i]) * sqrt_weight_);
    } else {
      for (int i = 0; i < effector_; ++i) {
        const glm::dvec3 arm = (effector_position_ - origins[i]) * sqrt_weight_;
        const int o = chain_.dof_offset(i);
        if (!turns(chain_.joint_type(i))) {
          slide_column(o);
          continue;
        }
        const int cnt = chain_.dof_count_of(i);
        for (int d = 0; d < cnt; ++d) column(o + d, arm);
      }
    }
    gram_ << a00, a01, a02, a01, a11, a12, a02, a12, a22;
    ws_.deadline.charge(Deadline::kFlopsPerJacobianEntry * 3.0 * active_dofs_);
    decomposed_ = false;
  }

  // Active set (see limit_aware_step): DOF `dof` leaves J (its column is zeroed) until the next
  // linearize(); refactor() then rebuilds J J^T from the remaining columns.
  void freeze(int dof) { ws_.jacobian.col(dof).head(3).setZero(); }
  // The same for one direction of a ball joint's DOFs o..o+2 (a cone or twist limit's normal).
  void freeze_direction(int o, const glm::dvec3& normal) { remove_ball_direction(ws_.jacobian, 3, o, normal); }
  void refactor() {
    const auto J = ws_.jacobian.topLeftCorner(3, active_dofs_);
    gram_.noalias() = J * J.transpose();
    decomposed_ = false;
  }

  // |J^T e|^2 = e^T (J J^T) e: zero at a stationary point (e.g. a straight chain pulled along itself).
  double gradient_norm2() const { return e_.dot(gram_ * e_); }
  // sqrt(trace(J J^T)) = |J|_F, the scale gradient_norm2 is judged against.
  double jacobian_norm() const { return std::sqrt(std::max(gram_.trace(), 0.0)); }

  // Damped least squares step h = J^T (J J^T + mu I)^-1 e into step[0..active). Returns the
  // decrease of the linear model, 0.5 (|e|^2 - |e - J h|^2) = 0.5 (|e|^2 - mu^2 |y|^2).
  double damped_step(double mu, double* step) {
    Eigen::Matrix3d m = gram_;
    m.diagonal().array() += mu;
    const Eigen::Vector3d y = solve_spd3(m, e_);
    apply_transpose(y, step);
    damped_ = m;
    return 0.5 * (e_.squaredNorm() - mu * mu * y.squaredNorm());
  }

  // The effector's second derivative along a joint-space direction h at the accepted pose,
  // p'' = d^2 p(theta + t h) / dt^2 at t = 0, exact for hinge chains (see has_acceleration). With
  // a_k the base-frame axis of DOF k, c_k = a_k x (p - o_k) (J's column without the weight) and
  // W_k = sum_{j<k} h_j a_j (the angular velocity of joint k's frame), differentiating
  // p' = sum_k h_k c_k gives sum_k h_k [W_k x c_k + a_k x sum_{j>=k} h_j c_j]; both double sums
  // run over the same pairs, so
  //   p'' = sum_k (2 W_k + h_k a_k) x (h_k c_k),
  // one cross product per DOF (O(n)).
  glm::dvec3 effector_second_derivative(const double* h) const {
    const double* col = ws_.jacobian.data();
    const Eigen::Index stride = ws_.jacobian.rows();
    const glm::dvec3* axes = ws_.dof_axes.data();
    double w2x = 0.0, w2y = 0.0, w2z = 0.0;  // 2 W_k
    double px = 0.0, py = 0.0, pz = 0.0;
    for (int k = 0; k < active_dofs_; ++k) {
      const double hk = h[k];
      const double* ck = col + stride * k;  // sqrt(w) c_k: the weight is divided out once, below
      const double ax = hk * axes[k].x, ay = hk * axes[k].y, az = hk * axes[k].z;
      const double tx = w2x + ax, ty = w2y + ay, tz = w2z + az;
      const double cx = hk * ck[0], cy = hk * ck[1], cz = hk * ck[2];
      px += ty * cz - tz * cy;
      py += tz * cx - tx * cz;
      pz += tx * cy - ty * cx;
      w2x += ax + ax;
      w2y += ay + ay;
      w2z += az + az;
    }
    return glm::dvec3(px, py, pz) / sqrt_weight_;
  }

  // Second-order ("geodesic acceleration") correction of the last damped_step h (Transtrum &
  // Sethna, "Improvements to the Levenberg-Marquardt algorithm for nonlinear least-squares
  // minimization", 2012): h2 = -(J^T J + mu)^-1 J^T p''/2 with p'' the effector's second
  // derivative along h (above). It cancels the curvature of the arcs the effector moves on, which
  // is what makes a Gauss-Newton step fall short far from the goal. Writes h2 into `correction`;
  // returns |h2|.
  double acceleration(const double* h, double* correction) const {
    const glm::dvec3 pdd = effector_second_derivative(h);
    const Eigen::Vector3d rhs = -0.5 * sqrt_weight_ * Eigen::Vector3d(pdd.x, pdd.y, pdd.z);
    const Eigen::Vector3d y = solve_spd3(damped_, rhs);
    apply_transpose(y, correction);
    double n2 = 0.0;
    for (int j = 0; j < active_dofs_; ++j) n2 += correction[j] * correction[j];
    return std::sqrt(n2);
  }

  // Pseudo-inverse step h = J+ e into step[0..active); remembers the change it predicts, J h
  // (= the part of e in J's range). Returns |(I - J J+) e|, the part no step can achieve.
  double pinv_step(double singular_threshold, double* step) {
    // Far from singular (certified by lambda_min >= 4 det / trace^2, since the two larger
    // eigenvalues multiply to at most trace^2 / 4) an LDL^T solve is exact and cheap.
    const double tr = gram_.trace();
    const double floor = gram_rank_floor(singular_threshold, tr);
    Eigen::Vector3d y;
    if (tr > 0.0 && 4.0 * gram_.determinant() / (tr * tr) > 100.0 * floor) {
      y = solve_spd3(gram_, e_);
      predicted_change_ = e_;
    } else {
      if (!decomposed_) {
        eigenvalues_matrix_ = gram_;
        jacobi_eigen(eigenvalues_matrix_, eigenvectors_, 3);
        decomposed_ = true;
      }
      const Eigen::Vector3d t = eigenvectors_.transpose() * e_;
      Eigen::Vector3d ft, kept;
      for (int i = 0; i < 3; ++i) {
        const double f = pinv_factor(eigenvalues_matrix_(i, i), floor);
        ft[i] = f * t[i];
        kept[i] = f > 0.0 ? t[i] : 0.0;
      }
      y = eigenvectors_ * ft;
      predicted_change_ = eigenvectors_ * kept;
    }
    apply_transpose(y, step);
    return (e_ - predicted_change_).norm();
  }
  double predicted_change_norm() const { return predicted_change_.norm(); }
  // |scale * J h - achieved change|: the part of the scaled step's promise the trial pose missed
  // (achieved change = e_accepted - e_trial).
  double missed_change(double scale) const {
    return (scale * predicted_change_ - (e_ - e_trial_)).norm();
  }

 private:
  // The weighted residual and cost of effector_trial_.
  double trial_residual() {
    const glm::dvec3 d = target_ - effector_trial_;
    e_trial_ = Eigen::Vector3d(d.x, d.y, d.z) * sqrt_weight_;
    cost_trial_ = 0.5 * e_trial_.squaredNorm();
    return cost_trial_;
  }

  void apply_transpose(const Eigen::Vector3d& y, double* step) const {
    const double* col = ws_.jacobian.data();
    const Eigen::Index stride = ws_.jacobian.rows();
    const double y0 = y[0], y1 = y[1], y2 = y[2];  // locals: stores to step[] could alias y
    for (int j = 0; j < active_dofs_; ++j) {
      const double* cj = col + stride * j;
      step[j] = cj[0] * y0 + cj[1] * y1 + cj[2] * y2;
    }
  }

  const Chain& chain_;
  Workspace& ws_;
  int effector_;
  int active_dofs_;
  glm::dvec3 target_;
  double sqrt_weight_;
  bool all_hinges_ = true;
  glm::dvec3 effector_position_{0.0}, effector_trial_{0.0};
  double distance_ = 0.0;
  double cost_ = 0.0, cost_trial_ = 0.0;
  Eigen::Vector3d e_ = Eigen::Vector3d::Zero(), e_trial_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d gram_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d damped_ = Eigen::Matrix3d::Identity();  // J J^T + mu I of the last damped_step
  Eigen::Matrix3d eigenvalues_matrix_, eigenvectors_;
  Eigen::Vector3d predicted_change_ = Eigen::Vector3d::Zero();
  bool decomposed_ = false;
};

// ------------------------------------------------------------------------------------------------
// Any goals, through kinematics.hpp. m = 3 * goals rows, n = dof_count, k = min(m, n).
// Workspace buffers:
//   residual / residual_trial (m)   accepted / trial residual (swapped on accept, no copy)
//   jacobian (m x n)                J at the accepted pose
//   m < n ("row form", J J^T):      goal_square k x k -> eigenvalues on its diagonal,
//                                   dof_square k x k eigenvectors V, dof_vec_a t = V^T e,
//                                   dof_vec_b y = V f t (then step = J^T y)
//   m >= n ("column form", J^T J):  dof_square k x k -> eigenvalues, goal_square k x k eigenvectors
//                                   W, gradient g = J^T e, dof_vec_a t = W^T g, step = W f t
//   goal_vec (m)                    pinv: the predicted change J h
class GoalModel {
 public:
  GoalModel(const Chain& chain, Span<const Goal> goals, Workspace& ws)
      : chain_(chain),
        goals_(goals),
        ws_(ws),
        m_(3 * goals.size),
        n_(chain.dof_count()),
        k_(std::min(m_, n_)),
        row_form_(m_ < n_),
        active_dofs_(active_dof_count(chain, goals)) {}

  int active_dofs() const { return active_dofs_; }

  double evaluate(const double* params) {
    forward_kinematics(chain_, params, ws_);
    errors_trial_ = evaluate_goals(chain_, goals_, ws_, ws_.residual_trial.head(m_));
    return errors_trial_.cost;
  }
  double evaluate_start(const double* params) { return evaluate(params); }
  void accept() {
    ws_.residual.swap(ws_.residual_trial);  // swaps the buffers' pointers: no copy, no allocation
    errors_ = errors_trial_;
  }
  double cost() const { return errors_.cost; }
  const GoalErrors& errors() const { return errors_; }
  bool converged(const SolverOptions& o) const { return errors_.within(o); }
  double residual_norm() const { return ws_.residual.head(m_).norm(); }

  void linearize(const double* params) {
    compute_dof_axes(chain_, params, ws_);
    auto J = ws_.jacobian.topRows(m_);
    compute_jacobian(chain_, goals_, ws_, J);
    refactor();
  }
  // Active set (see limit_aware_step): as SinglePositionModel's.
  void freeze(int dof) { ws_.jacobian.col(dof).head(m_).setZero(); }
  void freeze_direction(int o, const glm::dvec3& normal) { remove_ball_direction(ws_.jacobian, m_, o, normal); }
  // The Gram matrix's eigen-decomposition and the projected residual of the current J.
  void refactor() {
    auto J = ws_.jacobian.topRows(m_);
    auto e = ws_.residual.head(m_);
    auto t = ws_.dof_vec_a.head(k_);
    stopped_ = false;
    if (row_form_) {
      auto A = ws_.goal_square.topLeftCorner(k_, k_);
      auto V = ws_.dof_square.topLeftCorner(k_, k_);
      if (!gram_rows(J, A)) return;
      trace_ = A.trace();
      stopped_ = jacobi_eigen(A, V, k_, &ws_.deadline) < 0;
      if (stopped_) return;
      t.noalias() = V.transpose() * e;
      gradient_norm2_ = 0.0;
      for (int i = 0; i < k_; ++i) gradient_norm2_ += std::max(A(i, i), 0.0) * t[i] * t[i];
    } else {
      auto A = ws_.dof_square.topLeftCorner(k_, k_);
      auto W = ws_.goal_square.topLeftCorner(k_, k_);
      // m >= n here, and m is 3 per goal: a product of a few thousand flops, never split.
      A.noalias() = J.transpose() * J;
      ws_.deadline.charge(static_cast<double>(k_) * k_ * m_);
      trace_ = A.trace();
      stopped_ = jacobi_eigen(A, W, k_, &ws_.deadline) < 0;
      if (stopped_) return;
      ws_.gradient.noalias() = J.transpose() * e;
      gradient_norm2_ = ws_.gradient.squaredNorm();
      t.noalias() = W.transpose() * ws_.gradient;
    }
  }

  double gradient_norm2() const { return gradient_norm2_; }
  double jacobian_norm() const { return std::sqrt(std::max(trace_, 0.0)); }
  // No second-order correction for general goals (orientation rows have other curvature).
  bool has_acceleration() const { return false; }
  double acceleration(const double*, double*) const { return 0.0; }

  double damped_step(double mu, double* step_out) {
    return step_with([mu](double lambda) { return 1.0 / (lambda + mu); }, step_out, nullptr);
  }

  double pinv_step(double singular_threshold, double* step_out) {
    const double floor = gram_rank_floor(singular_threshold, trace_);
    double unreachable = 0.0;
    step_with([floor](double lambda) { return pinv_factor(lambda, floor); }, step_out, &unreachable);
    return unreachable;
  }
  double predicted_change_norm() const { return ws_.goal_vec.head(m_).norm(); }
  double missed_change(double scale) const {
    double s = 0.0;
    for (int i = 0; i < m_; ++i) {
      const double d = scale * ws_.goal_vec[i] - (ws_.residual[i] - ws_.residual_trial[i]);
      s += d * d;
    }
    return std::sqrt(s);
  }

 private:
  // A = J J^T (m x m, m < n). On hundreds of DOFs with several goals the product alone outgrows the
  // budget's 20 us of slack (m^2 n flops: 135k on 600 DOF with 5 goals), and the active set repeats
  // it per freeze pass, so above kGramFlopsPerCheck it is formed kGramRowsPerCheck rows at a time
  // with a clock reading between (issue 16, item 6). False, and stopped_, when the budget ran out
  // (A is then incomplete: no step). Below, one product as before (the same rounding).
  static constexpr double kGramFlopsPerCheck = 20000.0;
  static constexpr int kGramRowsPerCheck = 3;
  template <class MatJ, class MatA>
  bool gram_rows(const MatJ& J, MatA& A) {
    const double flops = static_cast<double>(m_) * m_ * n_;
    if (flops <= kGramFlopsPerCheck) {
      A.noalias() = J * J.transpose();
      ws_.deadline.charge(flops);
      return true;
    }
    for (int r = 0; r < m_; r += kGramRowsPerCheck) {
      if (r > 0 && ws_.deadline.spent()) {
        stopped_ = true;
        return false;
      }
      const int rows = std::min(kGramRowsPerCheck, m_ - r);
      A.middleRows(r, rows).noalias() = J.middleRows(r, rows) * J.transpose();
      ws_.deadline.charge(static_cast<double>(rows) * m_ * n_);
    }
    return true;
  }

  // Step h = J^+_f e for the filter f(lambda) into step_out (n entries). Returns the linear model's
  // decrease 0.5 (|e|^2 - |e - J h|^2). With `pinv_unreachable` set (pseudo-inverse), also stores
  // the predicted change J h in goal_vec and returns |e - J h| through the pointer.
  template <typename Filter>
  double step_with(Filter filter, double* step_out, double* pinv_unreachable) {
    auto J = ws_.jacobian.topRows(m_);
    auto t = ws_.dof_vec_a.head(k_);
    Eigen::Map<Eigen::VectorXd> h(step_out, n_);
    double decrease = 0.0;
    if (stopped_) {  // the budget stopped the decomposition: no step, nothing predicted
      h.setZero();
      if (pinv_unreachable) {
        ws_.goal_vec.head(m_).setZero();
        *pinv_unreachable = residual_norm();
      }
      return 0.0;
    }
    ws_.deadline.charge(static_cast<double>(k_) * (k_ + n_) + (pinv_unreachable ? static_cast<double>(m_) * n_ : 0.0));
    if (row_form_) {
      const auto A = ws_.goal_square.topLeftCorner(k_, k_);
      const auto V = ws_.dof_square.topLeftCorner(k_, k_);
      auto y = ws_.dof_vec_b.head(k_);
      double missed2 = 0.0;
      for (int i = 0; i < k_; ++i) {
        const double lambda = std::max(A(i, i), 0.0);
        const double f = filter(lambda);
        y[i] = f * t[i];
        const double r = 1.0 - lambda * f;  // e - J h = V diag(1 - lambda f) t
        decrease += 0.5 * t[i] * t[i] * (1.0 - r * r);
        missed2 += r * r * t[i] * t[i];
      }
      ws_.gradient.head(k_) = y;  // V * y must not alias y
      y.noalias() = V * ws_.gradient.head(k_);
      h.noalias() = J.transpose() * y;
      if (pinv_unreachable) {
        ws_.goal_vec.head(m_).noalias() = J * h;
        *pinv_unreachable = std::sqrt(missed2);
      }
    } else {
      const auto A = ws_.dof_square.topLeftCorner(k_, k_);
      const auto W = ws_.goal_square.topLeftCorner(k_, k_);
      auto ft = ws_.dof_vec_b.head(k_);
      for (int i = 0; i < k_; ++i) {
        const double lambda = std::max(A(i, i), 0.0);
        const double f = filter(lambda);
        ft[i] = f * t[i];
        decrease += f * t[i] * t[i] * (1.0 - 0.5 * lambda * f);
      }
      h.noalias() = W * ft;
      if (pinv_unreachable) {
        ws_.goal_vec.head(m_).noalias() = J * h;
        *pinv_unreachable = (ws_.residual.head(m_) - ws_.goal_vec.head(m_)).norm();
      }
    }
    return decrease;
  }

  const Chain& chain_;
  Span<const Goal> goals_;
  Workspace& ws_;
  int m_, n_, k_;
  bool row_form_;
  int active_dofs_;
  GoalErrors errors_, errors_trial_;
  double trace_ = 0.0;
  double gradient_norm2_ = 0.0;
  bool stopped_ = false;  // the time budget stopped the last refactor(): no step from it
};

// ------------------------------------------------------------------------------------------------
// Helpers both solvers' loops use.

// params_trial = params + step (capped by max_step_angle, ball vectors wrapped), projected onto the
// joint limits.
inline void make_trial(const Chain& chain, const SolverOptions& o, const double* params, const double* step,
                       Workspace& ws) {
  const int n = chain.dof_count();
  double* trial = ws.params_trial.data();
  std::copy(params, params + n, trial);
  apply_step(chain, step, o.max_step_angle, trial);
  project_to_limits(chain, trial);
  ws.deadline.charge(2.0 * Deadline::kFlopsPerJoint * chain.joint_count());  // about two FK passes
}

// Limit-aware steps (an active set; the one mechanism DLS and the pseudo-inverse share, with the
// predicates BFGS freezes by, hinge_blocked() and ball_blocked() in kinematics.hpp). Projecting a
// trial pose onto the limits clips every component that pushes a joint resting on a limit further
// out: the step that is left is not the one the linear model chose (its predicted decrease is
// wrong), DLS raises the damping on the resulting rejections and the pseudo-inverse halves, until
// both stall on the limit. Instead, a hinge DOF on a bound whose step pushes outward is frozen -
// its column leaves J - and a ball joint on its cone or twist boundary whose step pushes outward
// loses the outward normal direction from its three columns (J <- J (I - n n^T), so the re-solved
// step slides along the boundary's tangent). The step is solved again over what is left, and the
// other DOFs do the blocked share; repeated while the new step blocks more (at most
// kMaxFreezePasses). Components that cross a bound from inside, and the second-order drift of a
// tangent step off the curved cone, are still clipped by the projection, and that joint then rests
// on its bound at the next linearisation. This is the active-set idea of projected Newton methods
// (Bertsekas 1982, "Projected Newton methods for optimization problems with simple constraints")
// applied to the Gauss-Newton / LM step. `step_fn(step)` computes the model's step into `step` and
// returns what the solver needs of it (DLS: the predicted decrease). The frozen columns and
// directions stay out of J until the next linearize().
constexpr int kMaxFreezePasses = 4;
template <class Model, class StepFn>
double limit_aware_step(const Chain& chain, Model& model, const double* params, double* step, StepFn&& step_fn) {
  double out = step_fn(step);
  if (!chain.any_limits()) return out;
  const int active = model.active_dofs();
  for (int pass = 0; pass < kMaxFreezePasses; ++pass) {
    bool froze = false;
    for (int i = 0; i < chain.joint_count() && chain.dof_offset(i) < active; ++i) {
      const int o = chain.dof_offset(i);
      if (!is_one_dof(chain.joint_type(i))) {
        glm::dvec3 normals[2];
        const int count = ball_blocked(chain, i, params, step + o, normals);
        for (int k = 0; k < count; ++k) model.freeze_direction(o, normals[k]);
        froze = froze || count > 0;
      } else if (step[o] != 0.0 && hinge_blocked(chain, i, params, step[o])) {
        model.freeze(o);
        froze = true;
      }
    }
    if (!froze) break;
    model.refactor();
    out = step_fn(step);
  }
  return out;
}

// Testing hooks: the solvers forced onto GoalModel even for one position goal, so a test can check
// that the fast path and the generic path agree. Same preconditions as solvers.hpp.
SolverStatus solve_jacobian_pinv_generic(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&,
                                         double* params);
SolverStatus solve_dls_generic(const Chain&, Span<const Goal>, const SolverOptions&, Workspace&, double* params);

}  // namespace jacobian
}  // namespace ikchain
