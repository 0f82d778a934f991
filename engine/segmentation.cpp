#include "engine/segmentation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "engine/errors.h"

namespace featureline {
namespace {

using Clock = std::chrono::steady_clock;
using Tri = std::array<std::uint32_t, 3>;
using Bary = std::array<double, 3>;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
/// Two points closer than this in a face's barycentric coordinates are the same point.
constexpr double kSame = 1e-9;

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(a) << 32) | b;
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

double triangle_area(const std::vector<Eigen::Vector3d>& p, const Tri& t) {
  return 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm();
}

// ---------------------------------------------------------------------------------------------
// Mesh tables
// ---------------------------------------------------------------------------------------------

/// Faces around each vertex, in compressed rows.
struct VertexFaces {
  std::vector<std::uint32_t> offsets, faces;
  VertexFaces(const std::vector<Tri>& tris, std::size_t n_vertices) : offsets(n_vertices + 1, 0) {
    for (const auto& t : tris)
      for (auto v : t) ++offsets[v + 1];
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    faces.resize(offsets.back());
    std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::uint32_t f = 0; f < tris.size(); ++f)
      for (auto v : tris[f]) faces[fill[v]++] = f;
  }
  const std::uint32_t* begin(std::uint32_t v) const { return faces.data() + offsets[v]; }
  const std::uint32_t* end(std::uint32_t v) const { return faces.data() + offsets[v + 1]; }
};

int corner_of(const Tri& t, std::uint32_t v) {
  for (int k = 0; k < 3; ++k)
    if (t[k] == v) return k;
  return -1;
}

/// across[f][k]: the face on the other side of edge k = (t[k], t[k+1]) of face f; kNone on
/// boundary edges and edges with more than two faces (flood fill never crosses those).
std::vector<Tri> face_adjacency(const std::vector<Tri>& tris, std::size_t n_vertices) {
  // Face edges bucketed by their lower end (a counting sort), then matched by the upper end
  // inside each bucket: a handful of entries each.
  struct Entry {
    std::uint32_t upper, face;
    int k;
  };
  std::vector<std::uint32_t> offsets(n_vertices + 1, 0);
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k) ++offsets[std::min(t[k], t[(k + 1) % 3]) + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<Entry> entries(offsets.back());
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = tris[f][k], b = tris[f][(k + 1) % 3];
      entries[fill[std::min(a, b)]++] = {std::max(a, b), f, k};
    }
  std::vector<Tri> across(tris.size(), Tri{kNone, kNone, kNone});
  for (std::size_t v = 0; v < n_vertices; ++v)
    for (auto i = offsets[v]; i < offsets[v + 1]; ++i) {
      int found = 0;
      std::uint32_t match = kNone;
      for (auto j = offsets[v]; j < offsets[v + 1]; ++j)
        if (j != i && entries[j].upper == entries[i].upper) ++found, match = entries[j].face;
      across[entries[i].face][entries[i].k] = found == 1 ? match : kNone;
    }
  return across;
}

/// `across` without the links over the cut edges.
std::vector<Tri> sever(const std::vector<Tri>& tris, const VertexFaces& vf, std::vector<Tri> across,
                       const std::unordered_map<std::uint64_t, int>& cuts) {
  for (const auto& cut : cuts) {
    const auto a = std::uint32_t(cut.first >> 32);  // the lower end; its faces hold the edge
    for (auto it = vf.begin(a); it != vf.end(a); ++it)
      for (int k = 0; k < 3; ++k)
        if (edge_key(tris[*it][k], tris[*it][(k + 1) % 3]) == cut.first) across[*it][k] = kNone;
  }
  return across;
}

/// Dijkstra on mesh edges with scratch arrays reused between searches.
class PathFinder {
 public:
  explicit PathFinder(const PreparedMesh& mesh)
      : mesh_(mesh), dist_(mesh.n_vertices(), HUGE_VAL), prev_(mesh.n_vertices(), kNone) {}

  /// Shortest edge path from `from` to the nearest vertex accepted by `goal`, no longer than
  /// `radius`; both ends included. Empty when there is none.
  std::vector<std::uint32_t> find(std::uint32_t from, const std::function<bool(std::uint32_t)>& goal, double radius) {
    using Item = std::pair<double, std::uint32_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    dist_[from] = 0;
    touched_.push_back(from);
    heap.push({0.0, from});
    std::uint32_t found = kNone;
    while (!heap.empty()) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > dist_[v]) continue;
      if (goal(v)) {
        found = v;
        break;
      }
      for (auto k = mesh_.neighbor_offsets[v]; k < mesh_.neighbor_offsets[v + 1]; ++k) {
        const auto w = mesh_.neighbors[k];
        const double nd = d + mesh_.neighbor_edge_lengths[k];
        if (nd <= radius && nd < dist_[w]) {
          if (dist_[w] == HUGE_VAL) touched_.push_back(w);
          dist_[w] = nd;
          prev_[w] = v;
          heap.push({nd, w});
        }
      }
    }
    std::vector<std::uint32_t> path;
    for (auto v = found; v != kNone; v = prev_[v]) path.push_back(v);
    std::reverse(path.begin(), path.end());
    for (auto v : touched_) dist_[v] = HUGE_VAL, prev_[v] = kNone;
    touched_.clear();
    return path;
  }

 private:
  const PreparedMesh& mesh_;
  std::vector<double> dist_;
  std::vector<std::uint32_t> prev_;
  std::vector<std::uint32_t> touched_;
};

