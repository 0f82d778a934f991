#include "engine/surface_point.h"

#include <algorithm>
#include <cmath>

#include "engine/errors.h"
#include "engine/internal/geometry.h"

namespace featureline {

bool same_location(const SurfaceLocation& x, const SurfaceLocation& y) {
  if (x.kind != y.kind || x.a != y.a) return false;
  switch (x.kind) {
    case SurfaceLocation::vertex: return true;
    case SurfaceLocation::edge: return x.b == y.b && std::abs(x.t - y.t) <= kSameLocation;
    case SurfaceLocation::face:
      return std::abs(x.w[0] - y.w[0]) <= kSameLocation && std::abs(x.w[1] - y.w[1]) <= kSameLocation &&
             std::abs(x.w[2] - y.w[2]) <= kSameLocation;
  }
  return false;
}

SurfaceLocation vertex_location(std::uint32_t v, std::uint32_t home) {
  SurfaceLocation l;
  l.kind = SurfaceLocation::vertex;
  l.a = v;
  l.home = home;
  return l;
}

SurfaceLocation locate_in_face(const std::vector<Triangle>& tris, std::uint32_t f, Barycentric w, double snap) {
  double sum = 0;
  for (auto& x : w) sum += (x = std::max(x, 0.0));
  if (!(sum > 0)) w = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  else
    for (auto& x : w) x /= sum;
  const Triangle& t = tris[f];
  const int top = int(std::max_element(w.begin(), w.end()) - w.begin());
  int small = 0, k_small = -1;
  for (int k = 0; k < 3; ++k)
    if (w[k] < snap) ++small, k_small = k;
  if (w[top] >= 1 - snap || small >= 2) return vertex_location(t[top], f);
  SurfaceLocation l;
  l.home = f;
  if (small == 1) {
    const int i = (k_small + 1) % 3, j = (k_small + 2) % 3;
    l.kind = SurfaceLocation::edge;
    l.a = t[i];
    l.b = t[j];
    l.t = w[j] / (w[i] + w[j]);
    if (l.a > l.b) std::swap(l.a, l.b), l.t = 1 - l.t;
    if (l.t < snap) return vertex_location(l.a, f);
    if (l.t > 1 - snap) return vertex_location(l.b, f);
    return l;
  }
  l.kind = SurfaceLocation::face;
  l.a = f;
  l.w = w;
  return l;
}

std::optional<Barycentric> barycentric_in(const std::vector<Triangle>& tris, std::uint32_t f, const SurfaceLocation& l) {
  const Triangle& t = tris[f];
  Barycentric w{0, 0, 0};
  switch (l.kind) {
    case SurfaceLocation::vertex: {
      const int k = corner_of(t, l.a);
      if (k < 0) return std::nullopt;
      w[k] = 1;
      return w;
    }
    case SurfaceLocation::edge: {
      const int ka = corner_of(t, l.a), kb = corner_of(t, l.b);
      if (ka < 0 || kb < 0) return std::nullopt;
      w[ka] = 1 - l.t;
      w[kb] = l.t;
      return w;
    }
    case SurfaceLocation::face:
      if (l.a != f) return std::nullopt;
      return l.w;
  }
  return std::nullopt;
}

bool lies_on_edge(const SurfaceLocation& l, std::uint32_t p, std::uint32_t q) {
  if (l.kind == SurfaceLocation::vertex) return l.a == p || l.a == q;
  if (l.kind == SurfaceLocation::edge) return (l.a == p && l.b == q) || (l.a == q && l.b == p);
  return false;
}

double edge_parameter(const SurfaceLocation& l, std::uint32_t p, std::uint32_t q) {
  if (l.kind == SurfaceLocation::vertex) return l.a == std::min(p, q) ? 0.0 : 1.0;
  return l.t;
}

Eigen::Vector3d position_of(const PreparedMesh& mesh, const SurfaceLocation& l) {
  const auto& p = mesh.positions();
  switch (l.kind) {
    case SurfaceLocation::vertex: return p[l.a];
    case SurfaceLocation::edge: return (1 - l.t) * p[l.a] + l.t * p[l.b];
    case SurfaceLocation::face: return mesh.point_at(l.a, l.w);
  }
  return p[0];
}

std::uint32_t nearest_corner(const PreparedMesh& pm, const SurfacePoint& p) {
  const int k = int(std::max_element(p.barycentric.begin(), p.barycentric.end()) - p.barycentric.begin());
  return pm.triangles()[p.face][std::size_t(k)];
}

SurfacePoint surface_point_at_vertex(const PreparedMesh& pm, std::uint32_t v) {
  SurfacePoint s;
  s.position = pm.positions()[v];
  s.face = pm.vertex_face()[v];
  const auto& t = pm.triangles()[s.face];
  for (int k = 0; k < 3; ++k) s.barycentric[k] = t[k] == v ? 1.0 : 0.0;
  return s;
}

void check_surface_point(const PreparedMesh& mesh, std::uint32_t face, const Barycentric& barycentric,
                         const std::string& where) {
  if (face >= mesh.triangles().size())
    throw InvalidInputError(where + ": face " + std::to_string(face) + " is out of range (the mesh has " +
                            std::to_string(mesh.triangles().size()) + " faces)");
  double sum = 0;
  for (double x : barycentric) {
    if (!std::isfinite(x) || x < -1e-6)
      throw InvalidInputError(where + ": barycentric coordinates must be finite and non-negative");
    sum += x;
  }
  if (std::abs(sum - 1) > 1e-6) throw InvalidInputError(where + ": barycentric coordinates must sum to 1");
}

}  // namespace featureline
