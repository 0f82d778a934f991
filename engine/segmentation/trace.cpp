#include "engine/segmentation/trace.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/internal/edge_search.h"

namespace featureline {

Traced Tracer::trace(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const {
  if (same_location(from, to)) return Traced::straight;
  const std::size_t mark = steps.size();
  if (walk(from, to, steps)) return Traced::straight;
  steps.resize(mark);
  return along_edges(from, to, steps);
}

std::vector<std::uint32_t> Tracer::faces_containing(const SurfaceLocation& l) const {
  const VertexFaces& vf = mesh_.vertex_faces();
  std::vector<std::uint32_t> out;
  switch (l.kind) {
    case SurfaceLocation::vertex: out.assign(vf.begin(l.a), vf.end(l.a)); break;
    case SurfaceLocation::edge:
      for (auto it = vf.begin(l.a); it != vf.end(l.a); ++it)
        if (corner_of(mesh_.triangles()[*it], l.b) >= 0) out.push_back(*it);
      break;
    case SurfaceLocation::face: out.push_back(l.a); break;
  }
  return out;
}

/// Barycentric coordinates in face f of x projected on f's plane (outside f when x is).
std::optional<Barycentric> Tracer::project(std::uint32_t f, const Eigen::Vector3d& x) const {
  const Triangle& t = mesh_.triangles()[f];
  const auto& p = mesh_.positions();
  const Eigen::Vector3d e1 = p[t[1]] - p[t[0]], e2 = p[t[2]] - p[t[0]], r = x - p[t[0]];
  const double a = e1.dot(e1), b = e1.dot(e2), c = e2.dot(e2), det = a * c - b * b;
  if (!(det > 1e-24 * a * c)) return std::nullopt;
  const double u = (c * e1.dot(r) - b * e2.dot(r)) / det, v = (a * e2.dot(r) - b * e1.dot(r)) / det;
  return Barycentric{1 - u - v, u, v};
}

/// `to` (held by face g, f's neighbour across an edge) in f's barycentric frame, with g unfolded
/// into f's plane across the shared edge; nullopt when f and g share no edge or are degenerate.
std::optional<Barycentric> Tracer::unfold_into(std::uint32_t f, std::uint32_t g, const SurfaceLocation& to) const {
  const Triangle& tf = mesh_.triangles()[f];
  const Triangle& tg = mesh_.triangles()[g];
  const auto& p = mesh_.positions();
  int shared = 0, s = -1;
  for (int k = 0; k < 3; ++k) {
    if (corner_of(tf, tg[k]) >= 0) ++shared;
    else s = k;
  }
  if (shared != 2) return std::nullopt;
  const auto wg = barycentric_of(mesh_.triangles(), g, to);
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
  return Barycentric{1 - w1 - w2, w1, w2};
}

/// The target `to` in face f's barycentric frame: exact when f holds it, unfolded across the
/// shared edge when a face holding it is f's neighbour, else projected on f's plane.
std::optional<Barycentric> Tracer::target_in(std::uint32_t f, const SurfaceLocation& to,
                                             const Eigen::Vector3d& target) const {
  if (auto w = barycentric_in(mesh_.triangles(), f, to)) return w;
  for (auto g : faces_containing(to)) {
    const Triangle& tf = mesh_.triangles()[f];
    const Triangle& tg = mesh_.triangles()[g];
    int shared = 0;
    for (int k = 0; k < 3; ++k) shared += corner_of(tf, tg[k]) >= 0;
    if (shared != 2) continue;
    return unfold_into(f, g, to);
  }
  return project(f, target);
}

/// Leaves vertex c through the face whose corner angle holds the direction to the target.
bool Tracer::leave_vertex(const SurfaceLocation& c, const SurfaceLocation& to, const Eigen::Vector3d& target,
                          SurfaceLocation& next, std::uint32_t& face) const {
  const auto& tris = mesh_.triangles();
  const VertexFaces& vf = mesh_.vertex_faces();
  double best = -HUGE_VAL;
  Barycentric best_q{0, 0, 0};
  int best_k = 0;
  face = kNoIndex;
  for (auto it = vf.begin(c.a); it != vf.end(c.a); ++it) {
    const auto q = target_in(*it, to, target);
    if (!q) continue;
    const int k = corner_of(tris[*it], c.a), j = (k + 1) % 3, l = (k + 2) % 3;
    const double score = std::min((*q)[j], (*q)[l]) / (std::abs((*q)[j]) + std::abs((*q)[l]) + 1e-300);
    if (score > best) best = score, face = *it, best_q = *q, best_k = k;
  }
  if (face == kNoIndex) return false;
  const int j = (best_k + 1) % 3, l = (best_k + 2) % 3;
  const double dj = best_q[j], dl = best_q[l];
  if (!(dj + dl > 0)) return false;
  const double u = std::clamp(dl / (dj + dl), 0.0, 1.0);
  Barycentric w{0, 0, 0};
  w[j] = 1 - u;
  w[l] = u;
  next = locate_in_face(tris, face, w, snap_);
  return true;
}

/// Leaves an edge or face point c: moves inside the candidate face the direction enters (an edge
/// point has two) to where it exits that face; along the edge when the line runs along it.
bool Tracer::leave_edge_or_face(const SurfaceLocation& c, std::uint32_t came_from, const SurfaceLocation& to,
                               const Eigen::Vector3d& target, SurfaceLocation& next, std::uint32_t& face) const {
  const auto& tris = mesh_.triangles();
  std::vector<std::uint32_t> candidates;
  if (c.kind == SurfaceLocation::face) candidates.push_back(c.a);
  else
    for (auto f : faces_containing(c))
      if (f != came_from) candidates.push_back(f);
  double best = -HUGE_VAL;
  Barycentric best_p{0, 0, 0}, best_d{0, 0, 0};
  face = kNoIndex;
  for (auto f : candidates) {
    const auto q = target_in(f, to, target);
    if (!q) continue;
    const Barycentric pc = barycentric_of(tris, f, c);
    Barycentric d;
    double norm = 0;
    for (int k = 0; k < 3; ++k) d[k] = (*q)[k] - pc[k], norm += d[k] * d[k];
    if (!(norm > 0)) continue;
    double score = 1;  // a face point may go anywhere
    if (c.kind == SurfaceLocation::edge) score = d[3 - corner_of(tris[f], c.a) - corner_of(tris[f], c.b)] / std::sqrt(norm);
    if (score > best) best = score, face = f, best_p = pc, best_d = d;
  }
  if (c.kind == SurfaceLocation::edge && !(best > 1e-9)) {
    // The line runs along this edge (or the estimates disagree about its side): go on from the
    // edge's end it heads for.
    face = faces_containing(c).front();
    const auto q = target_in(face, to, target);
    if (!q) return false;
    const Barycentric pc = barycentric_of(tris, face, c);
    const int ka = corner_of(tris[face], c.a), kb = corner_of(tris[face], c.b);
    next = vertex_location((*q)[ka] - pc[ka] > (*q)[kb] - pc[kb] ? c.a : c.b, face);
    return true;
  }
  if (face == kNoIndex || !(best > 0)) return false;
  double s_min = HUGE_VAL;
  int exit = -1;
  for (int k = 0; k < 3; ++k)
    if (best_d[k] < 0 && best_p[k] > 0) {
      const double s = best_p[k] / -best_d[k];
      if (s < s_min) s_min = s, exit = k;
    }
  if (exit < 0) return false;
  Barycentric w;
  for (int k = 0; k < 3; ++k) w[k] = best_p[k] + s_min * best_d[k];
  w[exit] = 0;
  next = locate_in_face(tris, face, w, snap_);
  return true;
}

bool Tracer::walk(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const {
  const Eigen::Vector3d target = position_of(mesh_, to);
  SurfaceLocation c = from;
  std::uint32_t came_from = kNoIndex;
  for (int step = 0; step < 64; ++step) {
    for (auto f : faces_containing(c))
      if (barycentric_in(mesh_.triangles(), f, to)) {
        steps.push_back({to, f});
        return true;
      }
    SurfaceLocation next;
    std::uint32_t face = kNoIndex;
    const bool moved = c.kind == SurfaceLocation::vertex ? leave_vertex(c, to, target, next, face)
                                                         : leave_edge_or_face(c, came_from, to, target, next, face);
    if (!moved || same_location(next, c)) return false;
    steps.push_back({next, face});
    came_from = face;
    c = next;
  }
  return false;
}

std::uint32_t Tracer::nearest_vertex(const SurfaceLocation& l) const {
  switch (l.kind) {
    case SurfaceLocation::vertex: return l.a;
    case SurfaceLocation::edge: return l.t < 0.5 ? l.a : l.b;
    case SurfaceLocation::face: {
      const int k = int(std::max_element(l.w.begin(), l.w.end()) - l.w.begin());
      return mesh_.triangles()[l.a][k];
    }
  }
  return l.a;
}

std::uint32_t Tracer::face_with_edge(std::uint32_t a, std::uint32_t b) const {
  const VertexFaces& vf = mesh_.vertex_faces();
  for (auto it = vf.begin(a); it != vf.end(a); ++it)
    if (corner_of(mesh_.triangles()[*it], b) >= 0) return *it;
  return kNoIndex;
}

Traced Tracer::along_edges(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const {
  const std::uint32_t a = nearest_vertex(from), b = nearest_vertex(to);
  const auto path = a == b ? std::vector<std::uint32_t>{a}
                           : shortest_path_between(mesh_, a, b, HUGE_VAL);
  if (path.empty()) {
    steps.push_back({to, to.home, true});
    return Traced::gap;
  }
  if (from.kind != SurfaceLocation::vertex) steps.push_back({vertex_location(a, from.home), from.home});
  for (std::size_t i = 1; i < path.size(); ++i) {
    const auto f = face_with_edge(path[i - 1], path[i]);
    steps.push_back({vertex_location(path[i], f), f});
  }
  if (to.kind != SurfaceLocation::vertex) steps.push_back({to, to.home});
  return Traced::along_edges;
}

}  // namespace featureline