bool are_neighbors(const PreparedMesh& mesh, std::uint32_t a, std::uint32_t b) {
  for (auto k = mesh.neighbor_offsets[a]; k < mesh.neighbor_offsets[a + 1]; ++k)
    if (mesh.neighbors[k] == b) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// Points on the original mesh
// ---------------------------------------------------------------------------------------------

/// A point of the original mesh in the simplest form that holds it: on a vertex, on an edge or
/// inside a face. Remeshing decides with these, not with rounded coordinates, whether a point is
/// shared by neighbouring faces.
struct Location {
  enum Kind : std::uint8_t { vertex, edge, face } kind = vertex;
  std::uint32_t a = 0, b = 0;  ///< vertex: a; edge: its ends, a < b; face: a is the face
  double t = 0;                ///< edge: weight of b
  Bary w{0, 0, 0};             ///< face: barycentric w.r.t. PreparedMesh::triangles[a]
  std::uint32_t home = 0;      ///< a face whose closure holds the point
};

bool same_location(const Location& x, const Location& y) {
  if (x.kind != y.kind || x.a != y.a) return false;
  switch (x.kind) {
    case Location::vertex: return true;
    case Location::edge: return x.b == y.b && std::abs(x.t - y.t) <= kSame;
    case Location::face:
      return std::abs(x.w[0] - y.w[0]) <= kSame && std::abs(x.w[1] - y.w[1]) <= kSame &&
             std::abs(x.w[2] - y.w[2]) <= kSame;
  }
  return false;
}

Location vertex_location(std::uint32_t v, std::uint32_t home) {
  Location l;
  l.kind = Location::vertex;
  l.a = v;
  l.home = home;
  return l;
}

/// The point with barycentric coordinates w in face f; coordinates below `tol` are snapped to 0
/// (onto an edge or a vertex).
Location classify(const std::vector<Tri>& tris, std::uint32_t f, Bary w, double tol) {
  double sum = 0;
  for (auto& x : w) sum += (x = std::max(x, 0.0));
  if (!(sum > 0)) w = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  else
    for (auto& x : w) x /= sum;
  const Tri& t = tris[f];
  const int top = int(std::max_element(w.begin(), w.end()) - w.begin());
  int small = 0, k_small = -1;
  for (int k = 0; k < 3; ++k)
    if (w[k] < tol) ++small, k_small = k;
  if (w[top] >= 1 - tol || small >= 2) return vertex_location(t[top], f);
  if (small == 1) {
    const int i = (k_small + 1) % 3, j = (k_small + 2) % 3;
    Location l;
    l.kind = Location::edge;
    l.a = t[i];
    l.b = t[j];
    l.t = w[j] / (w[i] + w[j]);
    if (l.a > l.b) std::swap(l.a, l.b), l.t = 1 - l.t;
    l.home = f;
    if (l.t < tol) return vertex_location(l.a, f);
    if (l.t > 1 - tol) return vertex_location(l.b, f);
    return l;
  }
  Location l;
  l.kind = Location::face;
  l.a = f;
  l.w = w;
  l.home = f;
  return l;
}

/// Barycentric coordinates of `l` in face f, when f's closure holds it.
std::optional<Bary> bary_in(const std::vector<Tri>& tris, std::uint32_t f, const Location& l);

/// bary_in where f must hold `l` (an internal invariant of the tracing and remeshing).
Bary bary_of(const std::vector<Tri>& tris, std::uint32_t f, const Location& l) {
  const auto w = bary_in(tris, f, l);
  if (!w) throw std::logic_error("segmentation: a point is not in the face it was traced in");
  return *w;
}

std::optional<Bary> bary_in(const std::vector<Tri>& tris, std::uint32_t f, const Location& l) {
  const Tri& t = tris[f];
  Bary w{0, 0, 0};
  switch (l.kind) {
    case Location::vertex: {
      const int k = corner_of(t, l.a);
      if (k < 0) return std::nullopt;
      w[k] = 1;
      return w;
    }
    case Location::edge: {
      const int ka = corner_of(t, l.a), kb = corner_of(t, l.b);
      if (ka < 0 || kb < 0) return std::nullopt;
      w[ka] = 1 - l.t;
      w[kb] = l.t;
      return w;
    }
    case Location::face:
      if (l.a != f) return std::nullopt;
      return l.w;
  }
  return std::nullopt;
}

Eigen::Vector3d position_of(const PreparedMesh& mesh, const Location& l) {
  const auto& p = mesh.positions;
  switch (l.kind) {
    case Location::vertex: return p[l.a];
    case Location::edge: return (1 - l.t) * p[l.a] + l.t * p[l.b];
    case Location::face: {
      const Tri& t = mesh.triangles[l.a];
      return l.w[0] * p[t[0]] + l.w[1] * p[t[1]] + l.w[2] * p[t[2]];
    }
  }
  return p[0];
}

/// Is `l` on the original edge (p, q)?
bool on_edge(const Location& l, std::uint32_t p, std::uint32_t q) {
  if (l.kind == Location::vertex) return l.a == p || l.a == q;
  if (l.kind == Location::edge) return (l.a == p && l.b == q) || (l.a == q && l.b == p);
  return false;
}

/// Position of `l` along the original edge (min(p,q) -> max(p,q)), l on that edge.
double param_on(const Location& l, std::uint32_t p, std::uint32_t q) {
  if (l.kind == Location::vertex) return l.a == std::min(p, q) ? 0.0 : 1.0;
  return l.t;
}

void validate_point(const PreparedMesh& mesh, const SurfacePoint& s, std::size_t line, std::size_t index) {
  auto where = [&] {
    std::ostringstream out;
    out << "line " << line << ", refined point " << index;
    return out.str();
  };
  if (s.face >= mesh.triangles.size())
    throw InvalidInputError(where() + ": face " + std::to_string(s.face) + " is out of range (the mesh has " +
                            std::to_string(mesh.triangles.size()) + " faces)");
  double sum = 0;
  for (double x : s.barycentric) {
    if (!std::isfinite(x) || x < -1e-6) throw InvalidInputError(where() + ": barycentric coordinates must be finite and non-negative");
    sum += x;
  }
  if (std::abs(sum - 1) > 1e-6) throw InvalidInputError(where() + ": barycentric coordinates must sum to 1");
}

// ---------------------------------------------------------------------------------------------
// Tracing a segment between two points across the original faces
// ---------------------------------------------------------------------------------------------

/// One piece of a traced line: from the previous location to `to`, straight inside `face`; or,
/// when `gap`, a jump to `to` (the line crossed between parts of the mesh that share no edge).
struct Step {
  Location to;
  std::uint32_t face = 0;
  bool gap = false;
};

enum class Traced { straight, along_edges, gap };

/// Follows the straight line between two surface points from face to face (the segment between
/// consecutive refined points, unfolded across each edge it crosses), recording where it crosses
/// edges. When the walk gets lost (cone vertices, folded geometry) the piece follows the
/// shortest edge path between the points' nearest vertices instead.
class Tracer {
 public:
  Tracer(const PreparedMesh& mesh, const VertexFaces& vertex_faces, double snap)
      : mesh_(mesh), vf_(vertex_faces), snap_(snap), paths_(mesh) {}

  /// Appends the steps from `from` to `to` and says how they were found.
  Traced trace(const Location& from, const Location& to, std::vector<Step>& steps) {
    if (same_location(from, to)) return Traced::straight;
    const std::size_t mark = steps.size();
    if (walk(from, to, steps)) return Traced::straight;
    steps.resize(mark);
    return along_edges(from, to, steps);
  }

 private:
  std::vector<std::uint32_t> faces_containing(const Location& l) const {
    std::vector<std::uint32_t> out;
    switch (l.kind) {
      case Location::vertex: out.assign(vf_.begin(l.a), vf_.end(l.a)); break;
      case Location::edge:
        for (auto it = vf_.begin(l.a); it != vf_.end(l.a); ++it)
          if (corner_of(mesh_.triangles[*it], l.b) >= 0) out.push_back(*it);
        break;
      case Location::face: out.push_back(l.a); break;
    }
    return out;
  }

  /// Barycentric coordinates in face f of x projected on f's plane (outside f when x is).
  std::optional<Bary> project(std::uint32_t f, const Eigen::Vector3d& x) const {
    const Tri& t = mesh_.triangles[f];
    const auto& p = mesh_.positions;
    const Eigen::Vector3d e1 = p[t[1]] - p[t[0]], e2 = p[t[2]] - p[t[0]], r = x - p[t[0]];
    const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2), det = a * c - b * b;
    if (!(det > 1e-24 * a * c)) return std::nullopt;
    const double u = (c * e1.dot(r) - b * e2.dot(r)) / det, v = (a * e2.dot(r) - b * e1.dot(r)) / det;
    return Bary{1 - u - v, u, v};
  }

  /// The target `to` in face f's barycentric frame: exact when f holds it, unfolded across the
  /// shared edge when a face holding it is f's neighbour, else projected on f's plane.
  std::optional<Bary> target_in(std::uint32_t f, const Location& to, const Eigen::Vector3d& target) const {
    if (auto w = bary_in(mesh_.triangles, f, to)) return w;
    const Tri& tf = mesh_.triangles[f];
    const auto& p = mesh_.positions;
    for (auto g : faces_containing(to)) {
      const Tri& tg = mesh_.triangles[g];
      int shared = 0, s = -1;
      for (int k = 0; k < 3; ++k) {
        if (corner_of(tf, tg[k]) >= 0) ++shared;
        else s = k;
      }
      if (shared != 2) continue;
      const auto wg = bary_of(mesh_.triangles, g, to);
      // f's 2D frame.
      const Eigen::Vector3d o = p[tf[0]], n = (p[tf[1]] - o).cross(p[tf[2]] - o);
      const double nn = n.norm(), l1 = (p[tf[1]] - o).norm();
      if (!(nn > 0) || !(l1 > 0)) return std::nullopt;
      const Eigen::Vector3d ex = (p[tf[1]] - o) / l1, ey = (n / nn).cross(ex);
      auto flat = [&](const Eigen::Vector3d& x) { return Eigen::Vector2d((x - o).dot(ex), (x - o).dot(ey)); };
      const std::uint32_t vp = tg[(s + 1) % 3], vr = tg[(s + 2) % 3], vs = tg[s];
      const Eigen::Vector2d p2 = flat(p[vp]), r2 = flat(p[vr]);
      std::uint32_t third = tf[0];
      for (auto v : tf)
        if (v != vp && v != vr) third = v;
      const Eigen::Vector3d pr = p[vr] - p[vp];
      const double len = pr.norm();
      if (!(len > 0)) return std::nullopt;
      const Eigen::Vector2d u = (r2 - p2) / (r2 - p2).norm();
      Eigen::Vector2d away(-u.y(), u.x());
      if (away.dot(flat(p[third]) - p2) > 0) away = -away;
      const Eigen::Vector3d ps = p[vs] - p[vp];
      const Eigen::Vector2d s2 = p2 + (ps.dot(pr) / len) * u + (ps.cross(pr).norm() / len) * away;
      const Eigen::Vector2d q2 = wg[(s + 1) % 3] * p2 + wg[(s + 2) % 3] * r2 + wg[s] * s2;
      // Back to f's barycentric coordinates.
      const Eigen::Vector2d a0 = flat(p[tf[0]]), a1 = flat(p[tf[1]]), a2 = flat(p[tf[2]]);
      const double det = cross2(a1 - a0, a2 - a0);
      if (!(std::abs(det) > 0)) return std::nullopt;
      const double w1 = cross2(q2 - a0, a2 - a0) / det, w2 = cross2(a1 - a0, q2 - a0) / det;
      return Bary{1 - w1 - w2, w1, w2};
    }
    return project(f, target);
  }

  bool walk(const Location& from, const Location& to, std::vector<Step>& steps) const {
    const auto& tris = mesh_.triangles;
    const Eigen::Vector3d target = position_of(mesh_, to);
    Location c = from;
    std::uint32_t came_from = kNone;
    for (int step = 0; step < 64; ++step) {
      for (auto f : faces_containing(c))
        if (bary_in(tris, f, to)) {
          steps.push_back({to, f});
          return true;
        }
      Location next;
      std::uint32_t face = kNone;
      if (c.kind == Location::vertex) {
        // Leave the vertex through the face whose corner angle holds the direction to the target.
        double best = -HUGE_VAL;
        Bary best_q{0, 0, 0};
        int best_k = 0;
        for (auto it = vf_.begin(c.a); it != vf_.end(c.a); ++it) {
          const auto q = target_in(*it, to, target);
          if (!q) continue;
          const int k = corner_of(tris[*it], c.a), j = (k + 1) % 3, l = (k + 2) % 3;
          const double score = std::min((*q)[j], (*q)[l]) / (std::abs((*q)[j]) + std::abs((*q)[l]) + 1e-300);
          if (score > best) best = score, face = *it, best_q = *q, best_k = k;
        }
        if (face == kNone) return false;
        const int j = (best_k + 1) % 3, l = (best_k + 2) % 3;
        const double dj = best_q[j], dl = best_q[l];
        if (!(dj + dl > 0)) return false;
        const double u = std::clamp(dl / (dj + dl), 0.0, 1.0);
        Bary w{0, 0, 0};
        w[j] = 1 - u;
        w[l] = u;
        next = classify(tris, face, w, snap_);
      } else {
        std::vector<std::uint32_t> candidates;
        if (c.kind == Location::face) {
          candidates.push_back(c.a);
        } else {
          for (auto f : faces_containing(c))
            if (f != came_from) candidates.push_back(f);
        }
        // Move inside the candidate face the direction enters (an edge point has two).
        double best = -HUGE_VAL;
        Bary best_p{0, 0, 0}, best_d{0, 0, 0};
        for (auto f : candidates) {
          const auto q = target_in(f, to, target);
          if (!q) continue;
          const Bary pc = bary_of(tris, f, c);
          Bary d;
          double norm = 0;
          for (int k = 0; k < 3; ++k) d[k] = (*q)[k] - pc[k], norm += d[k] * d[k];
          if (!(norm > 0)) continue;
          double score = 1;  // a face point may go anywhere
          if (c.kind == Location::edge) {
            const int opposite = 3 - corner_of(tris[f], c.a) - corner_of(tris[f], c.b);
            score = d[opposite] / std::sqrt(norm);
          }
          if (score > best) best = score, face = f, best_p = pc, best_d = d;
        }
        if (c.kind == Location::edge && !(best > 1e-9)) {
          // The line runs along this edge (or the estimates disagree about its side): go on
          // from the edge's end it heads for.
          const std::uint32_t f = faces_containing(c).front();
          const auto q = target_in(f, to, target);
          if (!q) return false;
          const Bary pc = bary_of(tris, f, c);
          const int ka = corner_of(tris[f], c.a), kb = corner_of(tris[f], c.b);
          face = f;
          next = vertex_location((*q)[ka] - pc[ka] > (*q)[kb] - pc[kb] ? c.a : c.b, f);
          if (same_location(next, c)) return false;
          steps.push_back({next, face});
          came_from = face;
          c = next;
          continue;
        }
        if (face == kNone || !(best > 0)) return false;
        double s_min = HUGE_VAL;
        int exit = -1;
        for (int k = 0; k < 3; ++k)
          if (best_d[k] < 0 && best_p[k] > 0) {
            const double s = best_p[k] / -best_d[k];
            if (s < s_min) s_min = s, exit = k;
          }
        if (exit < 0) return false;
        Bary w;
        for (int k = 0; k < 3; ++k) w[k] = best_p[k] + s_min * best_d[k];
        w[exit] = 0;
        next = classify(tris, face, w, snap_);
      }
      if (same_location(next, c)) return false;
      steps.push_back({next, face});
      came_from = face;
      c = next;
    }
    return false;
  }

  std::uint32_t nearest_vertex(const Location& l) const {
    switch (l.kind) {
      case Location::vertex: return l.a;
      case Location::edge: return l.t < 0.5 ? l.a : l.b;
      case Location::face: {
        const int k = int(std::max_element(l.w.begin(), l.w.end()) - l.w.begin());
        return mesh_.triangles[l.a][k];
      }
    }
    return l.a;
  }

  std::uint32_t face_with_edge(std::uint32_t a, std::uint32_t b) const {
    for (auto it = vf_.begin(a); it != vf_.end(a); ++it)
      if (corner_of(mesh_.triangles[*it], b) >= 0) return *it;
    return kNone;
  }

  Traced along_edges(const Location& from, const Location& to, std::vector<Step>& steps) {
    const std::uint32_t a = nearest_vertex(from), b = nearest_vertex(to);
    const auto path = a == b ? std::vector<std::uint32_t>{a}
                             : paths_.find(a, [b](std::uint32_t v) { return v == b; }, HUGE_VAL);
    if (path.empty()) {
      steps.push_back({to, to.home, true});
      return Traced::gap;
    }
    if (from.kind != Location::vertex) steps.push_back({vertex_location(a, from.home), from.home});
    for (std::size_t i = 1; i < path.size(); ++i) {
      const auto f = face_with_edge(path[i - 1], path[i]);
      steps.push_back({vertex_location(path[i], f), f});
    }
    if (to.kind != Location::vertex) steps.push_back({to, to.home});
    return Traced::along_edges;
  }

  const PreparedMesh& mesh_;
  const VertexFaces& vf_;
  double snap_;
  PathFinder paths_;
};

