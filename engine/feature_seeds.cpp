#include "engine/feature_seeds.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include <Eigen/Dense>

#include "engine/errors.h"
#include "engine/internal/geometry.h"
#include "engine/internal/stopwatch.h"

namespace featureline {

void check_feature_seed_options(const FeatureSeedOptions& options) {
  using O = FeatureSeedOptions;
  auto check = [](const ValidRange& range, double value, const char* name) { check_in_range(range, value, name); };
  check(O::max_crease_chains_range, options.max_crease_chains, "max_crease_chains");
  check(O::min_chain_edges_range, options.min_chain_edges, "min_chain_edges");
  check(O::corner_angle_range, options.corner_angle, "corner_angle");
  check(O::junction_turn_range, options.junction_turn, "junction_turn");
  check(O::max_vertices_per_sign_range, options.max_vertices_per_sign, "max_vertices_per_sign");
  check(O::spacing_range, options.spacing, "spacing");
  check(O::crease_clearance_range, options.crease_clearance, "crease_clearance");
  check(O::min_strength_range, options.min_strength, "min_strength");
  check(O::min_signal_to_noise_range, options.min_signal_to_noise, "min_signal_to_noise");
}

namespace {

// A seed's crest test: the fitted field's peak across the crest lies within this many local
// edge lengths of the vertex. Of the vertices either side of a crest that runs between them,
// one is always this close, so every crest has vertices that pass.
constexpr double kCrestOffset = 0.5;
// Within the two rings, no vertex within 45 degrees of the across direction (cosine below) has
// a feature value more than this share above the vertex's: on noisy fields the fit alone
// passes the odd flank vertex (in 6 ridge fields at 0-30% noise, one of 120 seeds, 3.7 grid
// spacings off the crest; none at any share from 0.05 to 0.2).
constexpr double kAcrossCone = 0.70710678118654752;
constexpr double kAcrossRise = 0.1;
// An isolated peak rather than a line: the field falls along its slowest direction at least
// this share as fast as across (then no crest direction is reported).
constexpr double kPeakRatio = 0.5;

double crease_sign_value(FeatureSign sign) { return sign == FeatureSign::ridge ? 1.0 : -1.0; }

// The adjacency entry of edge v -> w (in v's row), or kNoIndex.
std::uint32_t entry_of(const PreparedMesh& mesh, std::uint32_t v, std::uint32_t w) {
  for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k)
    if (mesh.neighbors()[k] == w) return k;
  return kNoIndex;
}

// The angle between the normals of edge (v, w)'s two faces, radians (0: flat), as the curvature
// stage measures it when it marks creases; 0 unless the edge has exactly two faces.
double dihedral_angle(const PreparedMesh& mesh, std::uint32_t v, std::uint32_t w) {
  const auto& P = mesh.positions();
  Eigen::Vector3d normals[2];
  int found = 0;
  for (const std::uint32_t f : mesh.faces_around(v)) {
    const Triangle& t = mesh.triangles()[f];
    if (corner_of(t, w) < 0) continue;
    if (found < 2) normals[found] = (P[t[1]] - P[t[0]]).cross(P[t[2]] - P[t[0]]);
    ++found;
  }
  return found == 2 ? angle_between(normals[0], normals[1]) : 0.0;
}

// The crease edges of one sign as the chain walk reads them: each vertex's entries of that
// sign, sorted by neighbour id so walks do not depend on the adjacency's circulator order.
struct SignedCreaseEdges {
  std::vector<std::uint32_t> offsets, entries;  ///< entries of v: entries[offsets[v] .. offsets[v+1])
  std::size_t degree(std::uint32_t v) const { return offsets[v + 1] - offsets[v]; }
};

SignedCreaseEdges signed_crease_edges(const PreparedMesh& mesh, std::int8_t sign) {
  const std::size_t n = mesh.n_vertices();
  SignedCreaseEdges edges;
  edges.offsets.assign(n + 1, 0);
  for (std::uint32_t v = 0; v < n; ++v) {
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k)
      if (mesh.curvature().crease[k] == sign) edges.entries.push_back(k);
    edges.offsets[v + 1] = std::uint32_t(edges.entries.size());
    std::sort(edges.entries.begin() + edges.offsets[v], edges.entries.end(),
              [&](std::uint32_t a, std::uint32_t b) { return mesh.neighbors()[a] < mesh.neighbors()[b]; });
  }
  return edges;
}

