// Internal to the engine: the one shortest-path search over mesh edges (Dijkstra, or A* with a
// heuristic), shared by the initial line (feature-weighted paths between keys) and segmentation
// (snap chains, joining loose ends), with per-thread scratch whose reset costs O(1).
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <queue>
#include <utility>
#include <vector>

#include "engine/cancellation.h"
#include "engine/prepared_mesh.h"

namespace featureline {

/// Per-thread search scratch whose reset is O(1): an entry is valid only when its stamp equals
/// the current generation. Keeps each query's cost proportional to what it visits, not to the
/// mesh size.
struct SearchScratch {
  std::vector<double> cost;
  std::vector<std::uint32_t> parent;
  std::vector<std::uint32_t> stamp;
  std::vector<std::uint32_t> closed_stamp;
  std::uint32_t generation = 0;

  /// Starts a new query over n vertices.
  void begin(std::size_t n) {
    if (stamp.size() < n) {
      cost.assign(n, 0);
      parent.assign(n, 0);
      stamp.assign(n, 0);
      closed_stamp.assign(n, 0);
      generation = 0;
    }
    if (++generation == 0) {  // wrapped: clear once every 4 billion queries
      std::fill(stamp.begin(), stamp.end(), 0);
      std::fill(closed_stamp.begin(), closed_stamp.end(), 0);
      generation = 1;
    }
  }
  bool seen(std::uint32_t v) const { return stamp[v] == generation; }
  bool closed(std::uint32_t v) const { return closed_stamp[v] == generation; }
};

/// This thread's scratch (one per thread: the server runs searches on several threads at once).
inline SearchScratch& search_scratch() {
  thread_local SearchScratch s;
  return s;
}

/// The cheapest path over mesh edges from `from` to the first vertex `is_goal(v)` accepts, both
/// ends included; empty when no goal is reachable within `max_cost`.
///  - `edge_cost(v, k)`: cost of the edge from v to mesh.neighbors[k], or negative to skip it;
///  - `heuristic(v)`: a lower bound of the cost from v to the goal (A*; return 0 for Dijkstra).
/// Checks `cancel` every 4096 settled vertices. Settles vertices in (cost + heuristic, id) order,
/// so equal-cost ties resolve the same way on every run.
template <class IsGoal, class EdgeCost, class Heuristic>
std::vector<std::uint32_t> cheapest_edge_path(const PreparedMesh& mesh, std::uint32_t from, IsGoal&& is_goal,
                                              EdgeCost&& edge_cost, Heuristic&& heuristic, double max_cost,
                                              const Cancellation* cancel = nullptr) {
  SearchScratch& s = search_scratch();
  s.begin(mesh.n_vertices());
  using Entry = std::pair<double, std::uint32_t>;  // (cost + heuristic, vertex)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  s.cost[from] = 0;
  s.parent[from] = from;
  s.stamp[from] = s.generation;
  open.emplace(heuristic(from), from);
  std::size_t settled = 0;
  std::uint32_t found = from;
  bool reached = false;
  while (!open.empty()) {
    const std::uint32_t v = open.top().second;
    open.pop();
    if (s.closed(v)) continue;
    s.closed_stamp[v] = s.generation;
    if ((++settled & 4095) == 0) throw_if_cancelled(cancel);
    if (is_goal(v)) {
      found = v;
      reached = true;
      break;
    }
    for (auto k = mesh.neighbor_offsets[v]; k < mesh.neighbor_offsets[v + 1]; ++k) {
      const auto w = mesh.neighbors[k];
      if (s.closed(w)) continue;
      const double step = edge_cost(v, k);
      if (step < 0) continue;
      const double cost = s.cost[v] + step;
      if (cost > max_cost) continue;
      if (!s.seen(w) || cost < s.cost[w]) {
        s.stamp[w] = s.generation;
        s.cost[w] = cost;
        s.parent[w] = v;
        open.emplace(cost + heuristic(w), w);
      }
    }
  }
  std::vector<std::uint32_t> path;
  if (!reached) return path;
  path.push_back(found);
  while (path.back() != from) path.push_back(s.parent[path.back()]);
  std::reverse(path.begin(), path.end());
  return path;
}

/// The shortest path by edge length from `from` to the first vertex `is_goal` accepts, no
/// longer than `max_length` (Dijkstra).
template <class IsGoal>
std::vector<std::uint32_t> shortest_path_to(const PreparedMesh& mesh, std::uint32_t from, IsGoal&& is_goal,
                                            double max_length) {
  return cheapest_edge_path(
      mesh, from, is_goal, [&mesh](std::uint32_t, std::uint32_t k) { return mesh.neighbor_edge_lengths[k]; },
      [](std::uint32_t) { return 0.0; }, max_length);
}

}  // namespace featureline
