#include "engine/curvature.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include "engine/errors.h"
#include "engine/executor.h"
#include "engine/internal/geometry.h"
#include "engine/internal/order_statistics.h"
#include "engine/internal/stopwatch.h"

namespace featureline {
namespace {

// Vertices and faces per block of a parallel loop: a few hundred microseconds of fits, so the
// next-block handout stays cheap while uneven work (denser neighbourhoods, creases) still
// spreads over the participants (equal halves of igea's fits took 198 and 226 ms).
constexpr std::size_t kBlock = 1024;

struct JetFit {
  double k_max = 0, k_min = 0;
  double residual = 0;  ///< weighted RMS of the fit's residuals, length units
  bool ok = false;
  bool lopsided = false;  ///< a cubic refused: the neighbourhood lies to one side of the vertex
};

// A cubic over a neighbourhood cut off on one side (the mesh's border, a crease the gathering
// stops at) extrapolates its odd terms to the vertex: its weighted centroid, in fit radii from
// the vertex, above this (about 0.4 for a half disc, under 0.1 inside an irregular mesh) leaves
// the vertex to the quadric.
constexpr double kLopsidedCentroid = 0.1;

// Gathers the vertices within `radius` of v reachable through vertices that are themselves
// within it (a breadth-first search over edges, so the other side of a thin part is not
// mixed in). The search does not continue past crease vertices (other than v), so a smooth
// patch is fitted on its own: the centre of a CAD cap fan sees its flat cap and rim, not the
// side beyond the rim. `stamp` marks visited vertices with `generation`.
void gather(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj, const std::vector<char>& on_crease,
            std::uint32_t v, double radius, std::vector<std::uint32_t>& stamp, std::uint32_t generation,
            std::vector<std::uint32_t>& out) {
  out.assign(1, v);
  // Raw pointers: the stores to `stamp` and `out` would otherwise make the compiler reload
  // every vector's data pointer in the inner loop.
  std::uint32_t* const visited = stamp.data();
  const std::uint32_t* const offsets = adj.offsets.data();
  const std::uint32_t* const neighbors = adj.neighbors.data();
  const Eigen::Vector3d* const points = P.data();
  const Eigen::Vector3d centre = P[v];
  visited[v] = generation;
  const double r2 = radius * radius;
  for (std::size_t head = 0; head < out.size(); ++head) {
    const auto a = out[head];
    if (head > 0 && on_crease[a]) continue;
    for (auto k = offsets[a], end = offsets[a + 1]; k < end; ++k) {
      const auto w = neighbors[k];
      if (visited[w] == generation) continue;
      visited[w] = generation;
      if ((points[w] - centre).squaredNorm() <= r2) out.push_back(w);
    }
  }
}

// The exponents (a, b) of a jet's monomials u^a w^b: the quadric's first 6, then the cubic's.
constexpr int kJetExponents[10][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 0}, {1, 1}, {0, 2}, {3, 0}, {2, 1}, {1, 2}, {0, 3}};

// The weighted moments of a neighbourhood, sum w u^a w^b (a + b <= 2 Degree) and sum w h u^a w^b
// (a + b <= Degree): the normal equations' entries depend only on their monomials' exponent
// sums, so each distinct one is accumulated once (28 products a point for a cubic instead of the
// outer product's 100; the jet fits were half of a scan's preparation).
template <int Degree>
struct JetMoments {
  static constexpr int kPowers = 2 * Degree + 1;
  double m[kPowers][kPowers] = {};
  double mh[Degree + 1][Degree + 1] = {};
  double hh = 0;  ///< sum w h^2

