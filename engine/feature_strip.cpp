#include "engine/feature_strip.h"

#include <algorithm>
#include <optional>
#include <cmath>
#include <complex>
#include <limits>

#include <Eigen/Sparse>

#include "engine/errors.h"
#include "engine/internal/geometry.h"
#include "engine/internal/vertex_map.h"

namespace featureline {
namespace {

double corner_angle(const Eigen::Vector3d& at, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return angle_between(a - at, b - at);
}

// The vertex after `next` counter-clockwise around `center`: the third corner of the face that
// runs from center to next, or kNoIndex where the edge center-next is on the boundary (seen
// from that side).
std::uint32_t next_around(const PreparedMesh& pm, std::uint32_t center, std::uint32_t next) {
  for (const std::uint32_t f : pm.faces_around(center)) {
    const auto& t = pm.triangles()[f];
    const int c = corner_of(t, center);
    if (t[(c + 1) % 3] == next) return t[(c + 2) % 3];
  }
  return kNoIndex;
}

// Sum of corner angles at `center` swept counter-clockwise from the edge to `from` until the
// edge to `until` (the faces on the left of a path arriving from `until`... see caller).
// Returns a negative value when a boundary interrupts the sweep.
double swept_angle(const PreparedMesh& pm, std::uint32_t center, std::uint32_t from, std::uint32_t until) {
  if (!pm.are_neighbors(center, from) || !pm.are_neighbors(center, until)) return -1;
  std::uint32_t spoke = from;
  double sum = 0;
  for (std::size_t guard = 0; guard < 1024; ++guard) {
    const std::uint32_t next = next_around(pm, center, spoke);
    if (next == kNoIndex) return -1;
    sum += corner_angle(pm.positions()[center], pm.positions()[spoke], pm.positions()[next]);
    spoke = next;
    if (spoke == until) return sum;
  }
  return -1;
}

}  // namespace

std::vector<Eigen::Vector2d> embed_line(const PreparedMesh& pm, const std::vector<std::uint32_t>& line) {
  const auto& P = pm.positions();
  std::vector<Eigen::Vector2d> p(line.size());
  if (line.empty()) return p;
  p[0] = Eigen::Vector2d::Zero();
  if (line.size() == 1) return p;
  p[1] = Eigen::Vector2d((P[line[1]] - P[line[0]]).norm(), 0);
  for (std::size_t i = 1; i + 1 < line.size(); ++i) {
    const auto prev = line[i - 1], cur = line[i], next = line[i + 1];
    // Angle on the left of the path at p_i: faces swept counter-clockwise from the outgoing
    // edge to the incoming one. Where the vertex is interior, the left and right sums are
    // scaled to 2 pi so the triangles on both sides fit around p_i (the paper's condition
    // "the angle of p1 p2 p3 equals the angle between e12 and e23" on a developed surface).
    const double left = swept_angle(pm, cur, next, prev);
    const double right = swept_angle(pm, cur, prev, next);
    double left_plane;
    if (left > 0 && right > 0) {
      left_plane = 2 * kPi * left / (left + right);
    } else if (left > 0) {
      left_plane = std::min(left, 2 * kPi - 1e-3);
    } else if (right > 0) {
      left_plane = std::max(2 * kPi - right, 1e-3);
    } else {
      left_plane = corner_angle(P[cur], P[prev], P[next]);  // no faces: keep the 3D angle
    }
    const Eigen::Vector2d incoming = (p[i] - p[i - 1]).normalized();
    const double back = std::atan2(-incoming.y(), -incoming.x());
    const double out = back - left_plane;
    p[i + 1] = p[i] + (P[next] - P[cur]).norm() * Eigen::Vector2d(std::cos(out), std::sin(out));
  }
  return p;
}

void check_strip_options(const StripOptions& options) {
  if (!StripOptions::rings_range.contains(options.rings))
    throw InvalidInputError("strip rings must be between 0 (automatic) and " + std::to_string(StripOptions::max_rings));
}

FeatureStrip extract_feature_strip(const PreparedMesh& pm, const std::vector<std::uint32_t>& line, const StripOptions& options) {
  if (line.size() < 2) throw InvalidInputError("a feature strip needs a line of at least two vertices");
  check_strip_options(options);
  FeatureStrip strip;
  strip.rings = options.rings;
  // Automatic: wider strips for longer lines. An edge path's distance from the true feature
  // grows with the line's length in edges (on a 245k-triangle ridge the initial line strays
  // 3-7 edges), and the snake can only reach what the strip covers (bench_accuracy: 6 rings
  // took that ridge's refined line from 0.95 to 0.10 edge lengths, 8 rings from 8 times the
  // dense length took its 140-edge pieces from 0.13 to 0.08).
  if (strip.rings == 0) {
    const int edges = int(line.size()) - 1, dense = options.dense_line_edges;
    strip.rings = edges >= 8 * dense ? 8 : edges >= 4 * dense ? 6 : edges >= 2 * dense ? 4 : edges >= dense ? 3 : 2;
  }

  StampedMap& local = stamped_map(0);  // mesh vertex -> local index
  local.begin(pm.n_vertices());
  auto add_vertex = [&](std::uint32_t v, int ring, std::uint32_t line_position) {
    if (local.contains(v)) return local.at(v);
    const auto index = std::uint32_t(strip.vertices.size());
    local.set(v, index);
    strip.vertices.push_back(v);
    strip.ring.push_back(ring);
    strip.line_position.push_back(line_position);
    return index;
  };
  for (std::size_t i = 0; i < line.size(); ++i) strip.line.push_back(add_vertex(line[i], 0, std::uint32_t(i)));
  // Breadth-first rings over the vertex adjacency.
  std::size_t ring_begin = 0;
  for (int ring = 1; ring <= strip.rings; ++ring) {
    const std::size_t ring_end = strip.vertices.size();
    for (std::size_t i = ring_begin; i < ring_end; ++i) {
      const auto v = strip.vertices[i];
      for (auto k = pm.neighbor_offsets()[v]; k < pm.neighbor_offsets()[v + 1]; ++k)
        add_vertex(pm.neighbors()[k], ring, strip.line_position[i]);
    }
    ring_begin = ring_end;
  }
  // Faces: every face of a vertex in rings < k whose three corners are in the strip.
  StampedMap& local_face = stamped_map(1);  // mesh face -> local triangle (here: seen)
  local_face.begin(pm.triangles().size());
  std::vector<std::uint32_t> faces;
  for (std::size_t i = 0; i < strip.vertices.size(); ++i) {
    if (strip.ring[i] >= strip.rings) continue;
    for (const std::uint32_t f : pm.faces_around(strip.vertices[i]))
      if (!local_face.contains(f)) local_face.set(f, 0), faces.push_back(f);
  }
  std::sort(faces.begin(), faces.end());  // the strip's triangles in mesh order, as always
  double edge_sum = 0, edge_sum2 = 0;
  for (auto f : faces) {
    const auto& t = pm.triangles()[f];
    std::array<std::uint32_t, 3> corners{};
    bool inside = true;
    for (int k = 0; k < 3 && inside; ++k) {
      inside = local.contains(t[k]);
      if (inside) corners[k] = local.at(t[k]);
    }
    if (!inside) continue;
    strip.triangles.push_back(corners);
    strip.faces.push_back(f);
    for (int k = 0; k < 3; ++k) {
      const double length2 = (pm.positions()[t[k]] - pm.positions()[t[(k + 1) % 3]]).squaredNorm();
      edge_sum += std::sqrt(length2), edge_sum2 += length2;
    }
  }
  strip.mean_edge_length = strip.triangles.empty() ? pm.statistics().mean_edge_length
                                                   : edge_sum / (3.0 * double(strip.triangles.size()));
  strip.mean_squared_edge_length = strip.triangles.empty() ? strip.mean_edge_length * strip.mean_edge_length
                                                           : edge_sum2 / (3.0 * double(strip.triangles.size()));

  // Triangle adjacency inside the strip, for walking point location: the mesh's face table
  // (built once in prepare_mesh) restricted to the strip.
  local_face.begin(pm.triangles().size());
  for (std::uint32_t t = 0; t < strip.faces.size(); ++t) local_face.set(strip.faces[t], t);
  strip.triangle_neighbors.assign(strip.triangles.size(), {-1, -1, -1});
  for (std::uint32_t t = 0; t < strip.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      // The edge opposite corner k is edge (k + 1) of the face in the mesh table's numbering.
      const auto across = pm.face_neighbors()[strip.faces[t]][(k + 1) % 3];
      if (across != kNoIndex && local_face.contains(across)) strip.triangle_neighbors[t][k] = std::int32_t(local_face.at(across));
    }
  return strip;
}

namespace {

// The paper's layout (Fig. 5): the line with its edge lengths and turning angles, then every
// unplaced vertex that closes a triangle over an already placed edge gets the apex of a
// triangle similar to the 3D one; several such triangles average. A wave places all its
// vertices at once, so the result does not depend on the order triangles are visited in.
void place_by_similar_triangles(const PreparedMesh& pm, const FeatureStrip& strip, FlatStrip& flat) {
  const std::size_t n = strip.vertices.size();
  std::vector<std::uint32_t> line_mesh(strip.line.size());
  for (std::size_t i = 0; i < strip.line.size(); ++i) line_mesh[i] = strip.vertices[strip.line[i]];
  const auto line_uv = embed_line(pm, line_mesh);
  for (std::size_t i = 0; i < strip.line.size(); ++i) {
    flat.uv[strip.line[i]] = line_uv[i];
    flat.placed[strip.line[i]] = 1;
  }
  std::vector<Eigen::Vector2d> sum(n, Eigen::Vector2d::Zero());
  std::vector<int> count(n, 0);
  std::vector<std::uint32_t> touched;
  while (true) {
    touched.clear();
    for (const auto& t : strip.triangles) {
      const int placed = flat.placed[t[0]] + flat.placed[t[1]] + flat.placed[t[2]];
      if (placed != 2) continue;
      int apex = 0;
      while (flat.placed[t[apex]]) ++apex;
      // Corners in the triangle's (counter-clockwise) order: a -> b is the placed edge and the
      // apex c lies on its left.
      const auto a = t[(apex + 1) % 3], b = t[(apex + 2) % 3], c = t[apex];
      const Eigen::Vector3d A = pm.positions()[strip.vertices[a]], B = pm.positions()[strip.vertices[b]],
                            C = pm.positions()[strip.vertices[c]];
      const Eigen::Vector3d ab = B - A;
      const double ab_len = ab.norm();
      const Eigen::Vector2d pab = flat.uv[b] - flat.uv[a];
      const double pab_len = pab.norm();
      if (!(ab_len > 0) || !(pab_len > 0)) continue;
      const double along = (C - A).dot(ab) / ab_len;
      const double across = (C - A).cross(ab).norm() / ab_len;
      const double scale = pab_len / ab_len;  // similar, not congruent: follow the placed edge
      const Eigen::Vector2d u = pab / pab_len;
      const Eigen::Vector2d left(-u.y(), u.x());
      if (count[c] == 0) touched.push_back(c);
      sum[c] += flat.uv[a] + scale * (along * u + across * left);
      ++count[c];
    }
    if (touched.empty()) break;
    for (auto v : touched) {
      flat.uv[v] = sum[v] / double(count[v]);
      flat.placed[v] = 1;
      sum[v].setZero();
      count[v] = 0;
    }
  }

}

// The strip's triangles reachable from the first line edge across shared edges (a strip can
// touch itself at a vertex, or hold a disconnected sliver, where a solve would be singular).
std::vector<std::uint32_t> triangles_connected_to_line(const FeatureStrip& strip) {
  const auto a = strip.line[0], b = strip.line[1];
  std::vector<std::uint32_t> component;
  std::vector<char> seen(strip.triangles.size(), 0);
  for (std::uint32_t t = 0; t < strip.triangles.size() && component.empty(); ++t) {
    const auto& tri = strip.triangles[t];
    const bool has_a = tri[0] == a || tri[1] == a || tri[2] == a, has_b = tri[0] == b || tri[1] == b || tri[2] == b;
    if (!has_a || !has_b) continue;
    seen[t] = 1;
    component.push_back(t);
    for (std::size_t i = 0; i < component.size(); ++i)
      for (auto next : strip.triangle_neighbors[component[i]])
        if (next >= 0 && !seen[std::size_t(next)]) {
          seen[std::size_t(next)] = 1;
          component.push_back(std::uint32_t(next));
        }
  }
  return component;
}

// The strip's vertices in the order that keeps the conformal map's normal matrix banded: up
// the line's left side, then back down its right side (by FeatureStrip::line_position), so
// each unknown's neighbours lie within a few rings' count of it and the two sides, which only
// meet around the line's ends, are not interleaved. A side is found by flooding the strip's
// triangles from the line's edges without crossing them.
std::vector<std::uint32_t> vertices_around_line(const FeatureStrip& strip) {
  const std::size_t edges = strip.line.size() - 1, n = strip.vertices.size();
  std::vector<std::int64_t> line_index(n, -1);
  for (std::size_t i = 0; i < strip.line.size(); ++i) line_index[strip.line[i]] = std::int64_t(i);
  // Corner k's opposite edge, as 0 (not a line edge), 1 (the line runs along it with the
  // triangle on its left) or 2 (on its right).
  const auto line_edge_side = [&](const std::array<std::uint32_t, 3>& t, int k) {
    const auto a = line_index[t[std::size_t(k + 1) % 3]], b = line_index[t[std::size_t(k + 2) % 3]];
    if (a < 0 || b < 0) return 0;
    return b == a + 1 ? 1 : a == b + 1 ? 2 : 0;
  };
  std::vector<std::uint8_t> triangle_side(strip.triangles.size(), 0), vertex_side(n, 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t t = 0; t < strip.triangles.size(); ++t)
    for (int k = 0; k < 3 && !triangle_side[t]; ++k)
      if (const int side = line_edge_side(strip.triangles[t], k)) triangle_side[t] = std::uint8_t(side), queue.push_back(t);
  for (std::size_t i = 0; i < queue.size(); ++i) {
    const auto t = queue[i];
    for (auto v : strip.triangles[t])
      if (!vertex_side[v]) vertex_side[v] = triangle_side[t];
    for (int k = 0; k < 3; ++k) {
      const auto next = strip.triangle_neighbors[t][std::size_t(k)];
      if (next < 0 || triangle_side[std::size_t(next)] || line_edge_side(strip.triangles[t], k)) continue;
      triangle_side[std::size_t(next)] = triangle_side[t];
      queue.push_back(std::uint32_t(next));
    }
  }
  // Counting sort by the position around the line: 0..edges up the left, then back down.
  const auto key = [&](std::uint32_t v) {
    return vertex_side[v] == 2 ? 2 * edges + 1 - strip.line_position[v] : strip.line_position[v];
  };
  std::vector<std::uint32_t> start(2 * edges + 3, 0);
  for (std::uint32_t v = 0; v < n; ++v) ++start[key(v) + 1];
  for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  std::vector<std::uint32_t> order(n);
  for (std::uint32_t v = 0; v < n; ++v) order[start[key(v)]++] = v;
  return order;
}

// Entries of a symmetric matrix's lower envelope (row i from its first non-zero to the diagonal),
// which bounds an LDLT factor's fill in the matrix's own order.
template <typename Matrix>
std::size_t envelope_size(const Matrix& matrix) {
  std::vector<Eigen::Index> first(std::size_t(matrix.rows()));
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) first[std::size_t(i)] = i;
  for (Eigen::Index col = 0; col < matrix.outerSize(); ++col)
    for (typename Matrix::InnerIterator it(matrix, col); it; ++it)
      first[std::size_t(it.row())] = std::min(first[std::size_t(it.row())], col);
  std::size_t size = 0;
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) size += std::size_t(i - first[std::size_t(i)]) + 1;
  return size;
}