// The turn (radians) a chain makes at v coming in along edge (a, v) and going out along (v, b).
double turn_at(const PreparedMesh& mesh, std::uint32_t a, std::uint32_t v, std::uint32_t b) {
  const auto& P = mesh.positions();
  return angle_between(P[v] - P[a], P[b] - P[v]);
}

// Which crease edges of a junction v a chain goes on through (FeatureSeedOptions::
// junction_turn): pairs of v's entries, the straightest first, each taken while both its edges
// are free, it turns at most `max_turn`, and every rival pair (one of its edges with another free
// edge) turns kJunctionMarginDegrees more, a rival edge beside the other one (a face's second
// edge marked by noise) excepted.
void pair_junction(const PreparedMesh& mesh, const SignedCreaseEdges& edges, std::uint32_t v, double max_turn,
                   std::vector<std::uint32_t>& partner) {
  const auto begin = edges.offsets[v], end = edges.offsets[v + 1];
  auto end_of = [&](std::uint32_t i) { return mesh.neighbors()[edges.entries[i]]; };
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs;
  for (auto i = begin; i < end; ++i)
    for (auto j = i + 1; j < end; ++j) pairs.emplace_back(turn_at(mesh, end_of(i), v, end_of(j)), i, j);
  std::sort(pairs.begin(), pairs.end());
  const double margin = kJunctionMarginDegrees * kPi / 180;
  auto is_free = [&](std::uint32_t i) { return partner[edges.entries[i]] == kNoIndex; };
  for (const auto& [turn, i, j] : pairs) {
    if (turn > max_turn) break;
    if (!is_free(i) || !is_free(j)) continue;
    bool clear = true;
    for (auto r = begin; r < end && clear; ++r) {
      if (r == i || r == j || !is_free(r)) continue;
      clear = (turn_at(mesh, end_of(i), v, end_of(r)) >= turn + margin || mesh.are_neighbors(end_of(j), end_of(r))) &&
              (turn_at(mesh, end_of(r), v, end_of(j)) >= turn + margin || mesh.are_neighbors(end_of(i), end_of(r)));
    }
    if (!clear) continue;
    partner[edges.entries[i]] = edges.entries[j];
    partner[edges.entries[j]] = edges.entries[i];
  }
}

// Per adjacency entry v -> w of a crease edge of the sign: the entry v -> u a chain arriving at
// v from w leaves by (kNoIndex: the chain ends at v). Counts junctions and corners.
std::vector<std::uint32_t> chain_partners(const PreparedMesh& mesh, const SignedCreaseEdges& edges, double corner_radians,
                                          double junction_radians, FeatureSeedStatistics& stats) {
  std::vector<std::uint32_t> partner(mesh.neighbors().size(), kNoIndex);
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
    const std::size_t degree = edges.degree(v);
    if (degree > 2) {
      ++stats.junctions;
      pair_junction(mesh, edges, v, junction_radians, partner);
    }
    if (degree != 2) continue;
    const auto i = edges.entries[edges.offsets[v]], j = edges.entries[edges.offsets[v] + 1];
    if (turn_at(mesh, mesh.neighbors()[i], v, mesh.neighbors()[j]) > corner_radians) {
      ++stats.corners;
      continue;
    }
    partner[i] = j;
    partner[j] = i;
  }
  return partner;
}

