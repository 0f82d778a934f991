#include "engine/initial_line.h"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <queue>
#include <sstream>

#include "engine/errors.h"
#include "engine/internal/edge_search.h"
#include "engine/internal/geometry.h"

namespace featureline {
namespace {

bool is_blocked(const std::vector<std::uint32_t>* blocked, std::uint32_t v) {
  return blocked != nullptr && std::binary_search(blocked->begin(), blocked->end(), v);
}

// Discrete rank scores of the paper: among n candidates the best gets n, the worst 1.
// Ties share the mean of their ranks, so equal candidates are not ordered arbitrarily.
void rank_scores(const std::vector<double>& badness, std::vector<double>& score) {
  const std::size_t n = badness.size();
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return badness[a] < badness[b]; });
  score.assign(n, 0);
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j < n && badness[order[j]] == badness[order[i]]) ++j;
    // ranks (0-based, best first) i..j-1 map to scores n-i .. n-j+1
    const double mean_score = double(n) - 0.5 * double(i + j - 1);
    for (std::size_t k = i; k < j; ++k) score[order[k]] = mean_score;
    i = j;
  }
}

}  // namespace

double keys_feature_sign(const PreparedMesh& mesh, const std::vector<std::uint32_t>& keys, const InitialLineOptions& options) {
  if (!options.sign_aware) return 0;
  int positive = 0, negative = 0;
  for (auto k : keys) {
    const double h = dominant_curvature(mesh.curvature(), k) / mesh.curvature_scale();
    if (h > 0.05) ++positive;
    if (h < -0.05) ++negative;
  }
  if (positive == int(keys.size())) return 1;
  if (negative == int(keys.size())) return -1;
  return 0;
}

double path_length(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path, bool closed) {
  double length = 0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (mesh.positions()[path[i]] - mesh.positions()[path[i - 1]]).norm();
  if (closed && path.size() > 2) length += (mesh.positions()[path.front()] - mesh.positions()[path.back()]).norm();
  return length;
}

// Creases steer the marching as they steer the feature path: between two keys on creases, a
// crease edge out of the current vertex is the feature whatever the curvature ranks say, and a
// chord across a face (CurvatureField::chord: on a CAD cap's skinny triangles it cuts the
// rounded corner) is none. Keeps the crease candidates when there are any, else drops the
// chords when anything else is left.
void keep_crease_candidates(const PreparedMesh& mesh, std::uint32_t current, std::uint32_t goal,
                            std::vector<std::uint32_t>& candidates) {
  const auto& on_crease = mesh.curvature().on_crease;
  if (on_crease.empty() || !on_crease[current] || !on_crease[goal]) return;
  std::vector<std::uint32_t> creases, others;
  for (auto v : candidates) {
    const auto k = mesh.edge_slot(current, v);
    if (mesh.is_crease_slot(k, 0)) creases.push_back(v);
    else if (!mesh.curvature().chord[k]) others.push_back(v);
  }
  if (!creases.empty()) candidates.swap(creases);
  else if (!others.empty()) candidates.swap(others);
}