// Below this many envelope entries per unknown the strip's own order is factored as it is (a
// strip 8 rings wide on each side has about 20 per row); beyond it (a strip that touches itself
// far along the line) a fill-reducing ordering costs less than the fill.
constexpr std::size_t kNaturalOrderEnvelope = 48;

template <typename Ordering, typename Matrix>
std::optional<Eigen::VectorXcd> solve_normal_equations(const Matrix& normal, const Eigen::VectorXcd& rhs) {
  Eigen::SimplicialLDLT<Matrix, Eigen::Lower, Ordering> solver(normal);
  if (solver.info() != Eigen::Success) return std::nullopt;
  Eigen::VectorXcd x = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !x.allFinite()) return std::nullopt;
  return x;
}

// Least-squares conformal map (Levy et al. 2002) of the strip around the line: in complex
// coordinates a triangle with 3D corners z_k (in its own plane) maps to w_k by a similarity
// exactly when sum_k W_k w_k = 0 with W_0 = z_1 - z_2, W_1 = z_2 - z_0, W_2 = z_0 - z_1; the
// squared residuals over the triangles' areas are minimised with the line's vertices held
// where embed_line puts them. (Pinning only two vertices lets the map's scale drift along a
// long noisy strip: on a 20%-noisy 140-edge strip two thirds of the triangles came out more
// than 35% stretched.) Returns false when the line is not inside one connected piece of the
// strip or the solve fails; the caller then falls back on the paper's layout.
bool place_conformally(const PreparedMesh& pm, const FeatureStrip& strip, FlatStrip& flat) {
  if (strip.line.size() < 2) return false;
  const std::vector<std::uint32_t> component = triangles_connected_to_line(strip);
  const std::size_t n = strip.vertices.size();
  constexpr std::int64_t kPinned = -1, kOutside = -2, kUnnumbered = -3;
  std::vector<std::int64_t> unknown(n, kOutside);
  for (auto v : strip.line) unknown[v] = kPinned;
  for (auto t : component)
    for (auto v : strip.triangles[t])
      if (unknown[v] == kOutside) unknown[v] = kUnnumbered;
  // Unknowns numbered along the line (by the line vertex each was reached from): a strip is a
  // band along its line, so in this order the normal matrix is banded and needs no fill-reducing
  // ordering (solve_normal_equations).
  std::int64_t count = 0;
  for (auto v : vertices_around_line(strip))
    if (unknown[v] == kUnnumbered) unknown[v] = count++;
  std::vector<char> line_in_component(n, 0);
  for (auto t : component)
    for (auto v : strip.triangles[t]) line_in_component[v] = 1;
  for (auto v : strip.line)
    if (!line_in_component[v]) return false;
  std::vector<std::uint32_t> line_mesh(strip.line.size());
  for (std::size_t i = 0; i < strip.line.size(); ++i) line_mesh[i] = strip.vertices[strip.line[i]];
  const auto line_uv = embed_line(pm, line_mesh);
  for (std::size_t i = 0; i < strip.line.size(); ++i) flat.uv[strip.line[i]] = line_uv[i];
  const auto position = [&](std::uint32_t v) { return pm.positions()[strip.vertices[v]]; };

  // Unknowns: w = u + iv of each free vertex, one complex number. A triangle's residual is
  // sum_k c_k w_k with c_k = W_k / sqrt(area); its pinned corners go to the right-hand side b.
  // The normal equations C^H C w = C^H b are Hermitian: summed straight away, entry by entry (no
  // rectangular matrix to multiply), and half the size of the real system of u and v, whose
  // ordering and factorisation cost most of the flattening of large strips.
  using Complex = std::complex<double>;
  std::vector<Eigen::Triplet<Complex>> entries;
  entries.reserve(component.size() * 9);
  Eigen::VectorXcd rhs = Eigen::VectorXcd::Zero(Eigen::Index(count));
  bool any_row = false;
  for (auto t : component) {
    const auto& tri = strip.triangles[t];
    const Eigen::Vector3d e1 = position(tri[1]) - position(tri[0]), e2 = position(tri[2]) - position(tri[0]);
    const double len1 = e1.norm(), twice_area = e1.cross(e2).norm();
    if (!(len1 > 0) || !(twice_area > 1e-12 * len1 * len1)) continue;
    const Complex z[3] = {{0, 0}, {len1, 0}, {e2.dot(e1) / len1, twice_area / len1}};
    const double weight = 1 / std::sqrt(0.5 * twice_area);
    const Complex W[3] = {z[1] - z[2], z[2] - z[0], z[0] - z[1]};
    // The row over this triangle's free unknowns, and its right-hand side.
    std::array<std::int64_t, 3> col{};
    std::array<Complex, 3> row{};
    int free = 0;
    Complex b = 0;
    for (int k = 0; k < 3; ++k) {
      const Complex c = weight * W[k];
      const auto v = tri[std::size_t(k)];
      if (unknown[v] == kPinned) {
        b -= c * Complex(flat.uv[v].x(), flat.uv[v].y());
        continue;
      }
      col[std::size_t(free)] = unknown[v], row[std::size_t(free)] = c;
      ++free;
    }
    any_row = true;
    for (std::size_t i = 0; i < std::size_t(free); ++i) {
      rhs[col[i]] += std::conj(row[i]) * b;
      for (std::size_t j = 0; j < std::size_t(free); ++j) entries.emplace_back(col[i], col[j], std::conj(row[i]) * row[j]);
    }
  }
  if (!any_row) return false;
  for (auto v : strip.line) flat.placed[v] = 1;
  if (count == 0) return true;
  Eigen::SparseMatrix<Complex> normal{Eigen::Index(count), Eigen::Index(count)};
  normal.setFromTriplets(entries.begin(), entries.end());
  const auto x = envelope_size(normal) <= kNaturalOrderEnvelope * std::size_t(count)
                     ? solve_normal_equations<Eigen::NaturalOrdering<int>>(normal, rhs)
                     : solve_normal_equations<Eigen::AMDOrdering<int>>(normal, rhs);
  if (!x) return false;
  for (std::size_t v = 0; v < n; ++v) {
    if (unknown[v] < 0) continue;
    flat.uv[v] = Eigen::Vector2d((*x)[unknown[v]].real(), (*x)[unknown[v]].imag());
    flat.placed[v] = 1;
  }
  return true;
}