// Maximal chains of the crease edges of `sign`, split where chain_partners ends them, appended
// to `chains` (vertices, closed, sign and length; the dihedral angle is measured later, for the
// chains returned only).
void walk_crease_chains(const PreparedMesh& mesh, FeatureSign sign, double corner_radians, double junction_radians,
                        std::vector<CreaseChainSeed>& chains, FeatureSeedStatistics& stats, const Cancellation* cancel) {
  const SignedCreaseEdges edges = signed_crease_edges(mesh, std::int8_t(crease_sign_value(sign)));
  if (edges.entries.empty()) return;
  const std::vector<std::uint32_t> partner = chain_partners(mesh, edges, corner_radians, junction_radians, stats);
  std::vector<char> used(mesh.neighbors().size(), 0);
  auto mark_used = [&](std::uint32_t v, std::uint32_t k) {
    used[k] = 1;
    const auto twin = entry_of(mesh, mesh.neighbors()[k], v);
    if (twin != kNoIndex) used[twin] = 1;
  };
  // From `start` along entry k until the chain ends or comes back to `start`; every step uses
  // an unused edge, so a walk ends within the number of crease edges.
  auto walk = [&](std::uint32_t start, std::uint32_t k) {
    CreaseChainSeed chain;
    chain.sign = sign;
    chain.vertices.push_back(start);
    std::uint32_t current = start;
    while (true) {
      mark_used(current, k);
      const auto next = mesh.neighbors()[k];
      chain.length += mesh.neighbor_edge_lengths()[k];
      if (next == start) {
        chain.closed = true;
        break;
      }
      chain.vertices.push_back(next);
      const auto arrival = entry_of(mesh, next, current);
      const auto following = arrival == kNoIndex ? kNoIndex : partner[arrival];
      if (following == kNoIndex || used[following]) break;
      current = next;
      k = following;
    }
    chains.push_back(std::move(chain));
  };
  // Chains with ends first, from their ends (by vertex id, then neighbour id); what is left are
  // cycles, each from its lowest vertex towards that vertex's lower neighbour.
  for (const bool ends : {true, false})
    for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
      if ((v & 4095) == 0) throw_if_cancelled(cancel);
      for (auto i = edges.offsets[v]; i < edges.offsets[v + 1]; ++i) {
        const auto k = edges.entries[i];
        if (!used[k] && (!ends || partner[k] == kNoIndex)) walk(v, k);
      }
    }
}

double length_weighted_dihedral_degrees(const PreparedMesh& mesh, const CreaseChainSeed& chain) {
  double sum = 0, weight = 0;
  const std::size_t m = chain.vertices.size();
  for (std::size_t i = 0; i < chain.edges(); ++i) {
    const auto a = chain.vertices[i], b = chain.vertices[(i + 1) % m];
    const double length = (mesh.positions()[b] - mesh.positions()[a]).norm();
    sum += length * dihedral_angle(mesh, a, b);
    weight += length;
  }
  return weight > 0 ? sum / weight * 180 / kPi : 0.0;
}

// v and its two rings of edges, leaving out vertices on creases and not passing through them
// (across a crease lies another surface). A two-ring has a few dozen vertices, so a linear
// search of what was visited is cheaper than a mesh-sized table.
void two_rings_off_creases(const PreparedMesh& mesh, std::uint32_t v, std::vector<std::uint32_t>& hood) {
  std::vector<std::uint32_t> visited{v}, frontier{v}, next;
  hood.assign(1, v);
  for (int ring = 0; ring < 2; ++ring) {
    next.clear();
    for (auto u : frontier)
      for (auto k = mesh.neighbor_offsets()[u]; k < mesh.neighbor_offsets()[u + 1]; ++k) {
        const auto w = mesh.neighbors()[k];
        if (std::find(visited.begin(), visited.end(), w) != visited.end()) continue;
        visited.push_back(w);
        if (mesh.curvature().on_crease[w]) continue;
        hood.push_back(w);
        next.push_back(w);
      }
    frontier.swap(next);
  }
}

// A quadratic fitted to the feature field of `sign` over v's two rings (two_rings_off_creases),
// in v's tangent plane, in units of its local edge length h: f = c0 + c1 x + c2 y + c3 x^2/2 +
// c4 xy + c5 y^2/2, with the Hessian's eigen-decomposition (eigenvalues ascending: across the
// crest first, along it second).
struct FieldFit {
  Eigen::Vector3d u, w;  ///< the tangent frame (x along u, y along w)
  Eigen::MatrixXd A;     ///< one row per fitted vertex, v first: 1, x, y, x^2/2, xy, y^2/2
  Eigen::VectorXd values;
  Eigen::Vector2d gradient;
  double across = 0, along = 0;
  Eigen::Vector2d across_direction, along_direction;
  Eigen::Vector3d along_3d() const { return (along_direction.x() * u + along_direction.y() * w).normalized(); }
};