std::optional<std::vector<std::uint32_t>> marching_search(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                          const InitialLineOptions& options, std::string* failure,
                                                          const std::vector<std::uint32_t>* blocked, const Cancellation* cancel) {
  auto fail = [&](std::string why) -> std::optional<std::vector<std::uint32_t>> {
    if (failure != nullptr) *failure = std::move(why);
    return std::nullopt;
  };
  const auto& P = mesh.positions();
  const Eigen::Vector3d start_to_end = P[to] - P[from];  // V_{s,e}
  // Lengths near the keys, not the mesh's mean edge: a fine part beside a coarse one would
  // otherwise allow too few steps and call every edge near the end "within two edges".
  const double edge = mesh.local_edge_length(to);
  const double finest = std::min(edge, mesh.local_edge_length(from));
  // Termination guard: a sensible line is at most a few times the straight distance (in edges).
  const std::size_t max_steps =
      std::min<std::size_t>(mesh.n_vertices(), std::size_t(8.0 * start_to_end.norm() / finest) + 64);

  SearchScratch& seen = search_scratch();
  seen.begin(mesh.n_vertices());
  std::vector<std::uint32_t> path{from};
  seen.mark_seen(from);
  std::vector<std::uint32_t> candidates;
  std::vector<double> angle_to_goal, angle_to_previous, distance, curvature_badness;
  std::vector<double> f_o1, f_o2, f_d, f_c;
  double closest = start_to_end.norm();
  auto C = [&](std::uint32_t v) { return dominant_curvature(mesh.curvature(), v); };
  const double goal_curvature = C(to);

  while (true) {
    const std::uint32_t current = path.back();
    const std::uint32_t begin = mesh.neighbor_offsets()[current], end = mesh.neighbor_offsets()[current + 1];
    // Step 3: if v_e is in V_a it is v_suc and the search ends.
    for (auto k = begin; k < end; ++k)
      if (mesh.neighbors()[k] == to) {
        path.push_back(to);
        return path;
      }
    if ((path.size() & 1023) == 0) throw_if_cancelled(cancel);
    if (path.size() > max_steps)
      return fail("marching did not reach the end key within " + std::to_string(max_steps) + " steps");
    candidates.clear();
    for (auto k = begin; k < end; ++k) {
      const auto v = mesh.neighbors()[k];
      if (!seen.seen(v) && !is_blocked(blocked, v)) candidates.push_back(v);
    }
    if (candidates.empty()) return fail("marching ran into a dead end (every neighbour already visited)");
    keep_crease_candidates(mesh, current, to, candidates);

    const Eigen::Vector3d previous_direction =
        path.size() >= 2 ? Eigen::Vector3d(P[current] - P[path[path.size() - 2]]) : start_to_end;  // V_{pre,c}
    const std::size_t n = candidates.size();
    angle_to_goal.resize(n);
    angle_to_previous.resize(n);
    distance.resize(n);
    curvature_badness.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = candidates[i];
      const Eigen::Vector3d step = P[v] - P[current];  // V_{c,i}
      angle_to_goal[i] = angle_between(step, start_to_end);
      angle_to_previous[i] = angle_between(step, previous_direction);
      distance[i] = (P[to] - P[v]).norm();
      switch (options.marching_curvature_term) {
        case MarchingCurvatureTerm::similar_to_current:
          curvature_badness[i] = std::abs(C(v) - C(current));
          break;
        case MarchingCurvatureTerm::similar_to_end:
          curvature_badness[i] = std::abs(C(v) - goal_curvature);
          break;
        case MarchingCurvatureTerm::high_magnitude: curvature_badness[i] = -std::abs(C(v)); break;
      }
    }
    rank_scores(angle_to_goal, f_o1);
    rank_scores(angle_to_previous, f_o2);
    rank_scores(distance, f_d);
    rank_scores(curvature_badness, f_c);
    std::size_t best = 0;
    double best_score = -HUGE_VAL;
    for (std::size_t i = 0; i < n; ++i) {
      // Eq. (10): F = alpha f_O1 + beta f_O2 + gamma f_D + delta f_C
      const double F = options.marching_alpha * f_o1[i] + options.marching_beta * f_o2[i] +
                       options.marching_gamma * f_d[i] + options.marching_delta * f_c[i];
      if (F > best_score) best_score = F, best = i;
    }
    const auto next = candidates[best];
    seen.mark_seen(next);
    path.push_back(next);
    // Passing the end: once within two edges of v_e, moving clearly away means it went by.
    const double d = (P[to] - P[next]).norm();
    if (closest < 2 * edge && d > closest + 2 * edge)
      return fail("marching passed the end key without reaching it");
    // Overshoot along V_{s,e}: the line is well beyond the end key's plane.
    if ((P[next] - P[from]).dot(start_to_end) > start_to_end.squaredNorm() + 3 * edge * start_to_end.norm())
      return fail("marching overshot the end key");
    closest = std::min(closest, d);
  }
}

FeaturePathCost::FeaturePathCost(const PreparedMesh& mesh, const InitialLineOptions& options, double feature_sign)
    : mesh_(mesh),
      floor_(std::clamp(options.feature_weight_floor, 1e-6, 1.0)),
      sign_(feature_sign),
      noisy_(mesh.curvature().noise >= kNoisyCreaseNoise) {}

std::optional<std::vector<std::uint32_t>> shortest_edge_path(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                             bool feature_weighted, const InitialLineOptions& options,
                                                             double feature_sign,
                                                             const std::vector<std::uint32_t>* blocked,
                                                             const Cancellation* cancel, double max_cost) {
  // Bounds that keep the search between the two keys: the cheapest possible cost per unit
  // length (the floor), and the landmarks' costs, which every feature path's edge costs at least
  // (at a floor below theirs, the share the lower floor can take off: cost(f) / cost(f0) is
  // smallest, f / f0, on an edge of full strength).
  std::vector<std::uint32_t> path;
  if (feature_weighted) {
    FeaturePathCost cost(mesh, options, feature_sign);
    const CostBounds bounds{cost.floor(), std::min(1.0, cost.floor() / PathLandmarks::kFloor)};
    path = cheapest_path_between(mesh, from, to, cost, blocked, bounds, max_cost, cancel);
  } else {
    const auto length = [&mesh](std::uint32_t, std::uint32_t k) { return mesh.neighbor_edge_lengths()[k]; };
    path = cheapest_path_between(mesh, from, to, length, blocked, CostBounds{1.0, 1.0}, max_cost, cancel);
  }
  if (path.empty()) return std::nullopt;
  return path;
}

