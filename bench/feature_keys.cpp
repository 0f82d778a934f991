#include "bench/feature_keys.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace featureline {
namespace {

// Vertices at exactly `rings` edges from `source` (breadth-first).
std::vector<std::uint32_t> ring_at(const PreparedMesh& mesh, std::uint32_t source, int rings) {
  std::vector<std::uint32_t> frontier{source}, next;
  std::unordered_set<std::uint32_t> seen{source};
  for (int r = 0; r < rings; ++r) {
    next.clear();
    for (auto v : frontier)
      for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
        const auto w = mesh.neighbors()[k];
        if (seen.insert(w).second) next.push_back(w);
      }
    frontier.swap(next);
  }
  return frontier;
}

}  // namespace

// Three keys along a feature: a random high-curvature vertex, then the most curved vertex
// of the same sign 12 and 24 rings away (the second farther from the first than the middle).
std::vector<std::uint32_t> pick_feature_keys(const PreparedMesh& mesh, std::mt19937_64& rng) {
  const double threshold = mesh.statistics().abs_curvature_p90;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const auto v0 = std::uint32_t(rng() % mesh.n_vertices());
    if (mesh.component()[v0] < 0 || std::abs(dominant_curvature(mesh.curvature(), v0)) < threshold) continue;
    const double sign = dominant_curvature(mesh.curvature(), v0) > 0 ? 1 : -1;
    auto best_in = [&](const std::vector<std::uint32_t>& ring, std::uint32_t not_near) {
      std::uint32_t best = ring.empty() ? v0 : ring[0];
      double best_score = -1e300;
      for (auto v : ring) {
        const double score = sign * dominant_curvature(mesh.curvature(), v) +
                             (not_near == v0 ? 0 : 1e-3 * (mesh.positions()[v] - mesh.positions()[not_near]).norm());
        if (score > best_score) best_score = score, best = v;
      }
      return best;
    };
    const auto ring12 = ring_at(mesh, v0, 12), ring24 = ring_at(mesh, v0, 24);
    if (ring12.empty() || ring24.empty()) continue;
    const auto v1 = best_in(ring12, v0);
    const auto v2 = best_in(ring24, v0);
    if (v1 == v2 || (mesh.positions()[v2] - mesh.positions()[v0]).norm() < (mesh.positions()[v1] - mesh.positions()[v0]).norm()) continue;
    return {v0, v1, v2};
  }
  return {};
}

// Three keys anywhere: a random vertex, a random vertex `spacing` rings from it, and a random
// vertex `spacing` rings from that one and farther from the first than `spacing` edges would be
// on a straight line's half (so the line does not fold back onto itself).
std::vector<std::uint32_t> pick_random_keys(const PreparedMesh& mesh, std::mt19937_64& rng, int spacing) {
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const auto v0 = std::uint32_t(rng() % mesh.n_vertices());
    if (mesh.component()[v0] < 0) continue;
    const auto ring1 = ring_at(mesh, v0, spacing);
    if (ring1.empty()) continue;
    const auto v1 = ring1[rng() % ring1.size()];
    auto ring2 = ring_at(mesh, v1, spacing);
    const double reach = (mesh.positions()[v1] - mesh.positions()[v0]).norm();
    ring2.erase(std::remove_if(ring2.begin(), ring2.end(),
                               [&](std::uint32_t v) { return (mesh.positions()[v] - mesh.positions()[v0]).norm() < reach; }),
                ring2.end());
    if (ring2.empty()) continue;
    return {v0, v1, ring2[rng() % ring2.size()]};
  }
  return {};
}

}  // namespace featureline
