// Nearest-vertex queries on a prepared mesh: a k-d tree (nanoflann) over the vertices that
// belong to a triangle, built once in prepare_mesh, so a key given as a point is snapped in
// O(log n) instead of a scan over every vertex per key.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace featureline {

class VertexIndex {
 public:
  VertexIndex();
  /// Indexes vertex v of `positions` when component[v] >= 0 (it belongs to a triangle). Reads
  /// the points in place: `positions`' buffer must outlive the index and not be reallocated
  /// (moving the vector keeps its buffer).
  VertexIndex(const std::vector<Eigen::Vector3d>& positions, const std::vector<std::int32_t>& component);
  ~VertexIndex();
  VertexIndex(VertexIndex&&) noexcept;
  VertexIndex& operator=(VertexIndex&&) noexcept;

  /// The indexed vertex nearest p (Euclidean); among equally near ones the lowest id, as a scan
  /// over the vertices in id order finds it. \pre the index holds a vertex and p is finite.
  std::uint32_t nearest(const Eigen::Vector3d& p) const;
  std::size_t memory_bytes() const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
};

}  // namespace featureline
