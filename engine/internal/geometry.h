// Internal to the engine: small geometric and combinatorial helpers that several stages need.
// One definition each, so a fix to one reaches every stage.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace featureline {

constexpr double kPi = 3.14159265358979323846;
/// "No face" / "no vertex" in the engine's uint32 tables (a boundary edge's missing neighbour).
constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();

using Triangle = std::array<std::uint32_t, 3>;

/// One key per undirected edge (lower id in the high half), for hashing and sorting edges.
inline std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(a) << 32) | b;
}

/// The z component of the 2D cross product: twice the signed area of (0, a, b).
inline double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

/// A line's bend from points beside it: the least-squares parabola s = c0 + c1 a + c2 a^2 through
/// points at a along the line's tangent and s across it, both divided by `scale` (a well
/// conditioned system); its curvature 2 c2 / scale toward +s, 0 when the points do not spread
/// along the line enough to show one.
class ParabolaFit {
 public:
  explicit ParabolaFit(double scale) : scale_(scale) {}
  void add(double along, double across) {
    const double a = along / scale_, u = across / scale_;
    const Eigen::Vector3d row(1, a, a * a);
    normal_.noalias() += row * row.transpose();
    rhs_.noalias() += u * row;
  }
  double curvature() const {
    const Eigen::LDLT<Eigen::Matrix3d> solver(normal_);
    const Eigen::Vector3d c = solver.solve(rhs_);
    if (solver.info() == Eigen::Success && c.allFinite() && normal_(2, 2) > 1e-3 * normal_(0, 0)) return 2 * c[2] / scale_;
    return 0;
  }

 private:
  double scale_;
  Eigen::Matrix3d normal_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs_ = Eigen::Vector3d::Zero();
};

/// The unsigned angle between two vectors, accurate near 0 and pi (atan2, not acos).
inline double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// The corner (0..2) of triangle t at vertex v, -1 when v is not a corner.
inline int corner_of(const Triangle& t, std::uint32_t v) {
  for (int k = 0; k < 3; ++k)
    if (t[k] == v) return k;
  return -1;
}

inline double triangle_area(const std::vector<Eigen::Vector3d>& p, const Triangle& t) {
  return 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm();
}

/// Disjoint sets over 0..n-1 with path halving; `unite` makes b's root the root of a's set, so
/// callers decide which representative survives a merge.
class UnionFind {
 public:
  explicit UnionFind(std::size_t n = 0) { reset(n); }
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0u);
  }
  std::uint32_t find(std::uint32_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  /// Joins a's set into b's; returns the surviving root.
  std::uint32_t unite(std::uint32_t a, std::uint32_t b) {
    const auto ra = find(a), rb = find(b);
    parent_[ra] = rb;
    return rb;
  }
  bool is_root(std::uint32_t x) const { return parent_[x] == x; }
  std::size_t size() const { return parent_.size(); }

 private:
  std::vector<std::uint32_t> parent_;
};

}  // namespace featureline
