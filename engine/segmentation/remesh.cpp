#include "engine/segmentation/remesh.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace featureline {

Remesher::Remesher(const PreparedMesh& mesh, double snap) : mesh_(mesh), snap_(snap), subs_(mesh.triangles().size()) {
  out_.positions = mesh.positions();
  out_.triangles = mesh.triangles();
  out_.source_faces.resize(mesh.triangles().size());
  std::iota(out_.source_faces.begin(), out_.source_faces.end(), 0u);
}

RemeshedCut Remesher::take() { return std::move(out_); }

std::uint32_t Remesher::locate(const SurfaceLocation& y) {
  if (y.kind == SurfaceLocation::vertex) return y.a;
  const std::uint32_t f = y.kind == SurfaceLocation::face ? y.a : y.home;
  return y.kind == SurfaceLocation::edge ? locate_on_edge(f, y) : locate_in_face(f, y);
}

std::uint32_t Remesher::locate_on_edge(std::uint32_t f, const SurfaceLocation& y) {
  for (auto t : subs(f))
    for (int k = 0; k < 3; ++k) {
      const auto b = out_.triangles[t][k], c = out_.triangles[t][(k + 1) % 3];
      const SurfaceLocation lb = location_of(b), lc = location_of(c);
      if (!lies_on_edge(lb, y.a, y.b) || !lies_on_edge(lc, y.a, y.b)) continue;
      const double tb = edge_parameter(lb, y.a, y.b), tc = edge_parameter(lc, y.a, y.b);
      if (std::abs(y.t - tb) <= kSameLocation) return b;
      if (std::abs(y.t - tc) <= kSameLocation) return c;
      if ((y.t - tb) * (y.t - tc) < 0) return split_edge(f, b, c, y);
    }
  throw std::logic_error("segmentation: an edge point is on no sub-edge");
}

/// Inside face f: on a vertex, on a sub-edge or inside the sub-triangle holding it most deeply.
std::uint32_t Remesher::locate_in_face(std::uint32_t f, const SurfaceLocation& y) {
  const Barycentric wy = barycentric_of(mesh_.triangles(), f, y);
  const Eigen::Vector2d py(wy[1], wy[2]);
  double best = -HUGE_VAL;
  std::uint32_t best_t = kNoIndex;
  for (auto t : subs(f)) {
    const auto& tri = out_.triangles[t];
    const auto ab = coords(f, tri[0]), bb = coords(f, tri[1]), cb = coords(f, tri[2]);
    const double det = cross2(bb - ab, cb - ab);
    if (!(det > 0)) continue;
    const double l1 = cross2(py - ab, cb - ab) / det, l2 = cross2(bb - ab, py - ab) / det;
    const double depth = std::min({1 - l1 - l2, l1, l2});
    if (depth > best) best = depth, best_t = t;
  }
  if (best_t == kNoIndex) throw std::logic_error("segmentation: a face point is in no sub-triangle");
  const Triangle t = out_.triangles[best_t];
  for (auto v : t)
    if ((coords(f, v) - py).norm() <= kSameLocation) return v;
  for (int k = 0; k < 3; ++k) {
    const auto b = t[k], c = t[(k + 1) % 3];
    const Eigen::Vector2d pb = coords(f, b), pc = coords(f, c);
    if (std::abs(cross2(pc - pb, py - pb)) / (pc - pb).norm() <= kSameLocation && original_edge_of(f, b, c) < 0)
      return split_edge(f, b, c, y);
  }
  return split_face(best_t, y);
}

std::uint32_t Remesher::walk(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int line) {
  const Triangle& corners = mesh_.triangles()[f];
  const Barycentric wy = barycentric_of(mesh_.triangles(), f, y);
  const Eigen::Vector2d py(wy[1], wy[2]);
  for (int guard = 0; guard < 100000; ++guard) {
    if (y.kind == SurfaceLocation::vertex && x == y.a) return x;
    const SurfaceLocation lx = location_of(x);
    if (y.kind != SurfaceLocation::vertex && (coords(f, x) - py).norm() <= kSameLocation) return x;
    // Both on one edge of the original face: follow its sub-edges.
    int shared_edge = -1;
    for (int k = 0; k < 3 && shared_edge < 0; ++k)
      if (lies_on_edge(lx, corners[k], corners[(k + 1) % 3]) && lies_on_edge(y, corners[k], corners[(k + 1) % 3]))
        shared_edge = k;
    const Move move = shared_edge >= 0 ? move_along_edge(x, y, f, shared_edge, line) : move_across(x, y, f, line);
    if (move.done) return move.vertex;
    x = move.vertex;
  }
  throw std::logic_error("segmentation: the remeshing walk did not end");
}

