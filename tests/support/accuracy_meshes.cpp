#include "tests/support/accuracy_meshes.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>

#include "tests/support/generator_detail.h"

namespace featureline::testing {
namespace {

using detail::kPi;
using detail::positive_finite;
using detail::require;
using detail::Triangle;
using detail::Vec3;

Eigen::Vector3d vec(const Vec3& p) { return {p[0], p[1], p[2]}; }

// Uniform value in [0, 1) from the top 53 bits (identical on every standard library).
double uniform_unit(std::mt19937_64& rng) { return std::ldexp(static_cast<double>(rng() >> 11), -53); }

// Two independent standard normal values (Box-Muller on our own uniform values).
std::pair<double, double> gaussian_pair(std::mt19937_64& rng) {
  const double u1 = 1.0 - uniform_unit(rng);  // (0, 1]: the logarithm stays finite
  const double u2 = uniform_unit(rng);
  const double radius = std::sqrt(-2.0 * std::log(u1));
  return {radius * std::cos(2 * kPi * u2), radius * std::sin(2 * kPi * u2)};
}

// Signed area of the triangle (p, q, s) in the xy plane, times two.
double signed_area_xy(const Vec3& p, const Vec3& q, const Vec3& s) {
  return (q[0] - p[0]) * (s[1] - p[1]) - (s[0] - p[0]) * (q[1] - p[1]);
}

// Adds a triangle of a horizontal cap, oriented counter-clockwise seen from +z when `up`,
// clockwise otherwise (so its normal points out of the slab).
void add_cap_triangle(std::vector<Triangle>& triangles, const std::vector<Vec3>& positions, Triangle t, bool up) {
  const double area = signed_area_xy(positions[t[0]], positions[t[1]], positions[t[2]]);
  if ((area > 0) != up) std::swap(t[1], t[2]);
  triangles.push_back(t);
}

struct SlabLayout {
  double cx = 0, cy = 0;  // centres of the corner arcs are (+-cx, +-cy)
  int nx = 0, ny = 0, cs = 0;
  int count() const { return 2 * nx + 2 * ny + 4 * cs; }
  // First outline index of each of the 8 pieces: right side, arc 1, top side, arc 2, left
  // side, arc 3, bottom side, arc 4.
  int piece_start(int piece) const {
    int start = 0;
    for (int q = 0; q < piece; ++q) start += q % 2 == 1 ? cs : (q % 4 == 0 ? ny : nx);
    return start;
  }
};

// Unit vector at angle (pi/2) * (quadrant + j / cs), exact on the axes.
std::pair<double, double> arc_direction(int quadrant, int j, int cs) {
  double c = 1, s = 0;
  if (j != 0) {
    const double theta = (kPi / 2) * j / cs;
    c = std::cos(theta);
    s = std::sin(theta);
  }
  for (int q = 0; q < quadrant; ++q) {  // rotate by 90 degrees, exactly
    const double t = c;
    c = -s;
    s = t;
  }
  return {c, s};
}

// The outline offset inwards to corner radius rho (rho = r: the outline itself), at height z.
// Its straight sides keep their length, so every ring has the same vertex count and layout.
void add_ring(std::vector<Vec3>& positions, const SlabLayout& l, double rho, double z) {
  const double cx = l.cx, cy = l.cy;
  for (int k = 0; k < l.ny; ++k) positions.push_back({cx + rho, -cy + 2 * cy * k / l.ny, z});
  for (int j = 0; j < l.cs; ++j) {
    const auto [c, s] = arc_direction(0, j, l.cs);
    positions.push_back({cx + rho * c, cy + rho * s, z});
  }
  for (int k = 0; k < l.nx; ++k) positions.push_back({cx - 2 * cx * k / l.nx, cy + rho, z});
  for (int j = 0; j < l.cs; ++j) {
    const auto [c, s] = arc_direction(1, j, l.cs);
    positions.push_back({-cx + rho * c, cy + rho * s, z});
  }
  for (int k = 0; k < l.ny; ++k) positions.push_back({-cx - rho, cy - 2 * cy * k / l.ny, z});
  for (int j = 0; j < l.cs; ++j) {
    const auto [c, s] = arc_direction(2, j, l.cs);
    positions.push_back({-cx + rho * c, -cy + rho * s, z});
  }
  for (int k = 0; k < l.nx; ++k) positions.push_back({-cx + 2 * cx * k / l.nx, -cy - rho, z});
  for (int j = 0; j < l.cs; ++j) {
    const auto [c, s] = arc_direction(3, j, l.cs);
    positions.push_back({cx + rho * c, -cy + rho * s, z});
  }
}

// Zig-zag strip of long thin triangles over a convex outline's vertices (ids first..first+N-1
// in counter-clockwise order), from outline index `from` to `to` along both ways round.
void add_zigzag_cap(std::vector<Triangle>& triangles, const std::vector<Vec3>& positions, std::uint32_t first,
                    int count, int from, int to, bool up) {
  std::vector<std::uint32_t> left, right;  // both from `from` to `to`
  for (int k = from;; k = (k + 1) % count) {
    left.push_back(first + std::uint32_t(k));
    if (k == to) break;
  }
  for (int k = from;; k = (k + count - 1) % count) {
    right.push_back(first + std::uint32_t(k));
    if (k == to) break;
  }
  add_cap_triangle(triangles, positions, {left[0], left[1], right[1]}, up);
  std::size_t l = 1, r = 1;
  const std::size_t last_l = left.size() - 2, last_r = right.size() - 2;
  while (l < last_l || r < last_r) {
    // Advance the chain that is behind (relative progress), so the strip zig-zags across.
    const bool advance_left = r >= last_r || (l < last_l && double(l) * double(last_r) <= double(r) * double(last_l));
    if (advance_left) {
      add_cap_triangle(triangles, positions, {left[l], left[l + 1], right[r]}, up);
      ++l;
    } else {
      add_cap_triangle(triangles, positions, {right[r], right[r + 1], left[l]}, up);
      ++r;
    }
  }
  add_cap_triangle(triangles, positions, {left[l], left[l + 1], right[r]}, up);
}

// Fine cap: rings inside the outline (ids ring_ids[0] is the outline), then a grid over the
// inner rectangle. Adds the new vertices and the triangles.
void add_fine_cap(std::vector<Vec3>& positions, std::vector<Triangle>& triangles, const SlabLayout& l, double r,
                  int rings, std::uint32_t outline_first, double z, bool up) {
  const int n = l.count();
  std::vector<std::uint32_t> ring_first{outline_first};
  for (int k = 1; k < rings; ++k) {
    ring_first.push_back(std::uint32_t(positions.size()));
    add_ring(positions, l, r - r * k / rings, z);
  }
  // Inner rectangle grid: vertex (i, j) at x = -cx + 2 cx i / nx, y = -cy + 2 cy j / ny.
  const auto grid_first = std::uint32_t(positions.size());
  auto grid = [&](int i, int j) { return grid_first + std::uint32_t(j * (l.nx + 1) + i); };
  for (int j = 0; j <= l.ny; ++j)
    for (int i = 0; i <= l.nx; ++i)
      positions.push_back({i == l.nx ? l.cx : -l.cx + 2 * l.cx * i / l.nx, j == l.ny ? l.cy : -l.cy + 2 * l.cy * j / l.ny, z});

  // Bands between consecutive rings.
  for (int k = 0; k + 1 < rings; ++k) {
    for (int i = 0; i < n; ++i) {
      const int i1 = (i + 1) % n;
      const std::uint32_t a = ring_first[k] + i, b = ring_first[k] + i1, c = ring_first[k + 1] + i1,
                          d = ring_first[k + 1] + i;
      add_cap_triangle(triangles, positions, {a, b, c}, up);
      add_cap_triangle(triangles, positions, {a, c, d}, up);
    }
  }
  // The innermost ring to the grid's border: ring index -> grid vertex (arcs collapse into
  // the inner rectangle's corners).
  std::vector<std::uint32_t> inner(std::size_t(n), 0);
  for (int piece = 0; piece < 8; ++piece) {
    const int start = l.piece_start(piece), length = l.piece_start(piece + 1) - start;
    for (int k = 0; k < length; ++k) {
      std::uint32_t g = 0;
      switch (piece) {
        case 0: g = grid(l.nx, k); break;
        case 1: g = grid(l.nx, l.ny); break;
        case 2: g = grid(l.nx - k, l.ny); break;
        case 3: g = grid(0, l.ny); break;
        case 4: g = grid(0, l.ny - k); break;
        case 5: g = grid(0, 0); break;
        case 6: g = grid(k, 0); break;
        default: g = grid(l.nx, 0); break;
      }
      inner[std::size_t(start + k)] = g;
    }
  }
  const std::uint32_t last_ring = ring_first.back();
  for (int i = 0; i < n; ++i) {
    const int i1 = (i + 1) % n;
    const std::uint32_t a = last_ring + i, b = last_ring + i1, c = inner[std::size_t(i1)], d = inner[std::size_t(i)];
    if (c == d) {
      add_cap_triangle(triangles, positions, {a, b, c}, up);
    } else {
      add_cap_triangle(triangles, positions, {a, b, c}, up);
      add_cap_triangle(triangles, positions, {a, c, d}, up);
    }
  }
  for (int j = 0; j < l.ny; ++j) {
    for (int i = 0; i < l.nx; ++i) {
      const std::uint32_t a = grid(i, j), b = grid(i + 1, j), c = grid(i + 1, j + 1), d = grid(i, j + 1);
      add_cap_triangle(triangles, positions, {a, b, c}, up);
      add_cap_triangle(triangles, positions, {a, c, d}, up);
    }
  }
}

}  // namespace

double mean_edge_length(const RawMesh& mesh) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  edges.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[std::size_t(k)], b = t[std::size_t((k + 1) % 3)];
      if (a != b) edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  if (edges.empty()) return 0;
  double sum = 0;
  for (const auto& [a, b] : edges) sum += (vec(mesh.positions[a]) - vec(mesh.positions[b])).norm();
  return sum / double(edges.size());
}

