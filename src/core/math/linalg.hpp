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
// `deadline` (optional): checked before every sweep from k >= kJacobiDeadlineSize on, and within
// one every kJacobiFlopsPerCheck flops (a sweep costs O(k^3): at 18 x 18, six goals, tens of
// microseconds; below, a whole decomposition costs less than the budget's slack); the sweeps'
// work is charged to it as it goes; when it is spent the decomposition stops where it is
// (a is then not diagonal: the caller must not step on it).
// Returns the sweeps run (0 for a matrix already diagonal), or -1 when the deadline stopped it.
constexpr int kJacobiDeadlineSize = 9;
constexpr double kJacobiFlopsPerCheck = 10000.0;  // ~5 us: a quarter of the bound's 20 us slack
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
    double pending = 0.0;  // flops since the last charge
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
      if (!deadline) continue;
      pending += 12.0 * k * (k - p - 1);  // the row's rotations: 3 k-long updates of 4 flops each
      // Within a sweep too, once the work since the last reading is kJacobiFlopsPerCheck: a sweep
      // of 21 x 21 (seven goals) is ~55k flops, 15-25 us, where the budget's slack is 20 us. A
      // stop mid-sweep leaves `a` similar to the input, not diagonal (see above).
      if (pending >= kJacobiFlopsPerCheck || p + 1 == k) {
        deadline->charge(pending);
        pending = 0.0;
        if (k >= kJacobiDeadlineSize && p + 1 < k && deadline->spent()) return -1;
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
// products, whose packing costs more than the arithmetic here, and too small for Eigen's dynamic
// vector expressions too where a kernel makes many short updates (sizes, alignment peeling):
// the Cholesky factor and the multi-right-hand-side substitution hold their rows in registers.
// subtract_products() takes two doubles at a time (Eigen's fixed-size 2-vectors: one SSE2
// operation each on x86-64, plain scalars elsewhere) and rounds exactly as the column updates it
// replaced: the element-wise updates are the same operations in the same order.
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

using Pair = Eigen::Array2d;
inline Pair load2(const double* p) { return Eigen::Map<const Pair>(p); }
inline void store2(double* p, const Pair& v) { Eigen::Map<Pair>{p} = v; }

// y[i] -= s[j * s_stride] * a[i + j * ld] for j = 0, 1, ..., count - 1 in turn, for the 2 * Pairs
// (+ 1 when Odd) rows i from 0, held in registers.
template <int Pairs, bool Odd>
inline void subtract_products_rows(double* y, const double* a, Eigen::Index ld, const double* s,
                                   Eigen::Index s_stride, int count) {
  static_assert(Pairs >= 0 && Pairs <= 4, "at most 8 rows in registers");
  // Named accumulators, not an array: GCC keeps these in registers.
  Pair y0, y1, y2, y3;
  double last = 0.0;
  if constexpr (Pairs > 0) y0 = load2(y);
  if constexpr (Pairs > 1) y1 = load2(y + 2);
  if constexpr (Pairs > 2) y2 = load2(y + 4);
  if constexpr (Pairs > 3) y3 = load2(y + 6);
  if constexpr (Odd) last = y[2 * Pairs];
  for (int j = 0; j < count; ++j, a += ld, s += s_stride) {
    const Pair sv = Pair::Constant(*s);
    if constexpr (Pairs > 0) y0 -= sv * load2(a);
    if constexpr (Pairs > 1) y1 -= sv * load2(a + 2);
    if constexpr (Pairs > 2) y2 -= sv * load2(a + 4);
    if constexpr (Pairs > 3) y3 -= sv * load2(a + 6);
    if constexpr (Odd) last -= *s * a[2 * Pairs];
  }
  if constexpr (Pairs > 0) store2(y, y0);
  if constexpr (Pairs > 1) store2(y + 2, y1);
  if constexpr (Pairs > 2) store2(y + 4, y2);
  if constexpr (Pairs > 3) store2(y + 6, y3);
  if constexpr (Odd) y[2 * Pairs] = last;
}
// The same for rows i < n: `count` subtract_scaled() calls down the columns of a, rounding as they
// do, with y held in registers (eight rows at a time, then the rest at once) instead of loaded and
// stored by every call.
inline void subtract_products(double* y, int n, const double* a, Eigen::Index ld, const double* s,
                              Eigen::Index s_stride, int count) {
  int i = 0;
  for (; i + 8 <= n; i += 8) subtract_products_rows<4, false>(y + i, a + i, ld, s, s_stride, count);
  switch (n - i) {
    case 1: subtract_products_rows<0, true>(y + i, a + i, ld, s, s_stride, count); break;
    case 2: subtract_products_rows<1, false>(y + i, a + i, ld, s, s_stride, count); break;
    case 3: subtract_products_rows<1, true>(y + i, a + i, ld, s, s_stride, count); break;
    case 4: subtract_products_rows<2, false>(y + i, a + i, ld, s, s_stride, count); break;
    case 5: subtract_products_rows<2, true>(y + i, a + i, ld, s, s_stride, count); break;
    case 6: subtract_products_rows<3, false>(y + i, a + i, ld, s, s_stride, count); break;
    case 7: subtract_products_rows<3, true>(y + i, a + i, ld, s, s_stride, count); break;
    default: break;
  }
}
// subtract_products() for two outputs over the same rows: y0[i] -= s0[j * s_stride] a[i + j * ld] and
// y1[i] -= s1[j * s_stride] a[i + j * ld], each entry's products in j order as subtract_products()
// takes them, with a's entries loaded once for both (a Cholesky factor's two adjacent columns, or
// a substitution's two adjacent rows).
template <int Pairs, bool Odd>
inline void subtract_products2_rows(double* y0, double* y1, const double* a, Eigen::Index ld, const double* s0,
                                    const double* s1, Eigen::Index s_stride, int count) {
  static_assert(Pairs >= 0 && Pairs <= 4, "at most 8 rows of two outputs in registers");
  Pair u0, u1, u2, u3, v0, v1, v2, v3;
  double u_last = 0.0, v_last = 0.0;
  if constexpr (Pairs > 0) u0 = load2(y0), v0 = load2(y1);
  if constexpr (Pairs > 1) u1 = load2(y0 + 2), v1 = load2(y1 + 2);
  if constexpr (Pairs > 2) u2 = load2(y0 + 4), v2 = load2(y1 + 4);
  if constexpr (Pairs > 3) u3 = load2(y0 + 6), v3 = load2(y1 + 6);
  if constexpr (Odd) u_last = y0[2 * Pairs], v_last = y1[2 * Pairs];
  for (int j = 0; j < count; ++j, a += ld, s0 += s_stride, s1 += s_stride) {
    const Pair su = Pair::Constant(*s0), sv = Pair::Constant(*s1);
    if constexpr (Pairs > 0) {
      const Pair a0 = load2(a);
      u0 -= su * a0, v0 -= sv * a0;
    }
    if constexpr (Pairs > 1) {
      const Pair a1 = load2(a + 2);
      u1 -= su * a1, v1 -= sv * a1;
    }
    if constexpr (Pairs > 2) {
      const Pair a2 = load2(a + 4);
      u2 -= su * a2, v2 -= sv * a2;
    }
    if constexpr (Pairs > 3) {
      const Pair a3 = load2(a + 6);
      u3 -= su * a3, v3 -= sv * a3;
    }
    if constexpr (Odd) u_last -= *s0 * a[2 * Pairs], v_last -= *s1 * a[2 * Pairs];
  }
  if constexpr (Pairs > 0) store2(y0, u0), store2(y1, v0);
  if constexpr (Pairs > 1) store2(y0 + 2, u1), store2(y1 + 2, v1);
  if constexpr (Pairs > 2) store2(y0 + 4, u2), store2(y1 + 4, v2);
  if constexpr (Pairs > 3) store2(y0 + 6, u3), store2(y1 + 6, v3);
  if constexpr (Odd) y0[2 * Pairs] = u_last, y1[2 * Pairs] = v_last;
}
inline void subtract_products2(double* y0, double* y1, int n, const double* a, Eigen::Index ld, const double* s0,
                               const double* s1, Eigen::Index s_stride, int count) {
  int i = 0;
  for (; i + 8 <= n; i += 8) subtract_products2_rows<4, false>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count);
  switch (n - i) {
    case 1: subtract_products2_rows<0, true>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 2: subtract_products2_rows<1, false>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 3: subtract_products2_rows<1, true>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 4: subtract_products2_rows<2, false>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 5: subtract_products2_rows<2, true>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 6: subtract_products2_rows<3, false>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    case 7: subtract_products2_rows<3, true>(y0 + i, y1 + i, a + i, ld, s0, s1, s_stride, count); break;
    default: break;
  }
}
// y[i] -= s a[i] for i < n (one more product of subtract_products(), in place).
inline void subtract_scaled(double* y, int n, const double* a, double s) {
  const Pair sv = Pair::Constant(s);
  int i = 0;
  for (; i + 2 <= n; i += 2) store2(y + i, load2(y + i) - sv * load2(a + i));
  if (i < n) y[i] -= s * a[i];
}
// y[i] /= d for i < n (two divisions per operation, each rounding as one).
inline void divide(double* y, double d, int n) {
  const Pair dv = Pair::Constant(d);
  int i = 0;
  for (; i + 2 <= n; i += 2) store2(y + i, load2(y + i) / dv);
  if (i < n) y[i] /= d;
}
// y[i] = x[i] for i < n, two entries per load and store.
inline void copy(double* y, const double* x, int n) {
  int i = 0;
  for (; i + 2 <= n; i += 2) store2(y + i, load2(x + i));
  if (i < n) y[i] = x[i];
}
// y[i] = x[i] + c for i < n, two entries per operation (each rounding as one).
inline void copy_plus(double* y, const double* x, int n, double c) {
  const Pair cv = Pair::Constant(c);
  int i = 0;
  for (; i + 2 <= n; i += 2) store2(y + i, load2(x + i) + cv);
  if (i < n) y[i] = x[i] + c;
}
// y[i] *= s for i < n.
inline void scale(double* y, double s, int n) {
  const Pair sv = Pair::Constant(s);
  int i = 0;
  for (; i + 2 <= n; i += 2) store2(y + i, load2(y + i) * sv);
  if (i < n) y[i] *= s;
}
using Seg = Eigen::Map<Eigen::VectorXd>;
using ConstSeg = Eigen::Map<const Eigen::VectorXd>;

