#include "engine/path_landmarks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "engine/cancellation.h"
#include "engine/executor.h"
#include "engine/initial_line.h"
#include "engine/prepared_mesh.h"

namespace featureline {
namespace {

// A monotone priority queue of integer keys (a radix heap; Ahuja, Mehlhorn, Orlin & Tarjan
// 1990): an entry sits in the bucket of the highest bit in which its key differs from the last
// key taken out, so each entry moves down at most 32 times. Dijkstra's keys never decrease.
class RadixHeap {
 public:
  using Entry = std::pair<std::uint32_t, std::uint32_t>;
  bool empty() const { return size_ == 0; }
  void push(std::uint32_t key, std::uint32_t value) {
    buckets_[bucket_of(key)].emplace_back(key, value);
    ++size_;
  }
  Entry pop() {
    if (buckets_[0].empty()) {
      std::size_t i = 1;
      while (buckets_[i].empty()) ++i;
      last_ = std::min_element(buckets_[i].begin(), buckets_[i].end())->first;
      for (const auto& entry : buckets_[i]) buckets_[bucket_of(entry.first)].push_back(entry);
      buckets_[i].clear();
    }
    const Entry top = buckets_[0].back();
    buckets_[0].pop_back();
    --size_;
    return top;
  }

 private:
  std::size_t bucket_of(std::uint32_t key) const {
    return key == last_ ? 0 : std::size_t(32 - __builtin_clz(key ^ last_));
  }
  std::array<std::vector<Entry>, 33> buckets_;
  std::uint32_t last_ = 0;
  std::size_t size_ = 0;
};

// Single-source cheapest costs over the mesh's edges, in whole units (`units[k]`: the edge in
// adjacency slot k), capped at kLongest (a cap keeps them a bound); kNever where no edge leads.
constexpr std::uint32_t kNever = std::numeric_limits<std::uint32_t>::max(), kLongest = kNever - 1;
std::vector<std::uint32_t> cheapest_units_from(const PreparedMesh& mesh, std::uint32_t source,
                                               const std::vector<std::uint32_t>& units, const Cancellation* cancel) {
  std::vector<std::uint32_t> cost(mesh.n_vertices(), kNever);
  RadixHeap open;
  cost[source] = 0;
  open.push(0, source);
  std::size_t count = 0;
  while (!open.empty()) {
    const auto [c, v] = open.pop();
    if (c != cost[v]) continue;  // a later, cheaper entry took its place
    if ((++count & 4095) == 0) throw_if_cancelled(cancel);
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
      const auto w = mesh.neighbors()[k];
      const std::uint32_t next = units[k] < kLongest - c ? c + units[k] : kLongest;
      if (next < cost[w]) cost[w] = next, open.push(next, w);
    }
  }
  return cost;
}

// Corners of the box (bit 0: +x, bit 1: +y, bit 2: +z): a regular tetrahedron's first, then the
// opposite one's, so fewer landmarks still spread out.
constexpr int kCorners[8] = {7, 1, 2, 4, 0, 6, 5, 3};

// The vertices of the largest component most extreme towards the box's corners.
std::vector<std::uint32_t> pick_landmarks(const PreparedMesh& mesh) {
  std::vector<std::size_t> size;
  for (auto c : mesh.component())
    if (c >= 0) size.resize(std::max(size.size(), std::size_t(c) + 1)), ++size[std::size_t(c)];
  if (size.empty()) return {};
  const auto largest = std::int32_t(std::max_element(size.begin(), size.end()) - size.begin());
  std::vector<std::uint32_t> picked(PathLandmarks::kCount, UINT32_MAX);
  std::vector<double> extent(PathLandmarks::kCount, -HUGE_VAL);
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
    if (mesh.component()[v] != largest) continue;
    const auto& p = mesh.positions()[v];
    for (int i = 0; i < PathLandmarks::kCount; ++i) {
      const int c = kCorners[i];
      const double along = ((c & 1) ? p.x() : -p.x()) + ((c & 2) ? p.y() : -p.y()) + ((c & 4) ? p.z() : -p.z());
      if (along > extent[i]) extent[i] = along, picked[i] = v;
    }
  }
  return picked;
}

}  // namespace

PathLandmarks build_path_landmarks(const PreparedMesh& mesh, Executor& executor, const Cancellation* cancel) {
  const auto landmarks = pick_landmarks(mesh);
  if (landmarks.empty()) return {};
  InitialLineOptions options;
  options.feature_weight_floor = PathLandmarks::kFloor;
  const auto& offsets = mesh.neighbor_offsets();
  std::vector<double> edge_cost(mesh.neighbors().size());
  executor.parallel_for(mesh.n_vertices(), 4096, [&](std::size_t begin, std::size_t end, std::size_t) {
    FeaturePathCost cost(mesh, options, 0);
    for (auto v = std::uint32_t(begin); v < end; ++v)
      for (auto k = offsets[v]; k < offsets[v + 1]; ++k) edge_cost[k] = std::max(0.0, cost(v, k));
  });
  // Edge costs in whole units, rounded down (and capped, which keeps them below the true costs).
  const auto in_units = [&edge_cost](double unit, double cap) {
    std::vector<std::uint32_t> units(edge_cost.size());
    for (std::size_t k = 0; k < units.size(); ++k) units[k] = std::uint32_t(std::min(std::floor(edge_cost[k] / unit), cap));
    return units;
  };
  // The unit: twice the first landmark's farthest cost (which bounds every cost within its
  // component) over the distances' range, measured in units a thousand times finer. Distances
  // it underestimates (edges far shorter than the mean lose most of their fine units) are capped,
  // which keeps them bounds.
  const double range = PathLandmarks::kUnreachable - 1;
  const double fine = mesh.statistics().mean_edge_length * PathLandmarks::kFloor / 1000;
  if (!(fine > 0) || !std::isfinite(fine)) return {};  // no edge length to measure in: no bounds
  std::uint32_t farthest = 0;
  for (auto c : cheapest_units_from(mesh, landmarks[0], in_units(fine, double(kLongest)), cancel))
    if (c != kNever) farthest = std::max(farthest, c);
  const double unit = farthest > 0 ? 2 * double(farthest) * fine / range : 1;
  const auto units = in_units(unit, PathLandmarks::kUnreachable);
  edge_cost = {};

  std::vector<PathLandmarks::Distances> distance(mesh.n_vertices());
  executor.parallel_for(PathLandmarks::kCount, 1, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto from_landmark = cheapest_units_from(mesh, landmarks[i], units, cancel);
      for (std::size_t v = 0; v < from_landmark.size(); ++v)
        distance[v][i] = from_landmark[v] == kNever
                             ? PathLandmarks::kUnreachable
                             : std::uint16_t(std::min<std::uint32_t>(from_landmark[v], PathLandmarks::kUnreachable - 1));
    }
  });
  return PathLandmarks(std::move(distance), unit);
}

}  // namespace featureline