  void add(double u, double w, double h, double weight) {
    double pu[kPowers], pw[kPowers];
    pu[0] = weight, pw[0] = 1;
    for (int k = 1; k < kPowers; ++k) pu[k] = pu[k - 1] * u, pw[k] = pw[k - 1] * w;
    for (int a = 0; a < kPowers; ++a)
      for (int b = 0; a + b < kPowers; ++b) m[a][b] += pu[a] * pw[b];
    for (int a = 0; a <= Degree; ++a)
      for (int b = 0; a + b <= Degree; ++b) mh[a][b] += h * pu[a] * pw[b];
    hh += weight * h * h;
  }
};

// Weighted least-squares fit of the height h = c0 + c1 u + c2 w + c3 u^2 + c4 uw + c5 w^2 (+ the
// cubic's c6 u^3 + c7 u^2 w + c8 u w^2 + c9 w^3) over the neighbourhood, in a frame whose z axis
// is the neighbourhood's mean normal, coordinates scaled by the radius for conditioning. The
// principal curvatures are the eigenvalues of the graph's shape operator I^-1 II at the origin
// (the cubic terms vanish there to second order), so a tilted frame is corrected by c1, c2.
template <int Terms>
JetFit fit_jet(const std::vector<Eigen::Vector3d>& P, const std::vector<Eigen::Vector3d>& N, std::uint32_t v,
               const std::vector<std::uint32_t>& hood, double radius, std::vector<double>& weights) {
  JetFit fit;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  const double inv_r = 1.0 / radius;
  // Gaussian weights, sigma = radius / 2. A compact (1 - d^2/r^2)^2 kernel was 25% faster, but
  // its smaller effective neighbourhood put the refined line on noisy ridges of 24k-245k
  // triangles 30-85% further from the crest (bench_accuracy; slightly closer on 5k).
  // One exponential per point (the frame and the fit use the same weights; `weights` is the
  // caller's scratch).
  weights.resize(hood.size());
  for (std::size_t i = 0; i < hood.size(); ++i) {
    weights[i] = std::exp(-2 * (P[hood[i]] - P[v]).squaredNorm() * inv_r * inv_r);
    n += weights[i] * N[hood[i]];
  }
  if (!(n.norm() > 1e-12)) n = N[v];
  if (!(n.norm() > 1e-12)) return fit;
  n.normalize();
  const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  constexpr int degree = Terms == 10 ? 3 : 2;
  JetMoments<degree> moments;
  for (std::size_t i = 0; i < hood.size(); ++i) {
    const Eigen::Vector3d x = (P[hood[i]] - P[v]) * inv_r;
    moments.add(x.dot(t1), x.dot(t2), x.dot(n), weights[i]);
  }
  Eigen::Matrix<double, Terms, Terms> A;
  Eigen::Matrix<double, Terms, 1> b;
  for (int i = 0; i < Terms; ++i) {
    const int* ei = kJetExponents[i];
    b[i] = moments.mh[ei[0]][ei[1]];
    for (int j = 0; j < Terms; ++j) A(i, j) = moments.m[ei[0] + kJetExponents[j][0]][ei[1] + kJetExponents[j][1]];
  }
  const double weight_sum = moments.m[0][0], hh = moments.hh;
  if (Terms == 10 && std::hypot(A(1, 0), A(2, 0)) > kLopsidedCentroid * A(0, 0)) {
    fit.lopsided = true;
    return fit;
  }
  // A neighbourhood on a line or too few points leaves the jet undetermined. (Within the unit
  // disc the cubic's columns are smaller than the quadric's, hence its looser bound.)
  const Eigen::LDLT<Eigen::Matrix<double, Terms, Terms>> ldlt(A);
  const auto d = ldlt.vectorD();
  const double conditioning = Terms == 6 ? 1e-9 : 1e-12;
  if (ldlt.info() != Eigen::Success || !(d.minCoeff() > conditioning * d.maxCoeff())) return fit;
  const Eigen::Matrix<double, Terms, 1> c = ldlt.solve(b);
  const double c1 = c[1], c2 = c[2];
  const double g = std::sqrt(1 + c1 * c1 + c2 * c2);
  Eigen::Matrix2d first, second;
  first << 1 + c1 * c1, c1 * c2, c1 * c2, 1 + c2 * c2;
  second << 2 * c[3], c[4], c[4], 2 * c[5];
  const Eigen::Matrix2d shape = first.inverse() * (second / g);
  const double tr = shape.trace(), det = shape.determinant();
  const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
  // Height grows along the outward normal, so a convex surface bends to negative h: the
  // convex-positive curvatures are the negated eigenvalues, back in length units.
  fit.k_max = -(0.5 * tr - disc) * inv_r;
  fit.k_min = -(0.5 * tr + disc) * inv_r;
  const double residual2 = std::max(0.0, hh - c.dot(b)) / weight_sum;  // sum w r^2 = h'Wh - c'A c
  fit.residual = std::sqrt(residual2) * radius;
  fit.ok = std::isfinite(fit.k_max) && std::isfinite(fit.k_min);
  return fit;
}

std::vector<double> local_edge_lengths(const AdjacencyView& adj) {
  const std::size_t n = adj.offsets.size() - 1;
  std::vector<double> local(n, 0.0);
  for (std::size_t v = 0; v < n; ++v) {
    const auto begin = adj.offsets[v], end = adj.offsets[v + 1];
    for (auto k = begin; k < end; ++k) local[v] += adj.edge_lengths[k];
    if (end > begin) local[v] /= double(end - begin);
  }
  return local;
}

// Fits every `stride`-th vertex at `radius` local edge lengths; vertices whose fit fails keep
// `fallback`.
// Returns the per-vertex residuals in local edge lengths (negative where no fit was made).
std::vector<double> fit_all(const std::vector<Eigen::Vector3d>& P, const std::vector<Eigen::Vector3d>& N,
                            const AdjacencyView& adj, const std::vector<char>& on_crease,
                            const std::vector<char>& boundary, const std::vector<double>& local, double radius,
                            std::size_t stride,
                            const std::vector<double>& fallback, CurvatureField& field, const Cancellation* cancel,
                            Executor& executor, JetDegree degree = JetDegree::quadric) {
  const std::size_t n = P.size();
  std::vector<double> residual(n, -1.0);
  struct Scratch {
    std::vector<std::uint32_t> stamp, hood;
    std::vector<double> weights;
    std::uint32_t generation = 0;
  };
  // One slot per participant, freed when the fits are done. A slot's vertex stamps are made by
  // the participant on its first block, so only the threads that actually took part hold a
  // mesh-sized array (a few of a large pool when others are busy).
  std::vector<Scratch> scratch(executor.workers());
  executor.parallel_for(n, kBlock, [&](std::size_t begin, std::size_t end, std::size_t worker) {
    auto& [stamp, hood, weights, generation] = scratch[worker];
    if (stamp.empty()) stamp.assign(n, 0);
    for (std::size_t v = begin; v < end; ++v) {
      if ((v & 4095) == 0) throw_if_cancelled(cancel);
      if (v % stride != 0) continue;
      field.k_max[v] = field.k_min[v] = fallback[v];
      if (!(local[v] > 0)) continue;
      JetFit fit;
      double r = radius * local[v];
      // Too few points (coarse or skinny neighbourhoods) widen the radius a few times.
      for (int attempt = 0; attempt < 4 && !fit.ok; ++attempt, r *= 1.5) {
        gather(P, adj, on_crease, std::uint32_t(v), r, stamp, ++generation, hood);
        if (hood.size() < 8) continue;
        // Near the mesh's border the cubic's odd terms extrapolate from one side: quadrics there.
        const bool cubic = degree == JetDegree::cubic &&
                           std::none_of(hood.begin(), hood.end(), [&](std::uint32_t u) { return boundary[u] != 0; });
        if (cubic) fit = fit_jet<10>(P, N, std::uint32_t(v), hood, r, weights);
        if (!cubic || fit.lopsided) fit = fit_jet<6>(P, N, std::uint32_t(v), hood, r, weights);
      }
      if (!fit.ok) continue;
      field.k_max[v] = fit.k_max;
      field.k_min[v] = fit.k_min;
      residual[v] = fit.residual / local[v];
    }
  });
  throw_if_cancelled(cancel);
  return residual;
}

// The crease vertices that bound a jet's neighbourhood (gather): those of crease runs (edges
// joined at shared vertices) at least kMinBarrierExtent of their own mean edge length across (on
// CAD tessellations a crease vertex's other edges are the long sides of skinny faces, several
// times the crease's: measured by those, a noisy rocker arm's broken crease runs all read short),
// and of shorter runs within kBarrierRings of a long run of their sign (a crease broken up by
// noise; beside a convex crease, noise makes short concave runs that are no crease). Noise alone
// bends a few edges here and there past the crease angle, and a fit stopped at them gathers
// little more than a one-ring: on a 20%-noisy valley, crest vertices between such edges read as a
// ridge, holes in the field the snake went round, 1.6 grid spacings off the crest.
constexpr double kMinBarrierExtent = 4;
constexpr int kBarrierRings = 5;

// Crease edges joined at their vertices, and whether the run is long (kMinBarrierExtent).
struct CreaseRun {
  std::vector<std::uint32_t> vertices;
  bool is_long = false;
  int sign = 0;  ///< sum of its edges' signs (each edge counted from both ends)
};

char sign_bit(const CreaseRun& run) { return run.sign >= 0 ? 1 : 2; }

std::vector<CreaseRun> crease_runs(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj,
                                   const CurvatureField& field) {
  std::vector<CreaseRun> runs;
  std::vector<char> in_run(P.size(), 0);
  for (std::uint32_t start = 0; start < P.size(); ++start) {
    if (!field.on_crease[start] || in_run[start]) continue;
    CreaseRun run;
    run.vertices.assign(1, start);
    in_run[start] = 1;
    Eigen::AlignedBox3d box(P[start]);
    double crease_sum = 0;  // each crease edge counted from both ends
    int crease_count = 0;
    for (std::size_t i = 0; i < run.vertices.size(); ++i) {
      const auto v = run.vertices[i];
      box.extend(P[v]);
      for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
        if (field.crease[k] != 0) crease_sum += adj.edge_lengths[k], ++crease_count;
        run.sign += field.crease[k];
        if (field.crease[k] != 0 && !in_run[adj.neighbors[k]])
          in_run[adj.neighbors[k]] = 1, run.vertices.push_back(adj.neighbors[k]);
      }
    }
    run.is_long = box.diagonal().norm() >= kMinBarrierExtent * crease_sum / crease_count;
    runs.push_back(std::move(run));
  }
  return runs;
}