/// x and y on edge k of original face f: to the next vertex along it, or to y.
Remesher::Move Remesher::move_along_edge(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int k, int line) {
  const Triangle& corners = mesh_.triangles()[f];
  const auto p = corners[k], q = corners[(k + 1) % 3];
  const double tx = edge_parameter(location_of(x), p, q), ty = edge_parameter(y, p, q), dir = ty > tx ? 1.0 : -1.0;
  std::uint32_t b = kNoIndex;
  for (auto t : subs(f)) {
    const int kx = corner_of(out_.triangles[t], x);
    if (kx < 0) continue;
    for (auto w : {out_.triangles[t][(kx + 1) % 3], out_.triangles[t][(kx + 2) % 3]}) {
      const SurfaceLocation lw = location_of(w);
      if (lies_on_edge(lw, p, q) && (edge_parameter(lw, p, q) - tx) * dir > 0) b = w;
    }
  }
  if (b == kNoIndex) throw std::logic_error("segmentation: lost along an edge");
  const double tb = edge_parameter(location_of(b), p, q);
  if ((y.kind == SurfaceLocation::vertex && y.a == b) ||
      (y.kind != SurfaceLocation::vertex && std::abs(tb - ty) <= kSameLocation)) {
    cut(x, b, line);
    return {true, b};
  }
  if ((ty - tx) * dir < (tb - tx) * dir) {
    const auto m = split_edge(f, x, b, y);
    cut(x, m, line);
    return {true, m};
  }
  cut(x, b, line);
  return {false, b};
}

/// From x through the sub-triangle whose corner angle at x holds the direction to y: ends at y
/// when it is in that triangle (or on its far edge), else crosses the far edge.
Remesher::Move Remesher::move_across(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int line) {
  const Barycentric wy = barycentric_of(mesh_.triangles(), f, y);
  const Eigen::Vector2d py(wy[1], wy[2]), px = coords(f, x), vy = py - px;
  double best = -HUGE_VAL;
  std::uint32_t tri = kNoIndex, b = kNoIndex, c = kNoIndex;
  for (auto t : subs(f)) {
    const int k = corner_of(out_.triangles[t], x);
    if (k < 0) continue;
    const auto tb = out_.triangles[t][(k + 1) % 3], tc = out_.triangles[t][(k + 2) % 3];
    const Eigen::Vector2d vb = coords(f, tb) - px, vc = coords(f, tc) - px;
    const double nb = vb.norm() * vy.norm(), nc = vc.norm() * vy.norm();
    if (!(nb > 0) || !(nc > 0)) continue;
    const double score = std::min(cross2(vb, vy) / nb, cross2(vy, vc) / nc);
    if (score > best) best = score, tri = t, b = tb, c = tc;
  }
  if (tri == kNoIndex) throw std::logic_error("segmentation: a line vertex is in no sub-triangle");
  const Eigen::Vector2d pb = coords(f, b), pc = coords(f, c);
  auto end_at = [&](std::uint32_t v) {
    cut(x, v, line);
    return Move{true, v};
  };
  if (y.kind == SurfaceLocation::vertex) {
    if (b == y.a || c == y.a) return end_at(y.a);
  } else {
    for (auto v : {b, c})
      if ((coords(f, v) - py).norm() <= kSameLocation) return end_at(v);
  }
  const int border = original_edge_of(f, b, c);
  if (y.kind == SurfaceLocation::face) {
    const double height = cross2(pc - pb, py - pb) / (pc - pb).norm();
    if (height > kSameLocation) return end_at(split_face(tri, y));
    if (height >= -kSameLocation && border < 0) return end_at(split_edge(f, b, c, y));
  } else if (border >= 0) {
    const Triangle& corners = mesh_.triangles()[f];
    const auto p = corners[border], q = corners[(border + 1) % 3];
    if (lies_on_edge(y, p, q)) {
      const double tb = edge_parameter(location_of(b), p, q), tc = edge_parameter(location_of(c), p, q);
      const double ty = edge_parameter(y, p, q);
      if ((ty - tb) * (ty - tc) < 0) return end_at(split_edge(f, b, c, y));
    }
  }
  // The segment leaves this triangle through edge bc.
  const double ob = cross2(vy, pb - px), oc = cross2(vy, pc - px);
  double u = ob != oc ? std::clamp(ob / (ob - oc), 0.0, 1.0) : 0.5;
  if (border >= 0) u = u < 0.5 ? 0 : 1;  // never split the face's border on the way: y is inside
  std::uint32_t next;
  if (u <= snap_ || u >= 1 - snap_) next = u <= snap_ ? b : c;
  else next = split_edge(f, b, c, between(f, b, c, u));
  cut(x, next, line);
  return {false, next};
}

SurfaceLocation Remesher::location_of(std::uint32_t v) const {
  if (v < mesh_.n_vertices()) return vertex_location(v, 0);
  return origins_[v - mesh_.n_vertices()];
}