// ---------------------------------------------------------------------------------------------
// Remeshing: splitting faces along the traced line (Fig. 8)
// ---------------------------------------------------------------------------------------------

/// The mesh being split. Every new vertex lies on an original edge or inside an original face,
/// and every triangle inside one original face, so all geometric decisions are made in that
/// face's barycentric plane (exact for orientation tests: it is an affine image of the face) and
/// area is preserved. Splits keep the corners' cyclic order, so orientation and manifoldness
/// are kept too. The triangles split off original face F are listed in subs(F): a handful each.
class Remesher {
 public:
  Remesher(const PreparedMesh& mesh, const std::vector<Tri>& original_across, double snap)
      : mesh_(mesh),
        across_(original_across),
        snap_(snap),
        positions_(mesh.positions),
        tris_(mesh.triangles),
        source_(mesh.triangles.size()),
        subs_(mesh.triangles.size()) {
    std::iota(source_.begin(), source_.end(), 0u);
  }

  /// Inserts `y` as a vertex (no cut); returns its id.
  std::uint32_t locate(const Location& y) {
    if (y.kind == Location::vertex) return y.a;
    const std::uint32_t f = y.kind == Location::face ? y.a : y.home;
    const Bary wy = bary_of(mesh_.triangles, f, y);
    const Eigen::Vector2d py(wy[1], wy[2]);
    if (y.kind == Location::edge) {
      for (auto t : subs(f))
        for (int k = 0; k < 3; ++k) {
          const auto b = tris_[t][k], c = tris_[t][(k + 1) % 3];
          const Location lb = location_of(b), lc = location_of(c);
          if (!on_edge(lb, y.a, y.b) || !on_edge(lc, y.a, y.b)) continue;
          const double tb = param_on(lb, y.a, y.b), tc = param_on(lc, y.a, y.b);
          if (std::abs(y.t - tb) <= kSame) return b;
          if (std::abs(y.t - tc) <= kSame) return c;
          if ((y.t - tb) * (y.t - tc) < 0) return split_edge(f, b, c, y);
        }
      throw std::logic_error("segmentation: an edge point is on no sub-edge");
    }
    // Inside face f: the sub-triangle holding it most deeply.
    double best = -HUGE_VAL;
    std::uint32_t best_t = kNone;
    for (auto t : subs(f)) {
      const auto ab = coords(f, tris_[t][0]), bb = coords(f, tris_[t][1]), cb = coords(f, tris_[t][2]);
      const double det = cross2(bb - ab, cb - ab);
      if (!(det > 0)) continue;
      const double l1 = cross2(py - ab, cb - ab) / det, l2 = cross2(bb - ab, py - ab) / det;
      const double depth = std::min({1 - l1 - l2, l1, l2});
      if (depth > best) best = depth, best_t = t;
    }
    if (best_t == kNone) throw std::logic_error("segmentation: a face point is in no sub-triangle");
    const Tri t = tris_[best_t];
    for (auto v : t)
      if ((coords(f, v) - py).norm() <= kSame) return v;
    for (int k = 0; k < 3; ++k) {
      const auto b = t[k], c = t[(k + 1) % 3];
      const Eigen::Vector2d pb = coords(f, b), pc = coords(f, c);
      if (std::abs(cross2(pc - pb, py - pb)) / (pc - pb).norm() <= kSame && original_edge_of(f, b, c) < 0)
        return split_edge(f, b, c, y);
    }
    return split_face(best_t, y);
  }

