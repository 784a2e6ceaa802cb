// The pieces of BFGS that do not depend on what is optimised (internal to src/core/solvers/),
// shared by the chain BFGS (bfgs.cpp) and the tree BFGS (tree_bfgs.cpp):
//  - the strong-Wolfe line search, Nocedal & Wright, Numerical Optimization (2nd ed.), Alg. 3.5
//    (bracketing) with zoom, Alg. 3.6, cubic interpolation eq. (3.59), extended by a projected
//    (kinked) path where only sufficient decrease is asked for (Bertsekas' Armijo rule along the
//    projection arc; see bfgs.cpp's comment on limits);
//  - the inverse-Hessian update, eq. (6.17), with the initial scaling eq. (6.20), in place on the
//    lower triangle of a symmetric matrix, and the product with that triangle.
#pragma once
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "ikchain/deadline.hpp"
#include "ikchain/options.hpp"

namespace ikchain {
namespace bfgs {

// out = H x for a symmetric H of which only the lower triangle is stored: one pass over it, as
// Eigen's selfAdjointView product (which warns -Wmaybe-uninitialized inside Eigen on GCC).
//
// The time budget (issue 16, item 6): on hundreds of DOFs one O(n^2) pass over H costs 50-300 us,
// past the 20 us the bound allows after the budget, so a pass reads `deadline` (optional) every
// kColumnsPerCheck columns and returns false, unfinished, once it is spent.
constexpr int kColumnsPerCheck = 64;
inline bool spent_at_column(Deadline* deadline, int j) {
  return deadline && j > 0 && j % kColumnsPerCheck == 0 && deadline->spent();
}

inline bool symmetric_product(const Eigen::MatrixXd& H, const Eigen::VectorXd& x, Eigen::VectorXd& out,
                              Deadline* deadline = nullptr) {
  const int n = static_cast<int>(x.size());
  out.setZero();
  for (int j = 0; j < n; ++j) {
    if (spent_at_column(deadline, j)) return false;
    if (deadline) deadline->charge(2.0 * n);  // this column and its mirror: 2 (n - j) on average ~ n
    const int below = n - j - 1;
    const auto col = H.col(j).tail(below);
    out[j] += H(j, j) * x[j] + col.dot(x.tail(below));
    out.tail(below) += x[j] * col;
  }
  return true;
}

// H = (y^T s / y^T y) I, eq. (6.20), on the lower triangle; false (H untouched) when the curvature
// y^T s is not positive.
inline bool scaled_identity(Eigen::MatrixXd& H, const Eigen::VectorXd& s, const Eigen::VectorXd& y) {
  const double sy = s.dot(y);
  if (!(sy > 1e-12 * s.norm() * y.norm())) return false;
  const int n = static_cast<int>(s.size());
  for (int j = 0; j < n; ++j) H.col(j).tail(n - j).setZero();
  H.diagonal().head(n).setConstant(sy / y.squaredNorm());
  return true;
}

// Eq. (6.17) in place on the lower triangle of H, expanded so only H y is needed:
//   H+ = H - rho (s (Hy)^T + (Hy) s^T) + (rho^2 y^T H y + rho) s s^T.
// `fresh`: H is first set to eq. (6.20)'s (y^T s / y^T y) I (and `fresh` cleared); then H y = c y
// needs no product and only the lower triangle is written (the same values as setting the whole
// identity first). The update is skipped when the curvature y^T s is not positive (H stays positive
// definite). `hy`: scratch. `deadline` (optional): a pass it stops leaves H unfinished, so `fresh`
// is set again (the solve stops at its next check anyway).
inline void update_inverse_hessian(Eigen::MatrixXd& H, const Eigen::VectorXd& s, const Eigen::VectorXd& y,
                                   Eigen::VectorXd& hy, bool& fresh, Deadline* deadline = nullptr) {
  const double sy = s.dot(y);
  if (!(sy > 1e-12 * s.norm() * y.norm())) return;
  const int n = static_cast<int>(s.size());
  const bool from_identity = fresh;
  const double scale = from_identity ? sy / y.squaredNorm() : 0.0;
  if (from_identity) {
    hy = scale * y;
  } else if (!symmetric_product(H, y, hy, deadline)) {
    fresh = true;
    return;
  }
  fresh = false;
  const double rho = 1.0 / sy;
  const double ss = rho * rho * y.dot(hy) + rho;
  for (int j = 0; j < n; ++j) {
    if (spent_at_column(deadline, j)) {
      fresh = true;
      return;
    }
    if (deadline) deadline->charge(2.0 * (n - j));
    const double sj = s[j], hj = hy[j];
    const double a = ss * sj - rho * hj;
    const double b = -rho * sj;
    // Only the lower triangle is stored and read, halving the memory traffic, which is what bounds
    // this loop for long chains.
    const int len = n - j;
    if (from_identity) {
      H.col(j).tail(len).noalias() = a * s.tail(len) + b * hy.tail(len);
      H(j, j) += scale;
    } else {
      H.col(j).tail(len).noalias() += a * s.tail(len) + b * hy.tail(len);
    }
  }
}

// One trial point of a line search; `Errors` is what the caller measures there.
template <class Errors>
struct Trial {
  double alpha = 0.0;
  double f = 0.0;         // cost at the trial point
  double dphi = 0.0;      // grad f(trial) . d
  double decrease = 0.0;  // grad f(start) . (trial - start): alpha * dphi0 unless projected
  bool projected = false;
  Errors err;
};

// The line search along a direction d from x, given f0 = f(x) and dphi0 = grad f(x) . d < 0.
// `Problem` provides:
//   Trial<E> try_step(double alpha)  evaluates x + alpha d (projected onto the limits);
//   void keep(const Trial<E>&)       remembers the trial just evaluated as the best acceptable one.
// Returns whether a point was kept. The time budget (`deadline`) is checked between trial steps:
// spent, the search ends with the best point it kept, if any.
template <class Problem, class Errors>
class WolfeSearch {
 public:
  using T = Trial<Errors>;
  WolfeSearch(Problem& problem, const SolverOptions& options, Deadline& deadline, double f0, double dphi0)
      : p_(problem), o_(options), deadline_(deadline), f0_(f0), dphi0_(dphi0) {}