// The snake's domain: placed triangles that keep their orientation and whose edges are within
// max_edge_distortion of their 3D lengths. Counts the fold-overs, and where one touches the
// line first.
void mark_valid_triangles(const PreparedMesh& pm, const FeatureStrip& strip, const StripOptions& options, FlatStrip& flat) {
  const std::size_t n = strip.vertices.size();
  std::vector<std::int64_t> line_index(n, -1);
  for (std::size_t i = 0; i < strip.line.size(); ++i) line_index[strip.line[i]] = std::int64_t(i);
  flat.triangle_valid.assign(strip.triangles.size(), 0);
  bool first_near = true;
  for (std::size_t ti = 0; ti < strip.triangles.size(); ++ti) {
    const auto& t = strip.triangles[ti];
    if (!flat.placed[t[0]] || !flat.placed[t[1]] || !flat.placed[t[2]]) continue;
    const Eigen::Vector2d e1 = flat.uv[t[1]] - flat.uv[t[0]], e2 = flat.uv[t[2]] - flat.uv[t[0]];
    const double signed_area = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
    if (signed_area > 0) {
      // |length2 / length3 - 1| <= max_edge_distortion for every edge, compared as squares:
      // length2^2 within [(1 - d)^2, (1 + d)^2] length3^2 (no square roots).
      const double low = std::max(0.0, 1 - options.max_edge_distortion), high = 1 + options.max_edge_distortion;
      bool within = true;
      for (int k = 0; k < 3 && within; ++k) {
        const double length3 = (pm.positions()[strip.vertices[t[k]]] - pm.positions()[strip.vertices[t[(k + 1) % 3]]]).squaredNorm();
        const double length2 = (flat.uv[t[k]] - flat.uv[t[(k + 1) % 3]]).squaredNorm();
        if (length3 > 0) within = length2 >= low * low * length3 && length2 <= high * high * length3;
      }
      if (within) flat.triangle_valid[ti] = 1;
      else ++flat.distorted_triangles;
      continue;
    }
    ++flat.flipped_triangles;
    for (auto v : t)
      if (line_index[v] >= 0) {
        ++flat.flipped_near_line;
        if (first_near) flat.first_flip_line_index = std::size_t(line_index[v]);
        first_near = false;
        break;
      }
  }
}

}  // namespace