std::optional<FieldFit> fit_field(const PreparedMesh& mesh, std::uint32_t v, double sign) {
  const auto& P = mesh.positions();
  const Eigen::Vector3d normal = mesh.vertex_normals()[v];
  const double h = mesh.local_edge_length(v);
  if (!(normal.squaredNorm() > 0) || !(h > 0)) return std::nullopt;
  std::vector<std::uint32_t> hood;
  two_rings_off_creases(mesh, v, hood);
  if (hood.size() < 8) return std::nullopt;
  FieldFit fit;
  fit.u = normal.unitOrthogonal();
  fit.w = normal.normalized().cross(fit.u);
  fit.A.resize(Eigen::Index(hood.size()), 6);
  fit.values.resize(Eigen::Index(hood.size()));
  for (std::size_t i = 0; i < hood.size(); ++i) {
    const Eigen::Vector3d d = (P[hood[i]] - P[v]) / h;
    const double x = d.dot(fit.u), y = d.dot(fit.w);
    fit.A.row(Eigen::Index(i)) << 1, x, y, 0.5 * x * x, x * y, 0.5 * y * y;
    fit.values[Eigen::Index(i)] = feature_value(mesh.curvature(), hood[i], sign);
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(fit.A);
  if (qr.rank() < 6) return std::nullopt;
  const Eigen::VectorXd c = qr.solve(fit.values);
  Eigen::Matrix2d hessian;
  hessian << c[3], c[4], c[4], c[5];
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(hessian);
  fit.gradient = Eigen::Vector2d(c[1], c[2]);
  fit.across = eigen.eigenvalues()[0];
  fit.along = eigen.eigenvalues()[1];
  fit.across_direction = eigen.eigenvectors().col(0);
  fit.along_direction = eigen.eigenvectors().col(1);
  return fit;
}

struct CrestTest {
  bool on_crest = false;
  std::optional<Eigen::Vector3d> direction;
};

// Is v on a crest of the feature field of `sign`? Across the crest (the fitted Hessian's most
// negative direction) the fitted parabola's peak must lie within kCrestOffset, the field must
// not rise faster along than it falls across, and no vertex across may be clearly stronger than
// v. The crest's direction is the Hessian's other eigenvector.
CrestTest test_crest(const PreparedMesh& mesh, std::uint32_t v, double sign) {
  CrestTest test;
  const std::optional<FieldFit> fit = fit_field(mesh, v, sign);
  if (!fit) return test;
  const double across = fit->across, along = fit->along;
  // A crest falls across it faster than it rises along it; the other way round is a saddle of
  // the field (where k_max turns from one direction to the other on a bent ridge's inner side).
  if (!(across < 0) || !(along <= -across)) return test;
  const double offset = -fit->gradient.dot(fit->across_direction) / across;
  if (!(std::abs(offset) <= kCrestOffset)) return test;
  // The fit can pass a flank vertex of a noisy field; the field's own values across the crest
  // must not rise much above v's anywhere within the two rings.
  for (Eigen::Index i = 1; i < fit->A.rows(); ++i) {
    const Eigen::Vector2d d(fit->A(i, 1), fit->A(i, 2));
    if (std::abs(d.dot(fit->across_direction)) >= kAcrossCone * d.norm() && fit->values[i] > (1 + kAcrossRise) * fit->values[0])
      return test;
  }
  test.on_crest = true;
  if (!(along < kPeakRatio * across)) {
    Eigen::Vector3d direction = fit->along_3d();
    Eigen::Index largest = 0;
    direction.cwiseAbs().maxCoeff(&largest);
    if (direction[largest] < 0) direction = -direction;
    test.direction = direction;
  }
  return test;
}

// Per vertex: whether it is within `rings` rings of edges of a crease vertex or a boundary
// vertex (breadth-first from all of them at once; each vertex is reached once).
std::vector<char> near_creases_or_boundary(const PreparedMesh& mesh, int rings) {
  const std::size_t n = mesh.n_vertices();
  std::vector<char> near(n, 0);
  std::vector<std::uint32_t> frontier, next;
  for (std::uint32_t v = 0; v < n; ++v)
    if (mesh.curvature().on_crease[v] || mesh.boundary_vertex()[v]) near[v] = 1, frontier.push_back(v);
  for (int ring = 0; ring < rings && !frontier.empty(); ++ring) {
    next.clear();
    for (auto u : frontier)
      for (auto k = mesh.neighbor_offsets()[u]; k < mesh.neighbor_offsets()[u + 1]; ++k)
        if (!near[mesh.neighbors()[k]]) near[mesh.neighbors()[k]] = 1, next.push_back(mesh.neighbors()[k]);
    frontier.swap(next);
  }
  return near;
}

// The seeds of one sign: candidates strongest first, each taken when it is far enough from the
// seeds already taken and passes the crest test (fitted only for candidates not suppressed).
std::vector<FeatureVertexSeed> find_vertex_seeds(const PreparedMesh& mesh, FeatureSign sign, const FeatureSeedOptions& options,
                                                 const std::vector<char>& excluded,
                                                 std::size_t& candidate_count, const Cancellation* cancel) {
  std::vector<FeatureVertexSeed> seeds;
  if (options.max_vertices_per_sign == 0) return seeds;
  const CurvatureField& field = mesh.curvature();
  const double s = crease_sign_value(sign);
  const double floor_times_h = noise_floor_times_edge(field, options.min_signal_to_noise);
  std::vector<std::pair<double, std::uint32_t>> candidates;  // (strength, vertex)
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
    if (mesh.component()[v] < 0 || excluded[v]) continue;
    const double value = feature_value(field, v, s);
    const double strength = value / mesh.curvature_scale();
    if (!(value > 0) || !(strength >= options.min_strength)) continue;
    if (floor_times_h > 0 && !(value * mesh.local_edge_length(v) >= floor_times_h)) continue;
    candidates.emplace_back(strength, v);
  }
  candidate_count = candidates.size();
  std::sort(candidates.begin(), candidates.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
  std::vector<double> suppression_radius;
  for (std::size_t i = 0; i < candidates.size() && seeds.size() < std::size_t(options.max_vertices_per_sign); ++i) {
    if ((i & 4095) == 0) throw_if_cancelled(cancel);
    const auto [strength, v] = candidates[i];
    bool suppressed = false;
    for (std::size_t j = 0; j < seeds.size() && !suppressed; ++j)
      suppressed = (mesh.positions()[v] - mesh.positions()[seeds[j].vertex]).norm() < suppression_radius[j];
    if (suppressed) continue;
    const CrestTest crest = test_crest(mesh, v, s);
    if (!crest.on_crest) continue;
    FeatureVertexSeed seed;
    seed.vertex = v;
    seed.sign = sign;
    seed.curvature = sign == FeatureSign::ridge ? field.k_max[v] : field.k_min[v];
    seed.strength = strength;
    seed.direction = crest.direction;
    seeds.push_back(seed);
    suppression_radius.push_back(options.spacing * mesh.local_edge_length(v));
  }
  return seeds;
}

}  // namespace