  bool sufficient_decrease(const T& t) const { return t.f < f0_ && t.f <= f0_ + o_.bfgs_wolfe_c1 * t.decrease; }
  bool curvature(const T& t) const { return std::abs(t.dphi) <= -o_.bfgs_wolfe_c2 * dphi0_; }

  // N&W Alg. 3.5: bracket an interval containing strong-Wolfe points, starting from alpha_init.
  bool run(double alpha_init, double alpha_max) {
    kept_ = false;
    T prev;
    prev.f = f0_;
    prev.dphi = dphi0_;
    double alpha = alpha_init;
    for (int evals = 1; evals <= o_.bfgs_max_line_search_steps; ++evals) {
      if (evals > 1 && deadline_.spent()) return kept_;
      const T t = p_.try_step(alpha);
      if (!sufficient_decrease(t) || (evals > 1 && t.f >= prev.f)) return zoom(prev, t, evals);
      keep(t);
      // A projected (kinked) path has no meaningful slope: sufficient decrease is enough there.
      if (t.projected || curvature(t)) return true;
      if (t.dphi >= 0.0) return zoom(t, prev, evals);
      if (alpha >= alpha_max) return true;
      prev = t;
      alpha = std::min(4.0 * alpha, alpha_max);
    }
    return kept_;
  }

 private:
  void keep(const T& t) {
    p_.keep(t);
    kept_ = true;
  }

  // N&W Alg. 3.6: lo satisfies sufficient decrease with the lowest f so far (kept unless alpha = 0);
  // the interval between lo and hi contains strong-Wolfe points.
  bool zoom(T lo, T hi, int evals) {
    for (; evals < o_.bfgs_max_line_search_steps; ++evals) {
      const double a0 = lo.alpha, a1 = hi.alpha;
      const double lo_end = std::min(a0, a1), hi_end = std::max(a0, a1);
      const double width = hi_end - lo_end;
      if (!(width > 1e-14 * hi_end)) break;
      double alpha = 0.5 * (a0 + a1);
      if (!hi.projected) {
        // Cubic through (a0, f, f') and (a1, f, f'), eq. (3.59), safeguarded into the interval.
        const double d1 = lo.dphi + hi.dphi - 3.0 * (lo.f - hi.f) / (a0 - a1);
        const double disc = d1 * d1 - lo.dphi * hi.dphi;
        if (disc >= 0.0) {
          const double d2 = std::copysign(std::sqrt(disc), a1 - a0);
          const double denom = hi.dphi - lo.dphi + 2.0 * d2;
          if (denom != 0.0) {
            const double c = a1 - (a1 - a0) * (hi.dphi + d2 - d1) / denom;
            if (std::isfinite(c)) alpha = std::clamp(c, lo_end + 0.1 * width, hi_end - 0.1 * width);
          }
        }
      }
      if (deadline_.spent()) break;
      const T t = p_.try_step(alpha);
      if (!sufficient_decrease(t) || t.f >= lo.f) {
        hi = t;
        continue;
      }
      keep(t);
      if (t.projected || curvature(t)) return true;
      if (t.dphi * (hi.alpha - lo.alpha) >= 0.0) hi = lo;
      lo = t;
    }
    return kept_;
  }

  Problem& p_;
  const SolverOptions& o_;
  Deadline& deadline_;
  const double f0_, dphi0_;
  bool kept_ = false;
};

}  // namespace bfgs
}  // namespace ikchain
