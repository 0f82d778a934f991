// Internal to the engine: symmetric pentadiagonal matrices and their LDL^T factorisation, the
// linear system of the snake (Eq. 15): its elasticity and rigidity couple each point with its two
// neighbours on either side only. Eigen has no banded factorisation; its sparse LDL^T of this
// matrix did the same arithmetic through index arrays and an elimination tree, and took 6% of a
// line's time (a point's row here is five multiply-adds). No pivoting: the snake's matrices are
// the identity plus positive semidefinite terms, hence positive definite.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace featureline {

/// A symmetric matrix with two diagonals on either side of the main one:
/// M(i, i) = d0[i], M(i, i + 1) = d1[i], M(i, i + 2) = d2[i].
struct SymmetricPentadiagonal {
  std::vector<double> d0, d1, d2;

  std::size_t size() const { return d0.size(); }
  /// An n x n zero matrix.
  void assign_zero(std::size_t n) {
    d0.assign(n, 0.0);
    d1.assign(n > 0 ? n - 1 : 0, 0.0);
    d2.assign(n > 1 ? n - 2 : 0, 0.0);
  }
  /// y = M x, for x of size() entries, summed in column order as Eigen's sparse product does
  /// (y is resized, so a buffer kept across calls is not reallocated).
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    const std::size_t n = size();
    y.resize(Eigen::Index(n));
    for (std::size_t i = 0; i < n; ++i) {
      double sum = 0;
      if (i >= 2) sum += d2[i - 2] * x[Eigen::Index(i - 2)];
      if (i >= 1) sum += d1[i - 1] * x[Eigen::Index(i - 1)];
      sum += d0[i] * x[Eigen::Index(i)];
      if (i + 1 < n) sum += d1[i] * x[Eigen::Index(i + 1)];
      if (i + 2 < n) sum += d2[i] * x[Eigen::Index(i + 2)];
      y[Eigen::Index(i)] = sum;
    }
  }
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const {
    Eigen::VectorXd y;
    multiply(x, y);
    return y;
  }
  /// The block of rows and columns [first, first + count).
  SymmetricPentadiagonal block(std::size_t first, std::size_t count) const {
    SymmetricPentadiagonal b;
    b.d0.assign(d0.begin() + std::ptrdiff_t(first), d0.begin() + std::ptrdiff_t(first + count));
    if (count > 1) b.d1.assign(d1.begin() + std::ptrdiff_t(first), d1.begin() + std::ptrdiff_t(first + count - 1));
    if (count > 2) b.d2.assign(d2.begin() + std::ptrdiff_t(first), d2.begin() + std::ptrdiff_t(first + count - 2));
    return b;
  }
};

/// M = L D L^T with L unit lower triangular of bandwidth 2 (l1: its first subdiagonal, l2: its
/// second) and D diagonal, in O(n). Row by row, the operations of Eigen's up-looking simplicial
/// LDL^T in its order, so the snake's lines are the same to the last bit as they were with it.
class PentadiagonalLDLT {
 public:
  /// false when a pivot is not positive and finite (M is not positive definite).
  bool factorize(const SymmetricPentadiagonal& m) {
    const std::size_t n = m.size();
    d_.resize(n), l1_.resize(n), l2_.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      // Row k of L solves L(0:k, 0:k) D y = M(0:k, k): y_{k-2} = M(k-2, k), then
      // y_{k-1} = M(k-1, k) - l1_{k-1} y_{k-2}; L(k, i) = y_i / D_i, D_k = M(k, k) - sum L(k, i) y_i.
      double pivot = m.d0[k], y1 = k >= 1 ? m.d1[k - 1] : 0.0;
      l2_[k] = l1_[k] = 0;
      if (k >= 2) {
        const double y2 = m.d2[k - 2];
        l2_[k] = y2 / d_[k - 2];
        y1 -= l1_[k - 1] * y2;
        pivot -= l2_[k] * y2;
      }
      if (k >= 1) {
        l1_[k] = y1 / d_[k - 1];
        pivot -= l1_[k] * y1;
      }
      if (!(pivot > 0) || !std::isfinite(pivot)) return false;
      d_[k] = pivot;
    }
    return true;
  }
  /// Solves M x = b in place. \pre factorize(M) returned true, b has M's size
  void solve_in_place(Eigen::VectorXd& b) const {
    const std::size_t n = d_.size();
    for (std::size_t i = 1; i < n; ++i) {  // L z = b, column by column
      if (i >= 2) b[Eigen::Index(i)] -= b[Eigen::Index(i - 2)] * l2_[i];
      b[Eigen::Index(i)] -= b[Eigen::Index(i - 1)] * l1_[i];
    }
    for (std::size_t i = 0; i < n; ++i) b[Eigen::Index(i)] *= 1.0 / d_[i];  // D y = z
    for (std::size_t i = n; i-- > 0;) {  // L^T x = y
      if (i + 1 < n) b[Eigen::Index(i)] -= l1_[i + 1] * b[Eigen::Index(i + 1)];
      if (i + 2 < n) b[Eigen::Index(i)] -= l2_[i + 2] * b[Eigen::Index(i + 2)];
    }
  }

 private:
  std::vector<double> d_, l1_, l2_;
};

}  // namespace featureline