std::vector<char> fit_barriers(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj, const CurvatureField& field) {
  const std::vector<CreaseRun> runs = crease_runs(P, adj, field);
  // Flags the vertices within kBarrierRings of the long runs, ring by ring: 1 near a convex run,
  // 2 near a concave one.
  std::vector<char> near(P.size(), 0);
  std::vector<std::uint32_t> front, next;
  for (const CreaseRun& run : runs)
    if (run.is_long)
      for (auto v : run.vertices) near[v] |= sign_bit(run), front.push_back(v);
  for (int ring = 0; ring < kBarrierRings && !front.empty(); ++ring, front.swap(next)) {
    next.clear();
    for (auto v : front)
      for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
        const auto w = adj.neighbors[k];
        if ((near[w] | near[v]) == near[w]) continue;
        if (!near[w]) next.push_back(w);
        near[w] |= near[v];
      }
  }
  std::vector<char> barrier(P.size(), 0);
  for (const CreaseRun& run : runs)
    if (run.is_long || std::any_of(run.vertices.begin(), run.vertices.end(),
                                   [&](std::uint32_t v) { return (near[v] & sign_bit(run)) != 0; }))
      for (auto v : run.vertices) barrier[v] = 1;
  return barrier;
}

// CurvatureField::chord: the edges joining two crease vertices without being creases, but on
// a noisy mesh none between vertices of the runs the fits stop at (`barrier`).
std::vector<char> mark_chords(const AdjacencyView& adj, const CurvatureField& field, const std::vector<char>& barrier) {
  const bool noisy = field.noise >= kNoisyCreaseNoise;
  std::vector<char> chord(adj.neighbors.size(), 0);
  for (std::uint32_t v = 0; v < field.on_crease.size(); ++v)
    for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
      const auto w = adj.neighbors[k];
      const bool firm_crease_gap = noisy && barrier[v] && barrier[w];
      chord[k] = field.crease[k] == 0 && field.on_crease[v] && field.on_crease[w] && !firm_crease_gap;
    }
  return chord;
}

// Dihedral angle of every adjacency entry's edge (0 on boundary edges) and the far corners of
// its two faces (-1 on the boundary).
struct EdgeAngles {
  std::vector<double> angle;
  std::vector<std::int32_t> corner_a, corner_b;
};

// The adjacency entry of edge v -> w (in v's row), or UINT32_MAX.
std::uint32_t entry_of(const AdjacencyView& adj, std::uint32_t v, std::uint32_t w) {
  for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k)
    if (adj.neighbors[k] == w) return k;
  return kNoIndex;
}

