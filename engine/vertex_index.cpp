#include "engine/vertex_index.h"

#include <cmath>
#include <stdexcept>
#include <utility>

#include <nanoflann.hpp>

namespace featureline {

/// nanoflann's dataset interface over the indexed vertices (tree point i is vertex ids[i]).
struct IndexedPoints {
  const Eigen::Vector3d* positions = nullptr;
  std::vector<std::uint32_t> ids;
  std::size_t kdtree_get_point_count() const { return ids.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return positions[ids[i]][Eigen::Index(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;  // let nanoflann compute it
  }
};

struct VertexIndex::Tree {
  using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, IndexedPoints>,
                                                     IndexedPoints, 3, std::uint32_t>;
  IndexedPoints points;  // before `tree`, which keeps a reference to it
  KdTree tree;
  explicit Tree(IndexedPoints p)
      : points(std::move(p)), tree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
};

VertexIndex::VertexIndex() = default;
VertexIndex::~VertexIndex() = default;
VertexIndex::VertexIndex(VertexIndex&&) noexcept = default;
VertexIndex& VertexIndex::operator=(VertexIndex&&) noexcept = default;

VertexIndex::VertexIndex(const std::vector<Eigen::Vector3d>& positions, const std::vector<std::int32_t>& component) {
  IndexedPoints points;
  points.positions = positions.data();
  for (std::uint32_t v = 0; v < positions.size(); ++v)
    if (component[v] >= 0) points.ids.push_back(v);
  points.ids.shrink_to_fit();
  tree_ = std::make_unique<Tree>(std::move(points));
}

std::uint32_t VertexIndex::nearest(const Eigen::Vector3d& p) const {
  if (!tree_ || tree_->points.ids.empty()) throw std::logic_error("nearest vertex asked of an empty index");
  const double query[3] = {p.x(), p.y(), p.z()};
  std::uint32_t found = 0;
  double distance = 0;
  tree_->tree.knnSearch(query, 1, &found, &distance);
  // Equally near vertices (copies made for non-manifold faces sit on their originals) are
  // decided as a scan in id order would: the lowest id, by Eigen's own distance. The radius
  // allows for nanoflann summing the squares in another order.
  std::vector<std::pair<std::uint32_t, double>> near;
  const double radius = distance * (1 + 1e-9) + 1e-300;
  nanoflann::SearchParams params;
  params.sorted = false;
  tree_->tree.radiusSearch(query, radius, near, params);
  std::uint32_t best = tree_->points.ids[found];
  double best_distance = (tree_->points.positions[best] - p).squaredNorm();
  for (const auto& [i, unused] : near) {
    const std::uint32_t v = tree_->points.ids[i];
    const double d = (tree_->points.positions[v] - p).squaredNorm();
    if (d < best_distance || (d == best_distance && v < best)) best = v, best_distance = d;
  }
  return best;
}

std::size_t VertexIndex::memory_bytes() const {
  if (!tree_) return 0;
  // The tree's nodes (nanoflann's pool and its permutation array) and our id list.
  return sizeof(Tree) + tree_->tree.usedMemory(tree_->tree) + tree_->points.ids.capacity() * sizeof(std::uint32_t);
}

}  // namespace featureline