  /// Inserts the straight segment from vertex x to `y` inside original face f, splitting the
  /// triangles it crosses, and marks its edges cut (for `line`). Returns y's vertex.
  std::uint32_t walk(std::uint32_t x, const Location& y, std::uint32_t f, int line) {
    const Tri& corners = mesh_.triangles[f];
    const Bary wy = bary_of(mesh_.triangles, f, y);
    const Eigen::Vector2d py(wy[1], wy[2]);
    for (int guard = 0; guard < 100000; ++guard) {
      if (y.kind == Location::vertex && x == y.a) return x;
      const Location lx = location_of(x);
      const Eigen::Vector2d px = coords(f, x);
      if (y.kind != Location::vertex && (px - py).norm() <= kSame) return x;

      // Both on one edge of the original face: follow its sub-edges.
      int shared_edge = -1;
      for (int k = 0; k < 3 && shared_edge < 0; ++k)
        if (on_edge(lx, corners[k], corners[(k + 1) % 3]) && on_edge(y, corners[k], corners[(k + 1) % 3]))
          shared_edge = k;
      if (shared_edge >= 0) {
        const auto p = corners[shared_edge], q = corners[(shared_edge + 1) % 3];
        const double tx = param_on(lx, p, q), ty = param_on(y, p, q), dir = ty > tx ? 1.0 : -1.0;
        std::uint32_t b = kNone;
        for (auto t : subs(f)) {
          const int k = corner_of(tris_[t], x);
          if (k < 0) continue;
          for (auto w : {tris_[t][(k + 1) % 3], tris_[t][(k + 2) % 3]}) {
            const Location lw = location_of(w);
            if (on_edge(lw, p, q) && (param_on(lw, p, q) - tx) * dir > 0) b = w;
          }
        }
        if (b == kNone) throw std::logic_error("segmentation: lost along an edge");
        const double tb = param_on(location_of(b), p, q);
        if ((y.kind == Location::vertex && y.a == b) || (y.kind != Location::vertex && std::abs(tb - ty) <= kSame)) {
          cut(x, b, line);
          return b;
        }
        if ((ty - tx) * dir < (tb - tx) * dir) {
          const auto m = split_edge(f, x, b, y);
          cut(x, m, line);
          return m;
        }
        cut(x, b, line);
        x = b;
        continue;
      }

      // The sub-triangle at x whose corner angle holds the direction to y.
      double best = -HUGE_VAL;
      std::uint32_t tri = kNone;
      std::uint32_t b = kNone, c = kNone;
      const Eigen::Vector2d vy = py - px;
      for (auto t : subs(f)) {
        const int k = corner_of(tris_[t], x);
        if (k < 0) continue;
        const auto tb = tris_[t][(k + 1) % 3], tc = tris_[t][(k + 2) % 3];
        const Eigen::Vector2d vb = coords(f, tb) - px, vc = coords(f, tc) - px;
        const double nb = vb.norm() * vy.norm(), nc = vc.norm() * vy.norm();
        if (!(nb > 0) || !(nc > 0)) continue;
        const double score = std::min(cross2(vb, vy) / nb, cross2(vy, vc) / nc);
        if (score > best) best = score, tri = t, b = tb, c = tc;
      }
      if (tri == kNone) throw std::logic_error("segmentation: a line vertex is in no sub-triangle");
      const Eigen::Vector2d pb = coords(f, b), pc = coords(f, c);
      if (y.kind == Location::vertex) {
        if (b == y.a || c == y.a) {
          cut(x, y.a, line);
          return y.a;
        }
      } else {
        for (auto v : {b, c})
          if ((coords(f, v) - py).norm() <= kSame) {
            cut(x, v, line);
            return v;
          }
      }
      const int border = original_edge_of(f, b, c);
      if (y.kind == Location::face) {
        const double height = cross2(pc - pb, py - pb) / (pc - pb).norm();
        if (height > kSame) {
          const auto m = split_face(tri, y);
          cut(x, m, line);
          return m;
        }
        if (height >= -kSame && border < 0) {
          const auto m = split_edge(f, b, c, y);
          cut(x, m, line);
          return m;
        }
      } else if (border >= 0) {
        const auto p = corners[border], q = corners[(border + 1) % 3];
        if (on_edge(y, p, q)) {
          const double tb = param_on(location_of(b), p, q), tc = param_on(location_of(c), p, q), ty = param_on(y, p, q);
          if ((ty - tb) * (ty - tc) < 0) {
            const auto m = split_edge(f, b, c, y);
            cut(x, m, line);
            return m;
          }
        }
      }
      // The segment leaves this triangle through edge bc.
      const double ob = cross2(vy, pb - px), oc = cross2(vy, pc - px);
      double u = ob != oc ? std::clamp(ob / (ob - oc), 0.0, 1.0) : 0.5;
      if (border >= 0) u = u < 0.5 ? 0 : 1;  // never split the face's border on the way: y is inside
      if (u <= snap_ || u >= 1 - snap_) {
        const auto v = u <= snap_ ? b : c;
        cut(x, v, line);
        x = v;
        continue;
      }
      const auto m = split_edge(f, b, c, between(f, b, c, u));
      cut(x, m, line);
      x = m;
    }
    throw std::logic_error("segmentation: the remeshing walk did not end");
  }