// Entry v -> w is visited once, from the face that runs through the edge from v to w (its far
// corner is a), with b the far corner of the face across. Both directions of an edge are
// measured from their own side, as every later test reads them.
EdgeAngles dihedral_angles(const MeshTablesView& mesh, Executor& executor) {
  const auto& P = mesh.positions;
  const AdjacencyView& adj = mesh.adjacency;
  EdgeAngles out;
  out.angle.assign(adj.neighbors.size(), 0.0);
  out.corner_a.assign(adj.neighbors.size(), -1);
  out.corner_b.assign(adj.neighbors.size(), -1);
  // In parallel over faces. An edge's angle is measured once, by the lower-numbered of its two
  // faces, which writes both directions' entries (the prepared mesh is manifold: OpenMesh took
  // every face, non-manifold ones on copied vertices, so no entry is written twice).
  executor.parallel_for(mesh.triangles.size(), kBlock, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t f = begin; f < end; ++f) {
      const auto& t = mesh.triangles[f];
      for (int side = 0; side < 3; ++side) {
        const std::uint32_t across = mesh.face_neighbors[f][side];
        if (across == kNoIndex || across < f) continue;
        const auto v = t[side], w = t[(side + 1) % 3], a = t[(side + 2) % 3];
        const auto& u = mesh.triangles[across];
        const auto b = u[0] != v && u[0] != w ? u[0] : u[1] != v && u[1] != w ? u[1] : u[2];
        const auto k = entry_of(adj, v, w), twin = entry_of(adj, w, v);
        if (k == kNoIndex || twin == kNoIndex) continue;
        const Eigen::Vector3d e = P[w] - P[v];
        const Eigen::Vector3d na = e.cross(P[a] - P[v]);
        const Eigen::Vector3d nb = (P[b] - P[v]).cross(e);
        if (!(na.norm() > 0) || !(nb.norm() > 0)) continue;
        out.angle[k] = out.angle[twin] = angle_between(na, nb);
        out.corner_a[k] = out.corner_b[twin] = std::int32_t(a);
        out.corner_b[k] = out.corner_a[twin] = std::int32_t(b);
      }
    }
  });
  return out;
}

double angle_of(const AdjacencyView& adj, const EdgeAngles& angles, std::uint32_t v, std::uint32_t w) {
  const auto k = entry_of(adj, v, w);
  return k == kNoIndex ? 0 : angles.angle[k];
}

// +1 where the edge in entry k (from v) is convex, -1 where concave: the far corner of its
// second face lies below the first face's plane. \pre an interior edge.
std::int8_t edge_sign(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj, const EdgeAngles& angles,
                      std::uint32_t v, std::uint32_t k) {
  const auto w = adj.neighbors[k];
  const auto a = std::uint32_t(angles.corner_a[k]), b = std::uint32_t(angles.corner_b[k]);
  const Eigen::Vector3d na = (P[w] - P[v]).cross(P[a] - P[v]);
  return (P[b] - P[v]).dot(na) < 0 ? 1 : -1;
}

// Two faces whose normals differ by less than this (radians) lie in one plane: a CAD
// tessellation's flat face cut into triangles.
constexpr double kCoplanarAngle = 0.5 * kPi / 180;

// Whether edge (v, w) is interior and its two faces lie in one plane.
bool flat_wing(const AdjacencyView& adj, const EdgeAngles& angles, std::uint32_t v, std::uint32_t w) {
  const auto k = entry_of(adj, v, w);
  return k != kNoIndex && angles.corner_a[k] >= 0 && angles.angle[k] < kCoplanarAngle;
}

// An edge is a crease when its dihedral angle exceeds the threshold and stands out from its
// faces' other four edges (the second largest of those under half its angle). A sharp bend
// that crosses triangles instead of following edges spreads over a band of edges, none of
// which is the crease; a CAD crease is one chain of edges between flat-ish faces (at a corner
// one wing edge belongs to the other crease, hence the second largest). On a coarse CAD
// tessellation (a cube of 12 triangles, a chamfered one) every triangle spans a whole side of
// its flat face and touches two creases, so none stands out; there (on a flat-faced mesh) an
// edge between two flat facets, not a band of bent triangles, is a crease too. Signed by edge_sign.
void mark_creases(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj, const EdgeAngles& angles,
                  double angle_degrees, bool flat_faced, CurvatureField& field) {
  field.crease.assign(adj.neighbors.size(), 0);
  field.crease_edges = 0;
  const double threshold = angle_degrees * kPi / 180;
  const auto sign_of = [&](std::uint32_t v, std::uint32_t k) { return edge_sign(P, adj, angles, v, k); };
  // Whether the face (x, y, z), whose edge (z, x) is sharp, is a flat facet of a CAD part: it lies
  // in one plane with a neighbour across (x, y) or (y, z); or a facet of one triangle (a
  // chamfer's corner), all its edges sharp, which counts beside a flat facet only (on scans
  // noise bends a triangle's three edges now and then).
  const auto flat_facet = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return flat_wing(adj, angles, x, y) || flat_wing(adj, angles, y, z);
  };
  const auto one_triangle_facet = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return angle_of(adj, angles, x, y) > threshold && angle_of(adj, angles, y, z) > threshold;
  };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> sharp_but_not_standing_out;  // (v, entry)
  for (std::uint32_t v = 0; v < P.size(); ++v)
    for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
      const double angle = angles.angle[k];
      if (!(angle > threshold) || angles.corner_a[k] < 0) continue;
      const auto w = adj.neighbors[k];
      const auto a = std::uint32_t(angles.corner_a[k]), b = std::uint32_t(angles.corner_b[k]);
      std::array<double, 4> wings = {angle_of(adj, angles, w, a), angle_of(adj, angles, a, v),
                                     angle_of(adj, angles, v, b), angle_of(adj, angles, b, w)};
      const bool facets = flat_faced && ((flat_facet(w, a, v) && (flat_facet(v, b, w) || one_triangle_facet(v, b, w))) ||
                                         (flat_facet(v, b, w) && one_triangle_facet(w, a, v)));
      std::sort(wings.begin(), wings.end());
      if (wings[2] >= 0.5 * angle && !facets) {
        sharp_but_not_standing_out.emplace_back(v, k);
        continue;
      }
      field.crease[k] = sign_of(v, k);
    }
  // A sharp edge whose wings are sharp too but which continues the loose end of a crease run
  // of its own sign is that crease: where a crease meets a corner, or on CAD tessellations
  // with a skinny face at the crease's end, a wing can be as sharp as the crease (rocker arm:
  // the end edge of two of its three chains; fandisk: of three chains at 90-degree corners).
  // In a band of bent triangles no edge stands out, so there is no run end to continue.
  std::vector<int> crease_degree(P.size(), 0);
  std::vector<std::int8_t> end_sign(P.size(), 0);
  for (std::uint32_t v = 0; v < P.size(); ++v)
    for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k)
      if (field.crease[k] != 0) ++crease_degree[v], end_sign[v] = field.crease[k];
  for (const auto& [v, k] : sharp_but_not_standing_out) {
    const auto w = adj.neighbors[k];
    const auto sign = sign_of(v, k);
    const bool continues_v = crease_degree[v] == 1 && end_sign[v] == sign;
    const bool continues_w = crease_degree[w] == 1 && end_sign[w] == sign;
    if (continues_v || continues_w) field.crease[k] = sign;
  }
  for (std::uint32_t v = 0; v < P.size(); ++v)
    for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k)
      if (field.crease[k] != 0 && v < adj.neighbors[k]) ++field.crease_edges;
}