RawMesh with_noise(RawMesh mesh, double fraction, std::uint64_t seed) {
  require(std::isfinite(fraction) && fraction >= 0, "with_noise", "fraction must be finite and >= 0");
  if (fraction == 0) return mesh;
  const double sigma = fraction * mean_edge_length(mesh) / std::sqrt(3.0);
  std::mt19937_64 rng(seed);
  for (Vec3& p : mesh.positions) {
    // Two pairs per vertex, always, so a vertex's displacement depends only on its index.
    const auto [g0, g1] = gaussian_pair(rng);
    const auto [g2, unused] = gaussian_pair(rng);
    (void)unused;
    p[0] += sigma * g0;
    p[1] += sigma * g1;
    p[2] += sigma * g2;
  }
  return mesh;
}

double rounded_rectangle_distance(double a, double b, double r, double x, double y) {
  const double qx = std::abs(x) - (a - r), qy = std::abs(y) - (b - r);
  const double outside = std::hypot(std::max(qx, 0.0), std::max(qy, 0.0));
  return outside + std::min(std::max(qx, qy), 0.0) - r;
}

CadPart make_rounded_slab(const RoundedSlabOptions& o) {
  const char* fn = "make_rounded_slab";
  require(positive_finite(o.corner_radius), fn, "corner_radius must be positive and finite");
  require(std::isfinite(o.half_x) && o.half_x > o.corner_radius, fn, "half_x must exceed corner_radius");
  require(std::isfinite(o.half_y) && o.half_y > o.corner_radius, fn, "half_y must exceed corner_radius");
  require(positive_finite(o.height), fn, "height must be positive and finite");
  require(o.corner_segments >= 1 && o.corner_segments <= 10000, fn, "corner_segments must be in 1..10000");
  require(o.side_segments >= 1 && o.side_segments <= 100000, fn, "side_segments must be in 1..100000");

  SlabLayout l;
  l.cx = o.half_x - o.corner_radius;
  l.cy = o.half_y - o.corner_radius;
  l.nx = o.side_segments;
  l.ny = std::max(1, int(std::lround(o.side_segments * l.cy / l.cx)));
  l.cs = o.corner_segments;
  const int n = l.count();
  const double side_edge = 2 * l.cx / l.nx;
  const bool fine = o.tessellation == SlabTessellation::fine;
  const int rows = fine ? std::max(1, int(std::lround(o.height / side_edge))) : 1;

  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  for (int s = 0; s <= rows; ++s) add_ring(positions, l, o.corner_radius, s == rows ? o.height : o.height * s / rows);
  for (int s = 0; s < rows; ++s) {
    for (int i = 0; i < n; ++i) {
      const std::uint32_t i1 = std::uint32_t((i + 1) % n);
      const std::uint32_t b0 = std::uint32_t(s * n + i), b1 = std::uint32_t(s * n) + i1;
      const std::uint32_t t0 = b0 + std::uint32_t(n), t1 = b1 + std::uint32_t(n);
      triangles.push_back({b0, b1, t1});  // counter-clockwise seen from outside
      triangles.push_back({b0, t1, t0});
    }
  }
  const auto bottom_first = 0u, top_first = std::uint32_t(rows * n);
  if (fine) {
    const int cap_rings = std::max(1, int(std::lround(o.corner_radius / side_edge)));
    add_fine_cap(positions, triangles, l, o.corner_radius, cap_rings, top_first, o.height, true);
    add_fine_cap(positions, triangles, l, o.corner_radius, cap_rings, bottom_first, 0.0, false);
  } else {
    // From the middle vertex of arc 1 (at (+a, +b)) to the middle vertex of arc 3.
    const int from = l.piece_start(1) + l.cs / 2, to = l.piece_start(5) + l.cs / 2;
    add_zigzag_cap(triangles, positions, top_first, n, from, to, true);
    add_zigzag_cap(triangles, positions, bottom_first, n, from, to, false);
  }

  CadPart part;
  for (int i = 0; i < n; ++i) {
    part.bottom_outline.push_back(bottom_first + std::uint32_t(i));
    part.top_outline.push_back(top_first + std::uint32_t(i));
  }
  part.mesh.positions = std::move(positions);
  part.mesh.triangles = std::move(triangles);
  part.mesh.source_faces = part.mesh.triangles.size();
  part.mean_edge_length = mean_edge_length(part.mesh);
  return part;
}