  std::vector<Eigen::Vector3d>& positions() { return positions_; }
  std::vector<Tri>& triangles() { return tris_; }
  std::vector<std::uint32_t>& sources() { return source_; }
  const std::unordered_map<std::uint64_t, int>& cuts() const { return cuts_; }

 private:
  Location location_of(std::uint32_t v) const {
    if (v < mesh_.n_vertices()) return vertex_location(v, 0);
    return origins_[v - mesh_.n_vertices()];
  }

  Eigen::Vector2d coords(std::uint32_t f, std::uint32_t v) const {
    const auto w = bary_in(mesh_.triangles, f, location_of(v));
    if (!w) throw std::logic_error("segmentation: a vertex is not in its face");
    return {(*w)[1], (*w)[2]};
  }

  std::vector<std::uint32_t>& subs(std::uint32_t f) {
    if (subs_[f].empty()) subs_[f].push_back(f);
    return subs_[f];
  }

  /// k when b and c both lie on edge k = (corner k, corner k+1) of original face f, else -1.
  int original_edge_of(std::uint32_t f, std::uint32_t b, std::uint32_t c) const {
    const Tri& t = mesh_.triangles[f];
    const Location lb = location_of(b), lc = location_of(c);
    for (int k = 0; k < 3; ++k)
      if (on_edge(lb, t[k], t[(k + 1) % 3]) && on_edge(lc, t[k], t[(k + 1) % 3])) return k;
    return -1;
  }

  /// The point at fraction u from b to c, on the original edge when bc lies on one.
  Location between(std::uint32_t f, std::uint32_t b, std::uint32_t c, double u) const {
    const Tri& t = mesh_.triangles[f];
    const int k = original_edge_of(f, b, c);
    Location l;
    l.home = f;
    if (k >= 0) {
      const auto p = t[k], q = t[(k + 1) % 3];
      l.kind = Location::edge;
      l.a = std::min(p, q);
      l.b = std::max(p, q);
      l.t = (1 - u) * param_on(location_of(b), p, q) + u * param_on(location_of(c), p, q);
      return l;
    }
    const Bary wb = bary_of(mesh_.triangles, f, location_of(b)), wc = bary_of(mesh_.triangles, f, location_of(c));
    l.kind = Location::face;
    l.a = f;
    for (int i = 0; i < 3; ++i) l.w[i] = (1 - u) * wb[i] + u * wc[i];
    return l;
  }