Eigen::Vector2d Remesher::coords(std::uint32_t f, std::uint32_t v) const {
  const auto w = barycentric_in(mesh_.triangles(), f, location_of(v));
  if (!w) throw std::logic_error("segmentation: a vertex is not in its face");
  return {(*w)[1], (*w)[2]};
}

std::vector<std::uint32_t>& Remesher::subs(std::uint32_t f) {
  if (subs_[f].empty()) subs_[f].push_back(f);
  return subs_[f];
}

/// k when b and c both lie on edge k = (corner k, corner k+1) of original face f, else -1.
int Remesher::original_edge_of(std::uint32_t f, std::uint32_t b, std::uint32_t c) const {
  const Triangle& t = mesh_.triangles()[f];
  const SurfaceLocation lb = location_of(b), lc = location_of(c);
  for (int k = 0; k < 3; ++k)
    if (lies_on_edge(lb, t[k], t[(k + 1) % 3]) && lies_on_edge(lc, t[k], t[(k + 1) % 3])) return k;
  return -1;
}

/// The point at fraction u from b to c, on the original edge when bc lies on one.
SurfaceLocation Remesher::between(std::uint32_t f, std::uint32_t b, std::uint32_t c, double u) const {
  const Triangle& t = mesh_.triangles()[f];
  const int k = original_edge_of(f, b, c);
  SurfaceLocation l;
  l.home = f;
  if (k >= 0) {
    const auto p = t[k], q = t[(k + 1) % 3];
    l.kind = SurfaceLocation::edge;
    l.a = std::min(p, q);
    l.b = std::max(p, q);
    l.t = (1 - u) * edge_parameter(location_of(b), p, q) + u * edge_parameter(location_of(c), p, q);
    return l;
  }
  const Barycentric wb = barycentric_of(mesh_.triangles(), f, location_of(b));
  const Barycentric wc = barycentric_of(mesh_.triangles(), f, location_of(c));
  l.kind = SurfaceLocation::face;
  l.a = f;
  for (int i = 0; i < 3; ++i) l.w[i] = (1 - u) * wb[i] + u * wc[i];
  return l;
}

std::uint32_t Remesher::add_vertex(const SurfaceLocation& l) {
  out_.positions.push_back(position_of(mesh_, l));
  origins_.push_back(l);
  return std::uint32_t(out_.positions.size() - 1);
}

std::uint32_t Remesher::add_triangle(const Triangle& t, std::uint32_t source) {
  out_.triangles.push_back(t);
  out_.source_faces.push_back(source);
  subs(source).push_back(std::uint32_t(out_.triangles.size() - 1));
  return std::uint32_t(out_.triangles.size() - 1);
}

std::uint32_t Remesher::split_face(std::uint32_t t, const SurfaceLocation& l) {
  const auto m = add_vertex(l);
  const Triangle old = out_.triangles[t];
  out_.triangles[t] = {old[0], old[1], m};
  add_triangle({old[1], old[2], m}, out_.source_faces[t]);
  add_triangle({old[2], old[0], m}, out_.source_faces[t]);
  return m;
}

/// Splits sub-edge bc at l in every sub-triangle holding it, in f and, when bc lies on an
/// original edge, in the face across it; a cut edge stays cut in both halves.
std::uint32_t Remesher::split_edge(std::uint32_t f, std::uint32_t b, std::uint32_t c, const SurfaceLocation& l) {
  std::vector<std::uint32_t> faces{f};
  const int k = original_edge_of(f, b, c);
  if (k >= 0 && mesh_.face_neighbors()[f][k] != kNoIndex) faces.push_back(mesh_.face_neighbors()[f][k]);
  const auto m = add_vertex(l);
  for (auto g : faces) {
    const std::vector<std::uint32_t> list = subs(g);  // copy: add_triangle appends to it
    for (auto t : list) {
      const Triangle old = out_.triangles[t];
      for (int i = 0; i < 3; ++i) {
        const auto u0 = old[i], u1 = old[(i + 1) % 3], o = old[(i + 2) % 3];
        if (edge_key(u0, u1) != edge_key(b, c)) continue;
        out_.triangles[t] = {u0, m, o};
        add_triangle({m, u1, o}, g);
        break;
      }
    }
  }
  const auto it = out_.cuts.find(edge_key(b, c));
  if (it != out_.cuts.end()) {
    const int owner = it->second;
    out_.cuts.erase(it);
    out_.cuts.emplace(edge_key(b, m), owner);
    out_.cuts.emplace(edge_key(m, c), owner);
  }
  return m;
}

void Remesher::cut(std::uint32_t a, std::uint32_t b, int line) {
  if (a != b) out_.cuts.emplace(edge_key(a, b), line);
}

}  // namespace featureline