FlatStrip flatten_strip(const PreparedMesh& pm, const FeatureStrip& strip, const StripOptions& options, const LineContext& line) {
  const std::size_t n = strip.vertices.size();
  const auto unplaced = [n] {
    FlatStrip flat;
    flat.uv.assign(n, Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
    flat.placed.assign(n, 0);
    return flat;
  };
  const auto paper_layout = [&] {
    FlatStrip paper = unplaced();
    place_by_similar_triangles(pm, strip, paper);
    mark_valid_triangles(pm, strip, options, paper);
    return paper;
  };
  std::optional<FlatStrip> paper;
  if (options.flattening != StripFlattening::conformal) {
    paper = paper_layout();
    // Automatic: the paper's layout is exact on developable strips and costs a fraction of a
    // sparse solve; only where it drops triangles from the snake's domain is the solve worth it.
    // On noisy meshes the holes it leaves cost accuracy early: bench_accuracy's 24k-triangle
    // valley at 20% noise (estimated noise 0.072) refines to 0.154 grid spacings when strips
    // losing 3-5% keep the paper's layout, 0.133 when they are solved (the same as solving
    // every strip); no other figure moves between 1%, 3% and 5%. On a scan as clean as the
    // bunny (0.021) a 3% threshold solved more lines for nothing: its median 3-key line went
    // from 1.8 to 2.2 ms (bench_pipeline, quiet machine).
    const double max_dropped_share = line.noisy_mesh ? StripOptions::max_dropped_share_noisy : StripOptions::max_dropped_share;
    const double dropped = double(paper->distorted_triangles + paper->flipped_triangles);
    if (options.flattening == StripFlattening::similar_triangles ||
        dropped <= max_dropped_share * double(strip.triangles.size()))
      return std::move(*paper);
  }
  FlatStrip conformal = unplaced();
  if (place_conformally(pm, strip, conformal)) {
    mark_valid_triangles(pm, strip, options, conformal);
    return conformal;
  }
  // The solve failed: the paper's layout is still an answer (laid out once).
  return paper ? std::move(*paper) : paper_layout();
}

}  // namespace featureline