FeatureSeeds find_feature_seeds(const PreparedMesh& mesh, const FeatureSeedOptions& options, const Cancellation* cancel) {
  check_feature_seed_options(options);
  auto clock = StageClock::now();
  FeatureSeeds seeds;
  FeatureSeedStatistics& stats = seeds.stats;

  std::vector<CreaseChainSeed> chains;
  const double corner_radians = options.corner_angle * kPi / 180, junction_radians = options.junction_turn * kPi / 180;
  for (auto sign : {FeatureSign::ridge, FeatureSign::valley})
    walk_crease_chains(mesh, sign, corner_radians, junction_radians, chains, stats, cancel);
  const auto too_short = [&](const CreaseChainSeed& c) { return c.edges() < std::size_t(options.min_chain_edges); };
  const auto kept_end = std::stable_partition(chains.begin(), chains.end(), [&](const auto& c) { return !too_short(c); });
  stats.short_chains = std::size_t(chains.end() - kept_end);
  chains.erase(kept_end, chains.end());
  stats.crease_chains = chains.size();
  // A total order, so equal lengths (a symmetric part's chains) come out the same every run.
  std::sort(chains.begin(), chains.end(), [](const CreaseChainSeed& a, const CreaseChainSeed& b) {
    if (a.length != b.length) return a.length > b.length;
    if (a.vertices.front() != b.vertices.front()) return a.vertices.front() < b.vertices.front();
    if (a.sign != b.sign) return a.sign == FeatureSign::ridge;
    return a.vertices < b.vertices;
  });
  if (chains.size() > std::size_t(options.max_crease_chains)) chains.resize(std::size_t(options.max_crease_chains));
  for (auto& chain : chains) chain.dihedral_degrees = length_weighted_dihedral_degrees(mesh, chain);
  seeds.crease_chains = std::move(chains);

  const std::vector<char> excluded = near_creases_or_boundary(mesh, options.crease_clearance);
  seeds.ridge_vertices = find_vertex_seeds(mesh, FeatureSign::ridge, options, excluded, stats.ridge_candidates, cancel);
  seeds.valley_vertices = find_vertex_seeds(mesh, FeatureSign::valley, options, excluded, stats.valley_candidates, cancel);
  stats.noise_floor_strength = noise_floor_times_edge(mesh.curvature(), options.min_signal_to_noise) /
                               mesh.statistics().mean_edge_length / mesh.curvature_scale();
  stats.elapsed_ms = lap_ms(clock);
  return seeds;
}

}  // namespace featureline