// CurvatureField::fold: each edge's dihedral angle over the crease angle, signed as
// mark_creases signs creases.
std::vector<std::int8_t> signed_folds(const std::vector<Eigen::Vector3d>& P, const AdjacencyView& adj,
                                      const EdgeAngles& angles, double angle_degrees, Executor& executor) {
  std::vector<std::int8_t> fold(adj.neighbors.size(), 0);
  const double threshold = angle_degrees * kPi / 180;
  executor.parallel_for(P.size(), kBlock, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (auto v = std::uint32_t(begin); v < end; ++v)
      for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
        if (angles.corner_a[k] < 0) continue;
        const double share = std::min(1.0, angles.angle[k] / threshold);
        fold[k] = std::int8_t(edge_sign(P, adj, angles, v, k) * std::lround(CurvatureField::kFoldScale * share));
      }
  });
  return fold;
}

// The principal curvatures while they are smoothed: k_max and k_min side by side per vertex,
// and each vertex's neighbours across smooth edges (in adjacency order, so every sum adds the
// same terms in the same order as over the adjacency). Values are not averaged across crease
// edges: the two sides of a crease are different surfaces, and blurring one into the other
// moves the field's crest off the crease.
struct SmoothedField {
  std::vector<std::uint32_t> offsets, neighbors;
  std::vector<std::array<double, 2>> values, next;  ///< (k_max, k_min) per vertex; next: a pass's output
};

SmoothedField start_smoothing(const CurvatureField& field, const AdjacencyView& adjacency) {
  SmoothedField s;
  const std::size_t n = field.k_max.size();
  s.offsets.resize(n + 1);
  s.neighbors.reserve(adjacency.neighbors.size());
  s.values.resize(n);
  s.next.resize(n);
  for (std::size_t v = 0; v < n; ++v) {
    s.offsets[v] = std::uint32_t(s.neighbors.size());
    for (auto k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k)
      if (field.crease[k] == 0) s.neighbors.push_back(adjacency.neighbors[k]);
    s.values[v] = {field.k_max[v], field.k_min[v]};
  }
  s.offsets[n] = std::uint32_t(s.neighbors.size());
  return s;
}

void finish_smoothing(const SmoothedField& s, CurvatureField& field) {
  for (std::size_t v = 0; v < s.values.size(); ++v) field.k_max[v] = s.values[v][0], field.k_min[v] = s.values[v][1];
}

// One pass of the umbrella average, half weight on the vertex itself.
void smooth_once(SmoothedField& s, Executor& executor) {
  executor.parallel_for(s.values.size(), kBlock, [&](std::size_t first, std::size_t last, std::size_t) {
    for (std::size_t v = first; v < last; ++v) {
      const auto begin = s.offsets[v], end = s.offsets[v + 1];
      if (begin == end) {
        s.next[v] = s.values[v];
        continue;
      }
      double sum_max = 0, sum_min = 0;
      for (auto k = begin; k < end; ++k) {
        const auto& w = s.values[s.neighbors[k]];
        sum_max += w[0], sum_min += w[1];
      }
      const int count = int(end - begin);
      s.next[v] = {0.5 * (s.values[v][0] + sum_max / count), 0.5 * (s.values[v][1] + sum_min / count)};
    }
  });
  s.values.swap(s.next);
}

// How rough the principal curvature fields are for their size: the median difference between
// a vertex's value and its neighbours' mean, over the 90th percentile of the values. Noise is
// rough at every scale; a smooth field's differences shrink with the square of the edge length.
double relative_roughness(const SmoothedField& s) {
  const std::size_t n = s.values.size();
  const std::size_t stride = std::max<std::size_t>(1, n / 20000);
  std::vector<double> difference, magnitude;
  for (std::uint32_t v = 0; v < n; v += std::uint32_t(stride)) {
    const auto begin = s.offsets[v], end = s.offsets[v + 1];
    if (begin == end) continue;
    for (int which = 0; which < 2; ++which) {
      double sum = 0;
      for (auto k = begin; k < end; ++k) sum += s.values[s.neighbors[k]][which];
      difference.push_back(std::abs(s.values[v][which] - sum / int(end - begin)));
      magnitude.push_back(std::abs(s.values[v][which]));
    }
  }
  if (magnitude.empty()) return 0;
  const double p90 = value_of_rank(magnitude, magnitude.size() * 9 / 10);
  return p90 > 0 ? median_of(difference) / p90 : 0;
}