  std::uint32_t add_vertex(const Location& l) {
    positions_.push_back(position_of(mesh_, l));
    origins_.push_back(l);
    return std::uint32_t(positions_.size() - 1);
  }

  std::uint32_t add_triangle(const Tri& t, std::uint32_t source) {
    tris_.push_back(t);
    source_.push_back(source);
    subs(source).push_back(std::uint32_t(tris_.size() - 1));
    return std::uint32_t(tris_.size() - 1);
  }

  std::uint32_t split_face(std::uint32_t t, const Location& l) {
    const auto m = add_vertex(l);
    const Tri old = tris_[t];
    tris_[t] = {old[0], old[1], m};
    add_triangle({old[1], old[2], m}, source_[t]);
    add_triangle({old[2], old[0], m}, source_[t]);
    return m;
  }

  std::uint32_t split_edge(std::uint32_t f, std::uint32_t b, std::uint32_t c, const Location& l) {
    std::vector<std::uint32_t> faces{f};
    const int k = original_edge_of(f, b, c);
    if (k >= 0 && across_[f][k] != kNone) faces.push_back(across_[f][k]);
    const auto m = add_vertex(l);
    for (auto g : faces) {
      const std::vector<std::uint32_t> list = subs(g);  // copy: add_triangle appends to it
      for (auto t : list) {
        const Tri old = tris_[t];
        for (int i = 0; i < 3; ++i) {
          const auto u0 = old[i], u1 = old[(i + 1) % 3], o = old[(i + 2) % 3];
          if (edge_key(u0, u1) != edge_key(b, c)) continue;
          tris_[t] = {u0, m, o};
          add_triangle({m, u1, o}, g);
          break;
        }
      }
    }
    const auto it = cuts_.find(edge_key(b, c));
    if (it != cuts_.end()) {
      const int owner = it->second;
      cuts_.erase(it);
      cuts_.emplace(edge_key(b, m), owner);
      cuts_.emplace(edge_key(m, c), owner);
    }
    return m;
  }

  void cut(std::uint32_t a, std::uint32_t b, int line) {
    if (a != b) cuts_.emplace(edge_key(a, b), line);
  }

  const PreparedMesh& mesh_;
  const std::vector<Tri>& across_;
  double snap_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Tri> tris_;
  std::vector<std::uint32_t> source_;
  std::vector<std::vector<std::uint32_t>> subs_;
  std::vector<Location> origins_;  ///< of vertex n_vertices() + i
  std::unordered_map<std::uint64_t, int> cuts_;  ///< cut edge -> the line that cut it first
};

// ---------------------------------------------------------------------------------------------
// Labelling
// ---------------------------------------------------------------------------------------------

/// Flood fill: faces joined across the links of `across`. Returns the number of labels (in order
/// of each label's lowest face).
int flood_fill(const std::vector<Tri>& across, std::vector<int>& labels) {
  labels.assign(across.size(), -1);
  int count = 0;
  std::vector<std::uint32_t> stack;
  for (std::uint32_t s = 0; s < across.size(); ++s) {
    if (labels[s] >= 0) continue;
    labels[s] = count;
    stack.assign(1, s);
    while (!stack.empty()) {
      const auto f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const auto g = across[f][k];
        if (g == kNone || labels[g] >= 0) continue;
        labels[g] = count;
        stack.push_back(g);
      }
    }
    ++count;
  }
  return count;
}

std::string percent(double fraction) {
  std::ostringstream out;
  out.precision(fraction < 0.001 ? 2 : 3);
  out << 100 * fraction << "%";
  return out.str();
}

}  // namespace