double distance_to_polyline(const std::vector<Eigen::Vector3d>& chain, bool closed, const Eigen::Vector3d& p) {
  require(!chain.empty(), "distance_to_polyline", "the chain has no points");
  double best = (p - chain.front()).squaredNorm();
  const std::size_t segments = chain.size() == 1 ? 0 : (closed ? chain.size() : chain.size() - 1);
  for (std::size_t s = 0; s < segments; ++s) {
    const Eigen::Vector3d& a = chain[s];
    const Eigen::Vector3d& b = chain[(s + 1) % chain.size()];
    const Eigen::Vector3d ab = b - a;
    const double length2 = ab.squaredNorm();
    double t = length2 > 0 ? (p - a).dot(ab) / length2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    best = std::min(best, (a + t * ab - p).squaredNorm());
  }
  return std::sqrt(best);
}

std::vector<Eigen::Vector3d> positions_of(const RawMesh& mesh, const std::vector<std::uint32_t>& ids) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(ids.size());
  for (auto v : ids) out.push_back(vec(mesh.positions.at(v)));
  return out;
}

std::vector<CreaseChain> find_crease_chains(const RawMesh& mesh, double min_dihedral_degrees, std::size_t min_edges) {
  require(std::isfinite(min_dihedral_degrees) && min_dihedral_degrees >= 0 && min_dihedral_degrees < 180,
          "find_crease_chains", "min_dihedral_degrees must be in [0, 180)");
  const std::size_t nv = mesh.positions.size();
  std::vector<Eigen::Vector3d> normals;
  normals.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = vec(mesh.positions[t[0]]);
    const Eigen::Vector3d n = (vec(mesh.positions[t[1]]) - a).cross(vec(mesh.positions[t[2]]) - a);
    const double length = n.norm();
    normals.push_back(length > 0 && t[0] != t[1] && t[1] != t[2] && t[0] != t[2] ? Eigen::Vector3d(n / length)
                                                                                    : Eigen::Vector3d::Zero());
  }
  // (low id, high id, face) for every triangle side, grouped by edge.
  std::vector<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> sides;
  sides.reserve(mesh.triangles.size() * 3);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = mesh.triangles[f][std::size_t(k)], b = mesh.triangles[f][std::size_t((k + 1) % 3)];
      if (a != b) sides.emplace_back(std::min(a, b), std::max(a, b), std::uint32_t(f));
    }
  std::sort(sides.begin(), sides.end());
  const double threshold = min_dihedral_degrees * kPi / 180;
  std::vector<std::vector<std::pair<std::uint32_t, std::size_t>>> sharp(nv);  // (neighbour, edge id)
  std::size_t edge_count = 0;
  for (std::size_t i = 0; i < sides.size();) {
    std::size_t j = i;
    while (j < sides.size() && std::get<0>(sides[j]) == std::get<0>(sides[i]) &&
           std::get<1>(sides[j]) == std::get<1>(sides[i]))
      ++j;
    if (j - i == 2) {
      const Eigen::Vector3d& n0 = normals[std::get<2>(sides[i])];
      const Eigen::Vector3d& n1 = normals[std::get<2>(sides[i + 1])];
      if (n0.squaredNorm() > 0 && n1.squaredNorm() > 0 && std::atan2(n0.cross(n1).norm(), n0.dot(n1)) > threshold) {
        const auto a = std::get<0>(sides[i]), b = std::get<1>(sides[i]);
        sharp[a].emplace_back(b, edge_count);
        sharp[b].emplace_back(a, edge_count);
        ++edge_count;
      }
    }
    i = j;
  }
  for (auto& list : sharp) std::sort(list.begin(), list.end());

  const double max_turn = kCreaseChainMaxTurnDegrees * kPi / 180;
  std::vector<char> split(nv, 0);
  for (std::size_t v = 0; v < nv; ++v) {
    if (sharp[v].empty()) continue;
    if (sharp[v].size() != 2) {
      split[v] = 1;
      continue;
    }
    const Eigen::Vector3d p = vec(mesh.positions[v]);
    const Eigen::Vector3d in = p - vec(mesh.positions[sharp[v][0].first]);
    const Eigen::Vector3d out = vec(mesh.positions[sharp[v][1].first]) - p;
    if (std::atan2(in.cross(out).norm(), in.dot(out)) > max_turn) split[v] = 1;
  }

  std::vector<char> visited(edge_count, 0);
  std::vector<CreaseChain> chains;
  auto walk = [&](std::uint32_t start, std::size_t first_slot) {
    CreaseChain chain;
    chain.vertices.push_back(start);
    std::uint32_t current = start;
    std::size_t slot = first_slot;
    for (;;) {
      const auto [next, edge] = sharp[current][slot];
      visited[edge] = 1;
      if (next == start) {
        chain.closed = true;
        break;
      }
      chain.vertices.push_back(next);
      if (split[next]) break;
      // A vertex of degree 2 that is not a split: leave by its other edge.
      const std::size_t other = sharp[next][0].second == edge ? 1 : 0;
      if (visited[sharp[next][other].second]) break;  // cannot happen on a simple chain
      current = next;
      slot = other;
    }
    if (chain.edges() >= min_edges) chains.push_back(std::move(chain));
  };
  for (std::uint32_t v = 0; v < nv; ++v)
    if (split[v])
      for (std::size_t s = 0; s < sharp[v].size(); ++s)
        if (!visited[sharp[v][s].second]) walk(v, s);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (sharp[v].size() == 2 && !split[v] && !visited[sharp[v][0].second]) walk(v, 0);
  return chains;
}

bool same_cycle(std::vector<std::uint32_t> a, const std::vector<std::uint32_t>& b) {
  if (a.size() != b.size()) return false;
  for (int direction = 0; direction < 2; ++direction) {
    for (std::size_t shift = 0; shift < a.size(); ++shift) {
      bool equal = true;
      for (std::size_t i = 0; i < a.size() && equal; ++i) equal = a[(i + shift) % a.size()] == b[i];
      if (equal) return true;
    }
    std::reverse(a.begin(), a.end());
  }
  return false;
}

}  // namespace featureline::testing