// Smooths in doubling runs (1, 2, 4, ... passes in all, at most max_passes) for as long as a
// run takes the field's relative roughness down to `tolerance` of what it was or less, and
// returns the passes kept. Noise is rough at every scale, so smoothing removes it run after
// run; once only the surface's own variation is left, a run barely changes the roughness and
// further runs would only blur features. The number of passes so follows both the noise and
// how finely the mesh samples its features: on a 245k-triangle ridge at 10-20% noise about
// 64-100 passes (the line's error 0.07-0.10 edge lengths instead of 0.36-0.88 unsmoothed), on a
// 5k-triangle one or a clean mesh 0-2 (bench_accuracy).
int smooth_until_noise_is_gone(SmoothedField& s, double tolerance, int max_passes, const Cancellation* cancel,
                               Executor& executor) {
  int passes = 0;
  double roughness = relative_roughness(s);
  std::vector<std::array<double, 2>> before;
  while (passes < max_passes && roughness > 0) {
    throw_if_cancelled(cancel);
    const int run = std::min(std::max(passes, 1), max_passes - passes);
    before = s.values;
    for (int pass = 0; pass < run; ++pass) smooth_once(s, executor);
    const double smoothed = relative_roughness(s);
    if (smoothed > tolerance * roughness) {
      s.values.swap(before);  // this run only blurred: keep the field as it was before it
      break;
    }
    passes += run;
    roughness = smoothed;
  }
  return passes;
}

// Below this estimated noise (local edge lengths) a mesh is an exact sampling of its surface:
// clean fields estimate 0.000-0.004 (the radius-2 quadrics' own model error), 10% noise 0.037-
// 0.044, igea 0.011. What the automatic smoothing takes for noise there is the jets' ripple
// over an irregular tessellation, and its blur costs more than the ripple: unsmoothed, the
// lines of all 18 clean bench_accuracy cells came nearer the crest (ridge at 80,000 triangles
// 0.013 -> 0.007 grid spacings, arc at 24,200 0.026 -> 0.016), no noisy or CAD cell moved.
constexpr double kExactSurfaceNoise = 0.005;

// The bounding box's diagonal in mean local edge lengths: how many edges the object spans, and so
// how many a feature of a given share of it does. 0 for an empty or degenerate mesh.
double diagonal_in_edges(const std::vector<Eigen::Vector3d>& P, const std::vector<double>& local) {
  if (P.empty()) return 0;
  Eigen::Vector3d lo = P[0], hi = P[0];
  for (const auto& p : P) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  double edge = 0;
  std::size_t count = 0;
  for (double l : local)
    if (l > 0) edge += l, ++count;
  if (count == 0 || !(edge > 0)) return 0;
  return (hi - lo).norm() / (edge / double(count));
}

// Each pass spreads a value over about half an edge length squared (variance), so m passes
// blur over about sqrt(m) / 2 edge lengths. Features are sized relative to the object, not to
// its edges: keep that blur within 1% of the bounding box's diagonal (a 245k-triangle field
// allows the full 100 passes, a 5k-triangle one 2), so fine meshes can average much more
// noise away without erasing what a coarse mesh of the same object would show.
int blur_limited_passes(double diagonal_edges) {
  const double blur_edges = 0.01 * diagonal_edges;
  const double passes = 4 * blur_edges * blur_edges;
  return int(std::min<double>(CurvatureLimits::max_smoothing_passes, std::floor(passes)));
}

// The automatic jet radius (local edge lengths): 2 on clean meshes, growing with the noise up to
// 6 (wider fits average noise away, the variance of a fitted curvature falling as radius^-6 at
// a fixed density, but blur features). That cap was measured on objects about 134 edges across
// (bench_accuracy's 24,200-triangle fields). On a finer mesh of the same object a feature spans
// more edges, so a noisy mesh's fits reach as much further as the square root of the object's
// size in edges beyond that: on the 80,000-triangle fields (247 edges across, radius 8.1) every
// noisy cell but one came nearer over 6 seeds (arc ridge at 20% noise: 0.132 -> 0.114 grid
// spacings), on the 245,000-triangle ones (425 across, 10.7) 9 of 12 curved cells nearer and 2
// further by up to 0.005 over 3 seeds; with the cube root, several 30% cells further. Meshes
// whose estimated noise is below kWideJetMinNoise (clean ones, and scans such as igea at 0.011
// and the bunny at 0.021) keep radius 2-4, and every object under 134 edges across keeps the
// cap of 6 (the CAD parts here span 5-100).
constexpr double kJetCapReferenceEdges = 134;
constexpr double kWideJetMinNoise = 0.03;
double automatic_jet_radius(double noise, double diagonal_edges, double probe_radius) {
  double radius = std::clamp(2 + 100 * noise, probe_radius, 6.0);
  if (noise >= kWideJetMinNoise && diagonal_edges > kJetCapReferenceEdges)
    radius = std::min(radius * std::sqrt(diagonal_edges / kJetCapReferenceEdges), CurvatureLimits::max_radius);
  return radius;
}

// The automatic crease angle (degrees) from the interior edges' dihedral angles (radians): 30,
// or well above the angles noise makes on its own, 4 x the median edge's, when that reads more.
// On a flat-faced mesh whose median edge is sharp anyway, the median is a crease's own angle,
// not noise: a coarse CAD tessellation, most of whose edges are creases (a 12-triangle cube's
// median edge is one of its 90-degree edges; it read 360). At most
// CurvatureLimits::max_crease_angle, a dihedral angle (a tetrahedron read 438, degenerate files 720).
double automatic_crease_angle(std::vector<double> interior, bool flat_faced) {
  const double noise_angle = 4 * median_of(std::move(interior)) * 180 / kPi;
  if (flat_faced && noise_angle > 90) return 30;
  return std::clamp(noise_angle, 30.0, CurvatureLimits::max_crease_angle);
}