InitialLineResult find_initial_line(const PreparedMesh& mesh, const std::vector<std::uint32_t>& keys, bool closed,
                                    const InitialLineOptions& options, const Cancellation* cancel) {
  throw_if_cancelled(cancel);
  if (keys.size() < 2) throw InvalidInputError("a feature line needs at least two keys");
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] >= mesh.n_vertices())
      throw InvalidInputError("key " + std::to_string(i) + " is vertex " + std::to_string(keys[i]) +
                              ", but the mesh has only " + std::to_string(mesh.n_vertices()) + " vertices");
    if (mesh.component()[keys[i]] < 0)
      throw GeometryError("key " + std::to_string(i) + " (vertex " + std::to_string(keys[i]) + ") belongs to no triangle");
    if (mesh.component()[keys[i]] != mesh.component()[keys[0]])
      throw GeometryError("keys 0 and " + std::to_string(i) + " (vertices " + std::to_string(keys[0]) + " and " +
                          std::to_string(keys[i]) + ") lie on different connected components of the mesh");
  }
  const std::size_t segments = closed ? keys.size() : keys.size() - 1;
  for (std::size_t i = 0; i < segments; ++i)
    if (keys[i] == keys[(i + 1) % keys.size()])
      throw InvalidInputError("keys " + std::to_string(i) + " and " + std::to_string((i + 1) % keys.size()) +
                              " are the same vertex " + std::to_string(keys[i]));

  InitialLineResult result;
  result.method = options.method;
  const double sign = keys_feature_sign(mesh, keys, options);
  std::vector<std::uint32_t> used;  // sorted: vertices already on the line (not to be crossed again)
  auto mark_used = [&](const std::vector<std::uint32_t>& path) {
    for (auto v : path) used.insert(std::lower_bound(used.begin(), used.end(), v), v);
  };
  // Later keys are blocked for earlier segments, so a segment does not run through a key it
  // does not end at (the line would then visit that key twice).
  // Merged rather than inserted one by one: linear per segment, so many keys stay cheap.
  std::vector<std::uint32_t> sorted_keys = keys;
  std::sort(sorted_keys.begin(), sorted_keys.end());
  sorted_keys.erase(std::unique(sorted_keys.begin(), sorted_keys.end()), sorted_keys.end());

  for (std::size_t seg = 0; seg < segments; ++seg) {
    const auto a = keys[seg], b = keys[(seg + 1) % keys.size()];
    std::vector<std::uint32_t> blocked;
    blocked.reserve(used.size() + sorted_keys.size());
    std::set_union(used.begin(), used.end(), sorted_keys.begin(), sorted_keys.end(), std::back_inserter(blocked));
    // The segment's own ends must stay reachable.
    blocked.erase(std::remove_if(blocked.begin(), blocked.end(), [&](std::uint32_t v) { return v == a || v == b; }),
                  blocked.end());

    std::optional<std::vector<std::uint32_t>> path;
    if (options.method == InitialMethod::marching) {
      std::string why;
      path = marching_search(mesh, a, b, options, &why, &blocked, cancel);
      if (!path) {
        if (!options.fallback)
          throw GeometryError("marching search failed between keys " + std::to_string(seg) + " and " +
                              std::to_string((seg + 1) % keys.size()) + ": " + why);
        result.fallbacks.push_back({seg, InitialMethod::marching, InitialMethod::feature_path, why});
      }
    }
    if (!path) {
      const bool weighted = options.method != InitialMethod::geodesic;
      path = shortest_edge_path(mesh, a, b, weighted, options, sign, &blocked, cancel);
      if (!path) {
        // The blocked vertices may wall the end off (e.g. a loop through a narrow part).
        path = shortest_edge_path(mesh, a, b, weighted, options, sign, nullptr, cancel);
        if (path)
          result.warnings.push_back("segment " + std::to_string(seg) +
                                    " had to cross the line's earlier segments to reach its end key");
      }
      if (!path) throw GeometryError("no edge path joins vertices " + std::to_string(a) + " and " + std::to_string(b));
    }
    if (seg == 0) {
      result.key_indices.push_back(0);
      result.vertices.push_back(a);
    }
    result.vertices.insert(result.vertices.end(), path->begin() + 1, path->end());
    // Every later stage costs in proportion to the line's length: bounded here, by design.
    if (result.vertices.size() - 1 > std::size_t(options.max_edges))
      throw InvalidInputError("the line through the keys has more than " + std::to_string(options.max_edges) +
                              " edges (reached at key " + std::to_string((seg + 1) % keys.size()) +
                              "); split it into shorter lines");
    mark_used(*path);
    if (!closed || seg + 1 < segments) result.key_indices.push_back(result.vertices.size() - 1);
  }
  if (closed) result.vertices.pop_back();  // the loop's last vertex is its first key again
  // Two neighbouring keys: the way back retraced their edge, a loop that encloses nothing.
  if (closed && result.vertices.size() < 3)
    throw GeometryError("a closed line through vertices " + std::to_string(keys[0]) + " and " + std::to_string(keys[1]) +
                        " alone runs along their edge and back; give a third key on the loop");
  result.length = path_length(mesh, result.vertices, closed);
  return result;
}

}  // namespace featureline