SegmentationResult segment_mesh(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                const SegmentationOptions& options, const Cancellation* cancel) {
  const auto start = Clock::now();
  throw_if_cancelled(cancel);
  if (lines.empty()) throw InvalidInputError("segmentation needs at least one feature line");
  if (!(options.min_segment_area_fraction >= 0 && options.min_segment_area_fraction < 1))
    throw InvalidInputError("min_segment_area_fraction must be in [0, 1)");
  if (!(options.attach_distance >= 0 && std::isfinite(options.attach_distance)))
    throw InvalidInputError("attach_distance must be a finite number >= 0");
  if (!(options.remesh_snap >= 0 && options.remesh_snap < 0.25))
    throw InvalidInputError("remesh_snap must be in [0, 0.25)");
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].refined.size() < 2)
      throw InvalidInputError("line " + std::to_string(i) + " has fewer than two refined points");
    for (std::size_t j = 0; j < lines[i].refined.size(); ++j) validate_point(mesh, lines[i].refined[j], i, j);
  }

  SegmentationResult result;
  const auto& tris0 = mesh.triangles;
  const std::size_t n0 = mesh.n_vertices();
  const VertexFaces vf0(tris0, n0);
  const auto across0 = face_adjacency(tris0, n0);
  std::vector<char> on_boundary(n0, 0);
  for (std::uint32_t f = 0; f < tris0.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (across0[f][k] == kNone) on_boundary[tris0[f][k]] = on_boundary[tris0[f][(k + 1) % 3]] = 1;
  // In edge lengths where each line ends (local_edge_length), not the mesh's mean edge.
  const double attach_distance = options.attach_distance;
  std::vector<std::string> loose_ends;  // open ends touching neither the boundary nor another line
  std::size_t fallbacks = 0;  // pieces of lines cut along edges (remesh) because the walk got lost
  std::vector<std::size_t> gaps(lines.size(), 0);  // pieces between parts of the mesh that share no edge

  std::unordered_map<std::uint64_t, int> cuts;
  const std::vector<Tri>* tris = &tris0;
  const std::vector<Eigen::Vector3d>* positions = &mesh.positions;
  std::vector<Tri> across_new;
  const std::vector<Tri>* across = &across0;
  std::optional<VertexFaces> vf_new;
  const VertexFaces* vf = &vf0;

  if (options.mode == SegmentationMode::snap) {
    // The paper: "the vertices nearest to the obtained feature line are finally chosen as the
    // segmentation line". Nearest corner of each refined point, consecutive ones joined by
    // shortest edge paths; the chain's edges are cut.
    PathFinder paths(mesh);
    std::vector<std::vector<std::uint32_t>> chains(lines.size());
    std::vector<std::vector<char>> linked(lines.size());  // linked[i][k]: chain[k-1] -- chain[k] is an edge
    for (std::size_t i = 0; i < lines.size(); ++i) {
      throw_if_cancelled(cancel);
      auto& chain = chains[i];
      auto append = [&](std::uint32_t v) {
        if (chain.empty()) {
          chain.push_back(v);
          linked[i].push_back(0);
          return;
        }
        const auto last = chain.back();
        if (v == last) return;
        if (are_neighbors(mesh, last, v)) {
          chain.push_back(v);
          linked[i].push_back(1);
          return;
        }
        const auto path = paths.find(last, [v](std::uint32_t w) { return w == v; }, HUGE_VAL);
        if (path.empty()) {  // across parts of the mesh that share no edge: a gap in the chain
          ++gaps[i];
          chain.push_back(v);
          linked[i].push_back(0);
          return;
        }
        chain.insert(chain.end(), path.begin() + 1, path.end());
        linked[i].resize(chain.size(), 1);
      };
      for (const auto& s : lines[i].refined) {
        const Tri& t = tris0[s.face];
        const Eigen::Vector3d x = s.barycentric[0] * mesh.positions[t[0]] + s.barycentric[1] * mesh.positions[t[1]] +
                                  s.barycentric[2] * mesh.positions[t[2]];
        std::uint32_t nearest = t[0];
        for (auto v : t)
          if ((mesh.positions[v] - x).squaredNorm() < (mesh.positions[nearest] - x).squaredNorm()) nearest = v;
        append(nearest);
      }
      if (lines[i].closed && chain.size() > 2) append(chain.front());
    }
    // Open ends join the boundary or another line nearby.
    for (std::size_t i = 0; i < lines.size(); ++i) {
      if (lines[i].closed) continue;
      for (int end = 0; end < 2; ++end) {
        const auto v = end == 0 ? chains[i].front() : chains[i].back();
        auto attached = [&](std::uint32_t w) {
          if (on_boundary[w]) return true;
          for (std::size_t j = 0; j < lines.size(); ++j)
            if (j != i && std::find(chains[j].begin(), chains[j].end(), w) != chains[j].end()) return true;
          return false;
        };
        if (attached(v)) continue;
        const double attach_radius = attach_distance * local_edge_length(mesh, v);
        const auto path = attach_radius > 0 ? paths.find(v, attached, attach_radius) : std::vector<std::uint32_t>{};
        if (path.empty()) {
          loose_ends.push_back("line " + std::to_string(i) + " ends at vertex " + std::to_string(v) +
                               ", on neither the mesh boundary nor another line");
          continue;
        }
        for (std::size_t k = 1; k < path.size(); ++k) cuts.emplace(edge_key(path[k - 1], path[k]), int(i));
      }
    }
    for (std::size_t i = 0; i < lines.size(); ++i)
      for (std::size_t k = 1; k < chains[i].size(); ++k)
        if (linked[i][k]) cuts.emplace(edge_key(chains[i][k - 1], chains[i][k]), int(i));
  } else {
    // Fig. 8: new vertices along the line, the faces it crosses split.
    const double snap = std::max(options.remesh_snap, 1e-6);
    Tracer tracer(mesh, vf0, snap);
    Remesher remesher(mesh, across0, snap);
    for (std::size_t i = 0; i < lines.size(); ++i) {
      throw_if_cancelled(cancel);
      std::vector<SurfacePoint> points = lines[i].refined;
      if (!lines[i].closed) {
        // Join each loose end to the nearest boundary vertex or point of another line nearby.
        for (int end = 0; end < 2; ++end) {
          const SurfacePoint& e = end == 0 ? points.front() : points.back();
          const Location l = classify(tris0, e.face, e.barycentric, snap);
          bool attached = l.kind == Location::vertex && on_boundary[l.a];
          if (l.kind == Location::edge)
            for (int k = 0; k < 3; ++k) {
              const Tri& t = tris0[l.home];
              if (across0[l.home][k] == kNone && on_edge(l, t[k], t[(k + 1) % 3])) attached = true;
            }
          if (attached) continue;
          const Eigen::Vector3d x = position_of(mesh, l);
          const auto& home = tris0[l.home];
          double best = attach_distance * (local_edge_length(mesh, home[0]) + local_edge_length(mesh, home[1]) +
                                           local_edge_length(mesh, home[2])) / 3;
          std::optional<SurfacePoint> join;
          for (std::uint32_t v = 0; v < n0; ++v)
            if (on_boundary[v] && (mesh.positions[v] - x).norm() <= best)
              best = (mesh.positions[v] - x).norm(), join = surface_point_at_vertex(mesh, v);
          for (std::size_t j = 0; j < lines.size(); ++j)
            if (j != i)
              for (const auto& s : lines[j].refined)
                if ((s.position - x).norm() <= best) best = (s.position - x).norm(), join = s;
          if (!join) {
            std::ostringstream msg;
            msg << "line " << i << " ends at (" << x.x() << ", " << x.y() << ", " << x.z()
                << "), on neither the mesh boundary nor another line";
            loose_ends.push_back(msg.str());
            continue;
          }
          if (end == 0) points.insert(points.begin(), *join);
          else points.push_back(*join);
        }
      }
      std::vector<Location> locations;
      for (const auto& s : points) {
        const auto l = classify(tris0, s.face, s.barycentric, snap);
        if (locations.empty() || !same_location(locations.back(), l)) locations.push_back(l);
      }
      if (lines[i].closed && locations.size() > 2 && !same_location(locations.back(), locations.front()))
        locations.push_back(locations.front());
      std::vector<Step> steps;
      for (std::size_t k = 1; k < locations.size(); ++k) {
        const auto how = tracer.trace(locations[k - 1], locations[k], steps);
        fallbacks += how == Traced::along_edges;
        gaps[i] += how == Traced::gap;
      }
      auto x = remesher.locate(locations.front());
      for (const auto& step : steps) x = step.gap ? remesher.locate(step.to) : remesher.walk(x, step.to, step.face, int(i));
    }
    result.positions = std::move(remesher.positions());
    result.triangles = std::move(remesher.triangles());
    result.source_faces = std::move(remesher.sources());
    result.remeshed = true;
    cuts = remesher.cuts();
    vf_new.emplace(result.triangles, result.positions.size());
    vf = &*vf_new;
    across_new = face_adjacency(result.triangles, result.positions.size());
    tris = &result.triangles;
    positions = &result.positions;
    across = &across_new;
  }

  throw_if_cancelled(cancel);
  // Label: faces connected across uncut edges; count what the cuts added to the components.
  std::vector<int> labels;
  const int base = flood_fill(*across, labels);
  int count = flood_fill(sever(*tris, *vf, *across, cuts), labels);
  if (count <= base) {
    std::ostringstream msg;
    msg << "the lines close no region: cutting along " << (lines.size() == 1 ? "the line" : "them")
        << " leaves every part of the mesh in one piece";
    if (!loose_ends.empty()) {
      msg << " (" << loose_ends.front();
      if (loose_ends.size() > 1) msg << "; and " << loose_ends.size() - 1 << " more loose end(s)";
      msg << "); an open line must end on the mesh boundary or on another line";
    } else {
      msg << " (a loop around a handle or a line along the boundary separates nothing)";
    }
    throw GeometryError(msg.str());
  }

  // Optionally, tiny segments join the neighbour they share the most cut boundary with.
  std::size_t merged = 0;
  if (options.merge_tiny_segments && options.min_segment_area_fraction > 0) {
    std::vector<double> area(static_cast<std::size_t>(count), 0.0);
    double total = 0;
    for (std::uint32_t f = 0; f < tris->size(); ++f) {
      const double a = triangle_area(*positions, (*tris)[f]);
      area[std::size_t(labels[f])] += a;
      total += a;
    }
    std::map<std::pair<int, int>, double> shared;  // label pair -> length of cut boundary between them
    for (std::uint32_t f = 0; f < tris->size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const auto g = (*across)[f][k];
        if (g == kNone || g < f || labels[g] == labels[f]) continue;
        const auto a = (*tris)[f][k], b = (*tris)[f][(k + 1) % 3];
        shared[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}] += ((*positions)[a] - (*positions)[b]).norm();
      }
    std::vector<int> parent(static_cast<std::size_t>(count));
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[std::size_t(x)] != x) x = parent[std::size_t(x)] = parent[std::size_t(parent[std::size_t(x)])];
      return x;
    };
    std::vector<int> by_area(static_cast<std::size_t>(count));
    std::iota(by_area.begin(), by_area.end(), 0);
    std::sort(by_area.begin(), by_area.end(), [&](int a, int b) { return area[std::size_t(a)] < area[std::size_t(b)]; });
    for (int r : by_area) {
      const int root = find(r);
      if (area[std::size_t(root)] >= options.min_segment_area_fraction * total) continue;
      std::map<int, double> neighbours;
      for (const auto& [pair, length] : shared) {
        const int a = find(pair.first), b = find(pair.second);
        if (a != b && (a == root || b == root)) neighbours[a == root ? b : a] += length;
      }
      if (neighbours.empty()) continue;  // a separate component of the mesh: nothing to join
      const auto best = std::max_element(neighbours.begin(), neighbours.end(),
                                         [](const auto& x, const auto& y) { return x.second < y.second; });
      parent[std::size_t(root)] = best->first;
      area[std::size_t(best->first)] += area[std::size_t(root)];
      ++merged;
    }
    std::vector<int> compact(static_cast<std::size_t>(count), -1);
    int n = 0;
    for (int r = 0; r < count; ++r)
      if (find(r) == r) compact[std::size_t(r)] = n++;
    for (auto& l : labels) l = compact[std::size_t(find(l))];
    count = n;
    if (count <= base)
      throw GeometryError("the lines close no region larger than min_segment_area_fraction (" +
                          std::to_string(options.min_segment_area_fraction) +
                          " of the area): every region they close was merged back into its neighbour");
  }

  // Measures per label, then labels by decreasing area.
  std::vector<Segment> segments(static_cast<std::size_t>(count));
  std::vector<std::uint32_t> first_face(std::size_t(count), kNone);
  for (auto& s : segments) {
    s.bbox_min = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    s.bbox_max = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  }
  for (std::uint32_t f = 0; f < tris->size(); ++f) {
    auto& s = segments[std::size_t(labels[f])];
    if (first_face[std::size_t(labels[f])] == kNone) first_face[std::size_t(labels[f])] = f;
    ++s.faces;
    s.area += triangle_area(*positions, (*tris)[f]);
    for (auto v : (*tris)[f])
      for (int d = 0; d < 3; ++d) {
        s.bbox_min[d] = std::min(s.bbox_min[d], (*positions)[v][d]);
        s.bbox_max[d] = std::max(s.bbox_max[d], (*positions)[v][d]);
      }
  }
  std::vector<char> line_separates(lines.size(), 0);
  for (std::uint32_t f = 0; f < tris->size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto g = (*across)[f][k];
      if (g == kNone || g < f || labels[g] == labels[f]) continue;
      const auto a = (*tris)[f][k], b = (*tris)[f][(k + 1) % 3];
      const double length = ((*positions)[a] - (*positions)[b]).norm();
      segments[std::size_t(labels[f])].boundary_length += length;
      segments[std::size_t(labels[g])].boundary_length += length;
      const auto it = cuts.find(edge_key(a, b));
      if (it != cuts.end()) line_separates[std::size_t(it->second)] = 1;
    }
  std::vector<int> order(static_cast<std::size_t>(count));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    if (segments[std::size_t(a)].area != segments[std::size_t(b)].area)
      return segments[std::size_t(a)].area > segments[std::size_t(b)].area;
    return first_face[std::size_t(a)] < first_face[std::size_t(b)];
  });
  std::vector<int> rank(static_cast<std::size_t>(count));
  for (int r = 0; r < count; ++r) rank[std::size_t(order[std::size_t(r)])] = r;
  result.labels.resize(labels.size());
  for (std::size_t f = 0; f < labels.size(); ++f) result.labels[f] = rank[std::size_t(labels[f])];
  for (int r = 0; r < count; ++r) {
    result.segments.push_back(segments[std::size_t(order[std::size_t(r)])]);
    result.segments.back().label = r;
    result.total_area += result.segments.back().area;
  }
  result.cut_edges = cuts.size();

  // Warnings: loose ends, lines that separate nothing, pieces traced along edges, tiny segments.
  for (const auto& e : loose_ends) result.warnings.push_back(e + "; it cuts into a region without closing it");
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (!line_separates[i])
      result.warnings.push_back("line " + std::to_string(i) + " separates no segments from each other (it " +
                                (lines[i].closed ? "runs inside one segment" : "is open and ends inside a segment") + ")");
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (gaps[i] > 0)
      result.warnings.push_back("line " + std::to_string(i) + " jumps " + std::to_string(gaps[i]) +
                                " time(s) between parts of the mesh that share no edge (a seam of duplicated "
                                "vertices or separate components); it is not cut across those gaps");
  if (fallbacks > 0)
    result.warnings.push_back(std::to_string(fallbacks) +
                              " piece(s) of the lines between consecutive refined points could not be followed "
                              "across faces and were cut along mesh edges instead");
  if (merged > 0)
    result.warnings.push_back(std::to_string(merged) +
                              " segment(s) below min_segment_area_fraction were merged into the neighbour they share "
                              "the most cut boundary with");
  for (const auto& s : result.segments) {
    const double fraction = result.total_area > 0 ? s.area / result.total_area : 0;
    if (fraction < options.min_segment_area_fraction) {
      std::ostringstream msg;
      msg << "segment " << s.label << " is tiny: " << percent(fraction) << " of the area (" << s.faces
          << " face(s)), below min_segment_area_fraction " << options.min_segment_area_fraction
          << "; lines that nearly meet or cross, or a line doubling back on itself, leave such slivers";
      result.warnings.push_back(msg.str());
    }
  }
  result.elapsed_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  return result;
}

}  // namespace featureline