// A CAD tessellation's faces are flat: a quarter of its interior edges or more join two faces of
// one plane (the fandisk's 80%, a 12-triangle cube's 33%; noisy meshes and scans far fewer).
bool flat_faced(const std::vector<double>& interior) {
  const auto flat = std::count_if(interior.begin(), interior.end(), [](double a) { return a < kCoplanarAngle; });
  return 4 * std::size_t(flat) >= interior.size() && !interior.empty();
}

// Whether every interior edge that is no crease joins two faces of one plane.
bool every_other_edge_flat(const AdjacencyView& adj, const EdgeAngles& angles, const std::vector<std::int8_t>& crease) {
  for (std::size_t k = 0; k < adj.neighbors.size(); ++k)
    if (crease[k] == 0 && angles.corner_a[k] >= 0 && !(angles.angle[k] < kCoplanarAngle)) return false;
  return true;
}

}  // namespace

void check_curvature_options(const CurvatureOptions& options) {
  using L = CurvatureLimits;
  if (!L::radius_range.contains(options.radius))
    throw InvalidInputError("curvature radius must be between 0 (automatic) and " + format_number(L::radius_range.max) +
                            " edge lengths");
  if (!L::smoothing_passes_range.contains(options.smoothing_passes))
    throw InvalidInputError("curvature smoothing passes must be between 0 and " +
                            format_number(L::smoothing_passes_range.max) + ", or -1 (automatic)");
  if (!L::smoothing_tolerance_range.contains(options.smoothing_tolerance))
    throw InvalidInputError("curvature smoothing tolerance must be between 0 and 1");
  if (!L::crease_angle_range.contains(options.crease_angle))
    throw InvalidInputError("crease angle must be at most " + format_number(L::crease_angle_range.max) +
                            " degrees (0: automatic, negative: none)");
}

CurvatureField compute_curvature_field(const MeshTablesView& mesh, const std::vector<Eigen::Vector3d>& normals,
                                       const CurvatureOptions& options, const Cancellation* cancel,
                                       Executor* executor_or_null) {
  check_curvature_options(options);
  Executor& executor = executor_or_default(executor_or_null);
  CurvatureField field;
  const auto& positions = mesh.positions;
  const AdjacencyView& adjacency = mesh.adjacency;
  const std::size_t n = positions.size();
  auto clock = StageClock::now();
  field.mean = compute_mean_curvature(mesh, normals);
  field.timings.mean_ms = lap_ms(clock);
  field.k_max = field.mean;
  field.k_min = field.mean;
  const std::vector<double> local = local_edge_lengths(adjacency);
  const double diagonal_edges = diagonal_in_edges(positions, local);
  // Creases: above 30 degrees, and well above the dihedral angles the noise makes on its own.
  bool polyhedral = false;
  if (options.crease_angle >= 0) {
    const EdgeAngles angles = dihedral_angles(mesh, executor);
    std::vector<double> interior;  // one angle per interior edge
    interior.reserve(angles.angle.size() / 2);
    for (std::uint32_t v = 0; v < n; ++v)
      for (auto k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k)
        if (angles.corner_a[k] >= 0 && v < adjacency.neighbors[k]) interior.push_back(angles.angle[k]);
    const bool flat_faces = flat_faced(interior);
    field.crease_angle = options.crease_angle > 0 ? options.crease_angle : automatic_crease_angle(std::move(interior), flat_faces);
    mark_creases(positions, adjacency, angles, field.crease_angle, flat_faces, field);
    polyhedral = field.crease_edges > 0 && every_other_edge_flat(adjacency, angles, field.crease);
  } else {
    field.crease.assign(adjacency.neighbors.size(), 0);
  }
  throw_if_cancelled(cancel);
  std::vector<char>& on_crease = field.on_crease;
  on_crease.assign(n, 0);
  for (std::uint32_t v = 0; v < n; ++v)
    for (auto k = adjacency.offsets[v]; k < adjacency.offsets[v + 1]; ++k)
      if (field.crease[k] != 0) on_crease[v] = 1;
  field.timings.creases_ms = lap_ms(clock);
  const std::vector<char> barrier = fit_barriers(positions, adjacency, field);
  if (options.method == CurvatureMethod::jet) {
    // Noise: the median residual of fits over two edge lengths (flat and smooth parts fit
    // almost exactly, so what remains is the noise; creases are too few to move a median),
    // on a sample of about 20,000 vertices: a median needs no more, and large meshes stay fast.
    constexpr double kProbeRadius = 2;
    const std::size_t stride = std::max<std::size_t>(1, n / 20000);
    std::vector<double> residual =
        fit_all(positions, normals, adjacency, barrier, mesh.boundary_vertex, local, kProbeRadius, stride, field.mean, field,
                cancel, executor);
    // A polyhedron (every edge a crease or flat: a CAD part of flat faces) is exact: fits across
    // its creases would read their kinks as noise (a 48-triangle cube: 0.41 edge lengths).
    if (polyhedral) std::fill(residual.begin(), residual.end(), -1.0);
    std::vector<double> residual_length;
    for (std::size_t v = 0; v < n; ++v)
      if (residual[v] >= 0) residual_length.push_back(residual[v] * local[v]);
    field.noise_samples = residual_length.size();
    field.noise_length = median_of(std::move(residual_length));
    residual.erase(std::remove_if(residual.begin(), residual.end(), [](double r) { return r < 0; }), residual.end());
    field.noise = median_of(residual);
    field.timings.noise_ms = lap_ms(clock);
    field.radius = options.radius > 0 ? options.radius : automatic_jet_radius(field.noise, diagonal_edges, kProbeRadius);
    // The probe's quadrics serve as the field itself when they are what was asked for.
    field.jet_degree = options.jet_degree != JetDegree::automatic ? options.jet_degree : JetDegree::cubic;
    if (field.radius != kProbeRadius || stride != 1 || field.jet_degree != JetDegree::quadric)
      fit_all(positions, normals, adjacency, barrier, mesh.boundary_vertex, local, field.radius, 1, field.mean, field,
              cancel, executor,
              field.jet_degree);
    field.timings.jet_ms = lap_ms(clock);
  }
  // Measured again rather than kept from the crease stage: the folds are only read on noisy
  // meshes, and the angles would be held through the fits.
  if (field.noise >= kNoisyCreaseNoise && field.crease_angle > 0)
    field.fold = signed_folds(positions, adjacency, dihedral_angles(mesh, executor), field.crease_angle, executor);
  field.chord = mark_chords(adjacency, field, barrier);
  field.timings.creases_ms += lap_ms(clock);
  SmoothedField smoothed = start_smoothing(field, adjacency);
  if (options.smoothing_passes < 0) {
    field.smoothing_passes = field.noise < kExactSurfaceNoise
                                 ? 0
                                 : smooth_until_noise_is_gone(smoothed, options.smoothing_tolerance,
                                                              blur_limited_passes(diagonal_edges), cancel, executor);
  } else {
    for (int pass = 0; pass < options.smoothing_passes; ++pass) {
      throw_if_cancelled(cancel);
      smooth_once(smoothed, executor);
    }
    field.smoothing_passes = options.smoothing_passes;
  }
  finish_smoothing(smoothed, field);
  field.timings.smoothing_ms = lap_ms(clock);
  return field;
}

