// The core's small dense linear algebra, in one place: the cyclic Jacobi eigen-decomposition (the
// Jacobian solvers' Gram matrices, the escapes' null-space projection, CCD's and FABRIK's 4x4 Horn
// fits), the Cholesky factorisation (BFGS's normal equations), the unrolled 3x3 LDL^T solve (the
// single-goal DLS step) and the column-block kernels of the tree DLS's priority levels (a
// right-looking Cholesky, triangular solves, a Gram update). Everything works in place on fixed-size matrices or workspace blocks and
// allocates nothing: Eigen's own decompositions size their storage at run time.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "ikchain/deadline.hpp"

namespace ikchain {
namespace linalg {

// Sweeps the Jacobi method may take. Convergence is quadratic once the off-diagonal part is small
// (Golub & Van Loan, sec. 8.5.5), so the stop test below ends it after a handful of sweeps,
// rank-deficient or not; the cap only bounds a pathological input.
constexpr int kMaxJacobiSweeps = 60;

// Cyclic Jacobi eigenvalue method (Golub & Van Loan, "Matrix Computations", 4th ed., Alg. 8.5.3):
// diagonalises the symmetric k x k matrix `a` in place (eigenvalues end on its diagonal, unsorted)
// and accumulates the eigenvectors as the columns of `v`. Jacobi is accurate for small eigenvalues
// (what decides rank deficiency), and k is small (3 per goal; 4 for Horn's quaternion fit).
//
// Stop test, relative to the matrix's own scale: off(A) <= 4 eps |A|_F (off = the Frobenius norm
// of the off-diagonal part; both are invariant under the rotations, up to rounding). Below that,
// every eigenvalue is already within ~4 eps |A|_F of the diagonal (Weyl), and the rotations only
// stir rounding: on a rank-deficient matrix the off-diagonal entries coupling a zero eigenvalue
// stay at ~eps |A| forever, so a test below rounding (the one this replaced, off^2 <= 1e-34 diag^2)
// is never met and every call ran all kMaxJacobiSweeps sweeps (issue 16, item 7).
//
// `deadline` (optional): checked once per sweep from k >= kJacobiDeadlineSize on (a sweep costs
// O(k^3): at 18 x 18, six goals, tens of microseconds; below, a whole decomposition costs less than
// the budget's slack); when it is spent the decomposition stops where it is
// (a is then not diagonal: the caller must not step on it).
// Returns the sweeps run (0 for a matrix already diagonal), or -1 when the deadline stopped it.
constexpr int kJacobiDeadlineSize = 9;
template <typename MatA, typename MatV>
int jacobi_eigen(MatA& a, MatV& v, int k, Deadline* deadline = nullptr) {
  v.setIdentity();
  constexpr double kTol = 4.0 * std::numeric_limits<double>::epsilon();
  for (int sweep = 0; sweep < kMaxJacobiSweeps; ++sweep) {
    double off = 0.0, total = 0.0;
    for (int p = 0; p < k; ++p) {
      total += a(p, p) * a(p, p);
      for (int q = p + 1; q < k; ++q) off += 2.0 * a(p, q) * a(p, q);
    }
    total += off;
    if (off <= kTol * kTol * total) return sweep;  // also off == 0 (a zero matrix included)
    if (deadline && k >= kJacobiDeadlineSize && deadline->spent()) return -1;
    for (int p = 0; p < k; ++p) {
      for (int q = p + 1; q < k; ++q) {
        const double apq = a(p, q);
        if (apq == 0.0) continue;
        // Rotation zeroing a(p,q) (Golub & Van Loan, Alg. 8.5.1, sym.schur2).
        const double tau = (a(q, q) - a(p, p)) / (2.0 * apq);
        const double t = std::abs(tau) > 1e150 ? 0.5 / tau
                                              : (tau >= 0.0 ? 1.0 : -1.0) / (std::abs(tau) + std::sqrt(1.0 + tau * tau));
        const double c = 1.0 / std::sqrt(1.0 + t * t);
        const double s = t * c;
        for (int r = 0; r < k; ++r) {  // A <- A J (columns p, q)
          const double arp = a(r, p), arq = a(r, q);
          a(r, p) = c * arp - s * arq;
          a(r, q) = s * arp + c * arq;
        }
        for (int r = 0; r < k; ++r) {  // A <- J^T A (rows p, q)
          const double apr = a(p, r), aqr = a(q, r);
          a(p, r) = c * apr - s * aqr;
          a(q, r) = s * apr + c * aqr;
        }
        for (int r = 0; r < k; ++r) {  // V <- V J
          const double vrp = v(r, p), vrq = v(r, q);
          v(r, p) = c * vrp - s * vrq;
          v(r, q) = s * vrp + c * vrq;
        }
      }
    }
  }
  return kMaxJacobiSweeps;
}

// Cholesky factorisation A = L L^T of the symmetric positive (semi)definite k x k matrix `a`, in
// place: L ends in the lower triangle (the upper one is not read and is left alone). Pivots that
// rounding (or a semidefinite A) pushes below min_pivot^2 are raised to it, so the factor stays
// finite; the callers add a damping of that size first, so the clamp only catches rounding.
template <typename MatA>
void cholesky_factor(MatA& a, int k, double min_pivot2) {
  for (int j = 0; j < k; ++j) {
    double d = a(j, j);
    for (int m = 0; m < j; ++m) d -= a(j, m) * a(j, m);
    d = std::sqrt(std::max(d, min_pivot2));
    a(j, j) = d;
    for (int i = j + 1; i < k; ++i) {
      double s = a(i, j);
      for (int m = 0; m < j; ++m) s -= a(i, m) * a(j, m);
      a(i, j) = s / d;
    }
  }
}

// Solves L L^T x = b in place (b becomes x) with the factor cholesky_factor() left in `l`.
template <typename MatL, typename Vec>
void cholesky_solve(const MatL& l, Vec& b, int k) {
  for (int i = 0; i < k; ++i) {  // L z = b
    double s = b[i];
    for (int m = 0; m < i; ++m) s -= l(i, m) * b[m];
    b[i] = s / l(i, i);
  }
  for (int i = k - 1; i >= 0; --i) {  // L^T x = z
    double s = b[i];
    for (int m = i + 1; m < k; ++m) s -= l(m, i) * b[m];
    b[i] = s / l(i, i);
  }
}

// Solves A y = b for a symmetric positive definite 3x3 A by LDL^T, unrolled (the single-goal DLS
// step's hot path: Eigen's fixed-size LLT is a generic loop with square roots, cholesky_factor too).
// Pivots that rounding made non-positive are clamped to a tiny positive value: the caller only
// uses this with a positive damping or a certified rank.
inline Eigen::Vector3d solve_spd3(const Eigen::Matrix3d& a, const Eigen::Vector3d& b) {
  constexpr double kTiny = 1e-300;
  const double d0 = std::max(a(0, 0), kTiny);
  const double l10 = a(1, 0) / d0, l20 = a(2, 0) / d0;
  const double d1 = std::max(a(1, 1) - l10 * a(1, 0), kTiny);
  const double l21 = (a(2, 1) - l20 * a(1, 0)) / d1;
  const double d2 = std::max(a(2, 2) - l20 * a(2, 0) - l21 * l21 * d1, kTiny);
  const double z0 = b[0];
  const double z1 = b[1] - l10 * z0;
  const double z2 = b[2] - l20 * z0 - l21 * z1;
  Eigen::Vector3d y;
  y[2] = z2 / d2;
  y[1] = z1 / d1 - l21 * y[2];
  y[0] = z0 / d0 - l10 * y[1] - l20 * y[2];
  return y;
}

// Small dense kernels on column-major blocks (pointer + leading dimension), column-oriented so the
// inner loops run down contiguous columns: the tree DLS's priority levels (solvers/tree_dls.cpp).
// Their matrices are 3 rows per goal (18 x 18 for six 6-D goals): too small for Eigen's blocked
// products, whose packing costs more than the arithmetic here.
struct Cols {
  double* p;
  Eigen::Index ld;
  double& operator()(int i, int j) const { return p[i + j * ld]; }
  double* col(int j) const { return p + j * ld; }
};
template <class Block>
Cols cols_of(Block&& b) {
  return Cols{b.data(), b.outerStride()};
}

using Seg = Eigen::Map<Eigen::VectorXd>;
using ConstSeg = Eigen::Map<const Eigen::VectorXd>;

// A = L L^T in place (lower triangle; the upper is not read), right-looking (cholesky_factor
// above is left-looking, on any matrix type: the two round differently, so each caller keeps its
// own); pivots below min_pivot2 are raised to it (cholesky_factor's rule).
inline void cholesky_lower(Cols a, int n, double min_pivot2) {
  for (int j = 0; j < n; ++j) {
    double* cj = a.col(j);
    const double d = std::sqrt(std::max(cj[j], min_pivot2));
    cj[j] = d;
    Seg(cj + j + 1, n - j - 1) *= 1.0 / d;
    for (int k = j + 1; k < n; ++k) Seg(a.col(k) + k, n - k) -= cj[k] * ConstSeg(cj + k, n - k);
  }
}
// x <- L^-1 x (forward substitution) for a vector with stride 1.
inline void lower_solve(Cols l, int n, double* x) {
  for (int k = 0; k < n; ++k) {
    const double* ck = l.col(k);
    const double v = (x[k] /= ck[k]);
    Seg(x + k + 1, n - k - 1) -= v * ConstSeg(ck + k + 1, n - k - 1);
  }
}
// x <- L^-T x (back substitution).
inline void lower_transpose_solve(Cols l, int n, double* x) {
  for (int k = n - 1; k >= 0; --k) {
    const double* ck = l.col(k);
    x[k] = (x[k] - ConstSeg(ck + k + 1, n - k - 1).dot(ConstSeg(x + k + 1, n - k - 1))) / ck[k];
  }
}
// S -= W^T W on S's lower triangle (W: rows x cols, S: cols x cols).
inline void subtract_gram_of_columns(Cols w, int rows, int cols, Cols s) {
  for (int j = 0; j < cols; ++j) {
    const ConstSeg wj(w.col(j), rows);
    for (int i = j; i < cols; ++i) s(i, j) -= ConstSeg(w.col(i), rows).dot(wj);
  }
}

}  // namespace linalg
}  // namespace ikchain