// A = L L^T in place (lower triangle; the upper is not read), right-looking (cholesky_factor
// above is left-looking, on any matrix type: the two round differently, so each caller keeps its
// own); pivots below min_pivot2 are raised to it (cholesky_factor's rule). Computed a column at a
// time (left-looking), which rounds as right-looking does: every entry gets the same products
// subtracted in the same order (column 0's first), then the same scaling.
// Two columns at a time: column k + 1 takes its products j < k with column k's (over rows k..,
// its upper entry at row k computed and put back), then the j = k one once column k is done.
inline void cholesky_lower(Cols a, int n, double min_pivot2) {
  int k = 0;
  for (; k + 2 <= n; k += 2) {
    double* ck = a.col(k);
    double* ck1 = a.col(k + 1);
    const double upper = ck1[k];  // not L's: left as it was
    // - L(i, j) L(k, j) and - L(i, j) L(k + 1, j), j < k
    subtract_products2(ck + k, ck1 + k, n - k, a.p + k, a.ld, a.p + k, a.p + k + 1, a.ld, k);
    ck1[k] = upper;
    const double d = std::sqrt(std::max(ck[k], min_pivot2));
    ck[k] = d;
    scale(ck + k + 1, 1.0 / d, n - k - 1);
    subtract_scaled(ck1 + k + 1, n - k - 1, ck + k + 1, ck[k + 1]);  // - L(i, k) L(k + 1, k)
    const double d1 = std::sqrt(std::max(ck1[k + 1], min_pivot2));
    ck1[k + 1] = d1;
    scale(ck1 + k + 2, 1.0 / d1, n - k - 2);
  }
  if (k < n) {
    double* ck = a.col(k);
    subtract_products(ck + k, n - k, a.p + k, a.ld, a.p + k, a.ld, k);  // - L(i, j) L(k, j), j < k
    const double d = std::sqrt(std::max(ck[k], min_pivot2));
    ck[k] = d;
    scale(ck + k + 1, 1.0 / d, n - k - 1);
  }
}
// x <- L^-1 x (forward substitution) for a vector with stride 1.
inline void lower_solve(Cols l, int n, double* x) {
  for (int k = 0; k < n; ++k) {
    const double* ck = l.col(k);
    const double v = (x[k] /= ck[k]);
    subtract_scaled(x + k + 1, n - k - 1, ck + k + 1, v);
  }
}
// X <- L^-1 X for the `count` rows of X^T given as the columns of xt (xt.col(k) is row k of X, its
// `rhs` entries contiguous): lower_solve() on each column of X at once, rounding as it does (each
// entry gets the products of the rows above it subtracted in row order, then the division), with
// the right-hand sides as the vectorised dimension instead of a column's short tail.
// Two rows at a time: row k + 1 takes its products j < k with row k's, then the j = k one once row k
// is done.
inline void lower_solve_rows(Cols l, int count, Cols xt, int rhs) {
  int k = 0;
  for (; k + 2 <= count; k += 2) {
    double* xk = xt.col(k);
    double* xk1 = xt.col(k + 1);
    // - L(k, j) X(j, :) and - L(k + 1, j) X(j, :), j < k
    subtract_products2(xk, xk1, rhs, xt.p, xt.ld, l.p + k, l.p + k + 1, l.ld, k);
    divide(xk, l(k, k), rhs);
    subtract_scaled(xk1, rhs, xk, l(k + 1, k));  // - L(k + 1, k) X(k, :)
    divide(xk1, l(k + 1, k + 1), rhs);
  }
  if (k < count) {
    double* xk = xt.col(k);
    subtract_products(xk, rhs, xt.p, xt.ld, l.p + k, l.ld, k);  // - L(k, j) X(j, :), j < k
    divide(xk, l(k, k), rhs);
  }
}
// Out = X^T for the rows x cols matrix X, two by two entries per load and store pair (a copy:
// no rounding).
inline void transpose(Cols x, int rows, int cols, Cols out) {
  int i = 0;
  for (; i + 2 <= rows; i += 2) {
    int j = 0;
    for (; j + 2 <= cols; j += 2) {
      const Pair c0 = load2(x.col(j) + i), c1 = load2(x.col(j + 1) + i);  // X(i.., j), X(i.., j + 1)
      store2(out.col(i) + j, Pair(c0[0], c1[0]));
      store2(out.col(i + 1) + j, Pair(c0[1], c1[1]));
    }
    if (j < cols) out(j, i) = x(i, j), out(j, i + 1) = x(i + 1, j);
  }
  if (i < rows)
    for (int j = 0; j < cols; ++j) out(j, i) = x(i, j);
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