std::vector<Eigen::Vector3d> compute_vertex_normals(const std::vector<Eigen::Vector3d>& positions,
                                                    const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  std::vector<Eigen::Vector3d> normals(positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles) {
    const Eigen::Vector3d p[3] = {positions[t[0]], positions[t[1]], positions[t[2]]};
    Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double len = n.norm();
    if (!(len > 0)) continue;
    n /= len;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
      const double angle = angle_between(a, b);
      normals[t[i]] += angle * n;
    }
  }
  for (auto& n : normals) {
    const double len = n.norm();
    if (len > 0) n /= len;
  }
  return normals;
}

std::vector<double> compute_mean_curvature(const MeshTablesView& mesh, const std::vector<Eigen::Vector3d>& normals) {
  const std::size_t n = mesh.positions.size();
  std::vector<Eigen::Vector3d> laplace(n, Eigen::Vector3d::Zero());
  std::vector<double> area(n, 0.0);
  // Meyer, Desbrun, Schroeder, Barr 2003: K(x_i) = 1/(2 A_mixed) sum_j (cot a_ij + cot b_ij)(x_i - x_j),
  // and K = 2 H n. The mixed area uses Voronoi areas on non-obtuse triangles and the
  // area/2, area/4 split on obtuse ones, so the areas tile the surface.
  for (const auto& idx : mesh.triangles) {
    const Eigen::Vector3d p[3] = {mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]]};
    const double double_area = (p[1] - p[0]).cross(p[2] - p[0]).norm();
    if (!(double_area > 1e-300)) continue;  // zero-area triangles carry no curvature information
    double cot[3];
    double dots[3];
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
      dots[i] = a.dot(b);
      cot[i] = dots[i] / double_area;  // |a x b| == double_area for every corner
    }
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3, l = (i + 2) % 3;
      // the edge (j, l) is opposite corner i
      const Eigen::Vector3d e = p[j] - p[l];
      laplace[idx[j]] += cot[i] * e;
      laplace[idx[l]] -= cot[i] * e;
    }
    const double tri_area = 0.5 * double_area;
    const bool obtuse = dots[0] < 0 || dots[1] < 0 || dots[2] < 0;
    for (int i = 0; i < 3; ++i) {
      if (!obtuse) {
        const int j = (i + 1) % 3, l = (i + 2) % 3;
        area[idx[i]] += 0.125 * ((p[i] - p[l]).squaredNorm() * cot[j] + (p[i] - p[j]).squaredNorm() * cot[l]);
      } else {
        area[idx[i]] += dots[i] < 0 ? 0.5 * tri_area : 0.25 * tri_area;
      }
    }
  }
  // On the boundary (an edge with one face; isolated vertices too) the cotangent Laplacian is
  // incomplete; borrow from interior neighbours.
  const AdjacencyView& adj = mesh.adjacency;
  std::vector<double> curvature(n, 0.0);
  std::vector<char> on_boundary(n, 0);
  for (std::size_t v = 0; v < n; ++v) {
    on_boundary[v] = mesh.boundary_vertex[v] || adj.offsets[v] == adj.offsets[v + 1];
    if (area[v] > 0) curvature[v] = 0.25 * laplace[v].dot(normals[v]) / area[v];
  }
  std::vector<double> boundary_value(n, 0.0);
  for (std::size_t v = 0; v < n; ++v) {
    if (!on_boundary[v]) continue;
    double sum = 0;
    int count = 0;
    for (auto k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k)
      if (!on_boundary[adj.neighbors[k]]) sum += curvature[adj.neighbors[k]], ++count;
    boundary_value[v] = count > 0 ? sum / count : 0.0;
  }
  for (std::size_t v = 0; v < n; ++v)
    if (on_boundary[v]) curvature[v] = boundary_value[v];
  return curvature;
}

}  // namespace featureline
