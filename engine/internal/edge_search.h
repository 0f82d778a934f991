// Internal to the engine: the one shortest-path search over mesh edges (Dijkstra, or A* with a
// heuristic), shared by the initial line (feature-weighted paths between keys) and segmentation
// (snap chains, joining loose ends), with per-thread scratch whose reset costs O(1).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <queue>
#include <utility>
#include <vector>

#include "engine/cancellation.h"
#include "engine/prepared_mesh.h"
#include "engine/scratch_memory.h"

namespace featureline {

/// Per-thread search scratch whose reset is O(1): an entry is valid only when its stamp equals
/// the current generation. Keeps each query's cost proportional to what it visits, not to the
/// mesh size. The stamps (with the settled bit) are an array of their own, 4 bytes a vertex:
/// the test every relaxed edge makes first (is its far end settled?) reads that array alone.
struct SearchScratch {
  struct Label {
    double cost;
    std::uint32_t parent;
  };
  std::vector<std::uint32_t> state;  ///< generation << 1 | settled
  std::vector<Label> labels;
  std::uint32_t generation = 0;

  SearchScratch() = default;
  SearchScratch(const SearchScratch&) = delete;
  SearchScratch& operator=(const SearchScratch&) = delete;
  ~SearchScratch() { account_scratch_bytes(-bytes()); }
  std::ptrdiff_t bytes() const {
    return std::ptrdiff_t(state.capacity() * sizeof(std::uint32_t) + labels.capacity() * sizeof(Label));
  }

  /// Starts a new query over n vertices.
  void begin(std::size_t n) {
    if (state.size() < n) {
      const std::ptrdiff_t before = bytes();
      state.assign(n, 0);
      labels.assign(n, Label{0, 0});
      generation = 0;
      account_scratch_bytes(bytes() - before);
    }
    if (++generation == (1u << 31)) {  // wrapped: clear once every 2 billion queries
      std::fill(state.begin(), state.end(), 0);
      generation = 1;
    }
  }
  bool seen(std::uint32_t v) const { return (state[v] >> 1) == generation; }
  bool closed(std::uint32_t v) const { return state[v] == (generation << 1 | 1); }
  void mark_seen(std::uint32_t v) { state[v] = generation << 1; }
  /// Settles v (a settled vertex counts as seen).
  void close(std::uint32_t v) { state[v] = generation << 1 | 1; }
  double cost(std::uint32_t v) const { return labels[v].cost; }
  std::uint32_t parent(std::uint32_t v) const { return labels[v].parent; }
  /// Labels v with (cost, parent) for this query; v must not be settled.
  void label(std::uint32_t v, double cost, std::uint32_t parent) {
    labels[v] = Label{cost, parent};
    state[v] = generation << 1;
  }
};

/// This thread's scratch (one per thread: the server runs searches on several threads at once).
/// `which` 1 is a second one, for the backward half of a search from both ends.
inline SearchScratch& search_scratch(int which = 0) {
  thread_local SearchScratch s[2];
  return s[which];
}

/// The cost of reaching w = mesh.neighbors()[k] from the settled vertex v, when that improves w's
/// label within max_cost; -1 otherwise (w settled, the edge skipped, NaN costs).
template <class EdgeCost>
double improved_cost(const SearchScratch& s, std::uint32_t v, std::uint32_t k, std::uint32_t w, EdgeCost& edge_cost,
                     double max_cost) {
  if (s.closed(w)) return -1;
  const double step = edge_cost(v, k);
  if (!(step >= 0)) return -1;
  const double cost = s.cost(v) + step;
  if (!(cost <= max_cost) || (s.seen(w) && !(cost < s.cost(w)))) return -1;
  return cost;
}

/// The cheapest path over mesh edges from `from` to the first vertex `is_goal(v)` accepts, both
/// ends included; empty when no goal is reachable within `max_cost`.
///  - `edge_cost(v, k)`: cost of the edge from v to mesh.neighbors()[k], or negative to skip it;
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
  s.label(from, 0, from);
  open.emplace(heuristic(from), from);
  std::size_t settled = 0;
  std::uint32_t found = from;
  bool reached = false;
  while (!open.empty()) {
    const std::uint32_t v = open.top().second;
    open.pop();
    if (s.closed(v)) continue;
    s.close(v);
    if ((++settled & 4095) == 0) throw_if_cancelled(cancel);
    if (is_goal(v)) {
      found = v;
      reached = true;
      break;
    }
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
      const auto w = mesh.neighbors()[k];
      const double cost = improved_cost(s, v, k, w, edge_cost, max_cost);
      if (cost < 0) continue;
      s.label(w, cost, v);
      open.emplace(cost + heuristic(w), w);
    }
  }
  std::vector<std::uint32_t> path;
  if (!reached) return path;
  path.push_back(found);
  while (path.back() != from) path.push_back(s.parent(path.back()));
  std::reverse(path.begin(), path.end());
  return path;
}

/// What a search between two vertices may assume of every edge's cost, for its lower bounds.
struct CostBounds {
  double slope = 0;  ///< no edge costs less than `slope` times its length
  /// No edge costs less than `landmarks` times its cost in the prepared mesh's landmarks
  /// (engine/path_landmarks.h: a feature path's cost at their floor, either sign); 0: the
  /// landmarks are not used.
  double landmarks = 0;
};

