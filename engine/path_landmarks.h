// Lower bounds of the feature path's cost between any two vertices, from a few landmarks (ALT:
// A*, landmarks and the triangle inequality; Goldberg & Harrelson 2005). For every landmark L,
// d(L, t) <= d(L, v) + d(v, t), so |d(L, t) - d(L, v)| bounds the cost from v to t from below,
// and the bound is consistent (it changes by at most an edge's cost along that edge). Off every
// feature the only other bound is the cheapest cost per unit length (the 10% floor) times the
// straight-line distance, ten times too low, and a search guided by it floods a disc; the
// landmarks' bound is close to the true cost there, so a search settles little more than the
// vertices near its path.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace featureline {

class PreparedMesh;
class Executor;
class Cancellation;

class PathLandmarks {
 public:
  static constexpr int kCount = 8;
  /// The floor of the edge cost the distances are measured with (FeaturePathCost of either
  /// sign, InitialLineOptions' default feature_weight_floor): every feature path, whatever its
  /// sign (a sign only raises costs) and whatever its floor above this, costs at least as much
  /// edge by edge; plain edge length too.
  static constexpr double kFloor = 0.1;
  /// Distances in units of unit(); kUnreachable where a landmark's component is not the vertex's.
  static constexpr std::uint16_t kUnreachable = 0xFFFF;
  using Distances = std::array<std::uint16_t, kCount>;

  PathLandmarks() = default;
  PathLandmarks(std::vector<Distances> distance, double unit) : distance_(std::move(distance)), unit_(unit) {}

  bool empty() const { return distance_.empty(); }
  /// The landmarks' distances to v, for lower_bound.
  const Distances& at(std::uint32_t v) const { return distance_[v]; }
  /// A lower bound of the landmark cost between two vertices of one component, from their
  /// distances (at()): exact integers, so the bound is consistent to the last bit.
  double lower_bound(const Distances& a, const Distances& b) const {
    int most = 0;
    for (int i = 0; i < kCount; ++i) {
      const int d = int(a[i]) - int(b[i]);
      most = std::max(most, d < 0 ? -d : d);
    }
    return unit_ * most;
  }
  double unit() const { return unit_; }
  std::size_t memory_bytes() const { return distance_.capacity() * sizeof(Distances); }

 private:
  std::vector<Distances> distance_;  ///< per vertex, each landmark's distance
  double unit_ = 0;
};

/// The landmarks of a prepared mesh (its tables and curvature complete): the vertices of its
/// largest component most extreme along the eight diagonals of its bounding box, and each one's
/// feature-path cost (PathLandmarks::kFloor, either sign) to every vertex, counted in whole units
/// with every edge's cost rounded down, so the stored distances obey the triangle inequality
/// exactly over costs no higher than the true ones. A unit is 1/65534 of twice the first
/// landmark's farthest distance (no distance in the component exceeds that); longer distances
/// are capped, which keeps them a bound. One search per landmark, on `executor`.
PathLandmarks build_path_landmarks(const PreparedMesh& mesh, Executor& executor, const Cancellation* cancel);

}  // namespace featureline