/// The average potential p(v) = (h(v, to) - h(v, from)) / 2 of a search from both ends (Ikeda
/// et al. 1994), where h(v, e) is the larger of two consistent lower bounds of the cost from v
/// to e: the straight-line one (slope |v - e|) and the landmarks' (Goldberg & Harrelson 2005).
class AveragePotential {
 public:
  AveragePotential(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to, const CostBounds& bounds)
      : mesh_(mesh), landmarks_(mesh.landmarks()), bounds_(bounds), from_(from), to_(to),
        use_landmarks_(bounds.landmarks > 0 && !landmarks_.empty()) {
    if (use_landmarks_) at_from_ = landmarks_.at(from), at_to_ = landmarks_.at(to);
  }
  double operator()(std::uint32_t v) const {
    const auto& P = mesh_.positions();
    double to_end = bounds_.slope * (P[to_] - P[v]).norm(), to_start = bounds_.slope * (P[from_] - P[v]).norm();
    if (use_landmarks_) {
      const auto& at_v = landmarks_.at(v);
      to_end = std::max(to_end, bounds_.landmarks * landmarks_.lower_bound(at_v, at_to_));
      to_start = std::max(to_start, bounds_.landmarks * landmarks_.lower_bound(at_v, at_from_));
    }
    return 0.5 * (to_end - to_start);
  }

 private:
  const PreparedMesh& mesh_;
  const PathLandmarks& landmarks_;
  CostBounds bounds_;
  std::uint32_t from_, to_;
  bool use_landmarks_;
  PathLandmarks::Distances at_from_{}, at_to_{};
};

/// The cheapest path over mesh edges between `from` and `to`, both included; empty when none
/// costs at most `max_cost`. A* from both ends at once with the average potential
/// (AveragePotential): forward keys g_f + p, backward keys g_b - p, both consistent, so the
/// search stops once the two smallest keys sum to the best path found. Where no feature guides
/// it and only the straight-line bound is given, a one-sided search floods a disc as wide as the
/// segment is long and the two halves two discs half as wide; the landmarks' bound keeps both
/// near the path.
///  - `edge_cost(v, k)`: cost of the edge between v and mesh.neighbors()[k], the same both ways;
///    negative to skip it;
///  - `blocked`: vertices no path may pass through (its two ends always may), or nullptr; they
///    are marked settled on both sides before the search, so they cost nothing per edge;
///  - `bounds`: what every edge's cost is at least (CostBounds).
/// Settles vertices in (key, id) order on the side with the smaller key, so ties resolve the same
/// way on every run. Checks `cancel` every 4096 settled vertices.
template <class EdgeCost>
std::vector<std::uint32_t> cheapest_path_between(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                 EdgeCost&& edge_cost, const std::vector<std::uint32_t>* blocked,
                                                 const CostBounds& bounds, double max_cost,
                                                 const Cancellation* cancel = nullptr) {
  if (from == to) return {from};
  const AveragePotential potential(mesh, from, to, bounds);
  using Entry = std::pair<double, std::uint32_t>;  // (cost + signed potential, vertex)
  using Queue = std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>>;
  SearchScratch* side[2] = {&search_scratch(0), &search_scratch(1)};
  Queue open[2];
  const std::uint32_t start[2] = {from, to};
  const double direction[2] = {1, -1};
  for (int d = 0; d < 2; ++d) {
    side[d]->begin(mesh.n_vertices());
    if (blocked != nullptr)
      for (auto v : *blocked)
        if (v != from && v != to) side[d]->close(v);
    side[d]->label(start[d], 0, start[d]);
    open[d].emplace(direction[d] * potential(start[d]), start[d]);
  }
  double best = HUGE_VAL;
  std::uint32_t meet = from;
  bool met = false;  // both sides labelled `meet`, at a total cost `best` within max_cost
  std::size_t settled = 0;
  while (!open[0].empty() && !open[1].empty() && open[0].top().first + open[1].top().first < best) {
    const int d = open[0].top().first <= open[1].top().first ? 0 : 1;
    SearchScratch& s = *side[d];
    const SearchScratch& other = *side[1 - d];
    const std::uint32_t v = open[d].top().second;
    open[d].pop();
    if (s.closed(v)) continue;
    s.close(v);
    if ((++settled & 4095) == 0) throw_if_cancelled(cancel);
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
      const auto w = mesh.neighbors()[k];
      const double cost = improved_cost(s, v, k, w, edge_cost, max_cost);
      if (cost < 0) continue;
      s.label(w, cost, v);
      open[d].emplace(cost + direction[d] * potential(w), w);
      if (other.seen(w) && cost + other.cost(w) < best && cost + other.cost(w) <= max_cost)
        best = cost + other.cost(w), meet = w, met = true;
    }
  }
  std::vector<std::uint32_t> path;
  if (!met) return path;
  for (std::uint32_t v = meet; v != from; v = side[0]->parent(v)) path.push_back(v);
  path.push_back(from);
  std::reverse(path.begin(), path.end());
  for (std::uint32_t v = meet; v != to;) path.push_back(v = side[1]->parent(v));
  return path;
}

/// The shortest path by edge length between two vertices, no longer than `max_length`.
inline std::vector<std::uint32_t> shortest_path_between(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                        double max_length) {
  return cheapest_path_between(
      mesh, from, to, [&mesh](std::uint32_t, std::uint32_t k) { return mesh.neighbor_edge_lengths()[k]; }, nullptr,
      CostBounds{1.0, 1.0}, max_length);
}

/// The shortest path by edge length from `from` to the first vertex `is_goal` accepts, no
/// longer than `max_length` (Dijkstra).
template <class IsGoal>
std::vector<std::uint32_t> shortest_path_to(const PreparedMesh& mesh, std::uint32_t from, IsGoal&& is_goal,
                                            double max_length) {
  return cheapest_edge_path(
      mesh, from, is_goal, [&mesh](std::uint32_t, std::uint32_t k) { return mesh.neighbor_edge_lengths()[k]; },
      [](std::uint32_t) { return 0.0; }, max_length);
}

}  // namespace featureline
