#include "engine/prepared_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include <OpenMesh/Core/System/omstream.hh>

#include <mutex>

#include "engine/errors.h"

namespace featureline {
namespace {

using Clock = std::chrono::steady_clock;

Eigen::Vector3d to_eigen(const TriMesh::Point& p) { return {p[0], p[1], p[2]}; }

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (std::uint64_t(a) << 32) | b;
}

// Counts edges with more than two triangles and vertices whose triangles form more than
// one edge-connected fan, on the input soup (before OpenMesh had to split anything).
void count_non_manifold(const RawMesh& raw, MeshStatistics& stats) {
  std::vector<std::uint64_t> keys;
  keys.reserve(raw.triangles.size() * 3);
  for (const auto& t : raw.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    for (int k = 0; k < 3; ++k) keys.push_back(edge_key(t[k], t[(k + 1) % 3]));
  }
  std::sort(keys.begin(), keys.end());
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i;
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    if (j - i > 2) ++stats.non_manifold_edges;
    i = j;
  }

  // Fans: per vertex, union the incident triangles that share an edge through the vertex.
  const std::size_t n = raw.positions.size();
  std::vector<std::uint32_t> offsets(n + 1, 0);
  for (const auto& t : raw.triangles)
    if (!(t[0] == t[1] || t[1] == t[2] || t[0] == t[2]))
      for (auto v : t) ++offsets[v + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<std::uint32_t> incident(offsets[n]);
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::uint32_t f = 0; f < raw.triangles.size(); ++f) {
    const auto& t = raw.triangles[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    for (auto v : t) incident[fill[v]++] = f;
  }
  std::vector<int> parent;
  std::vector<std::pair<std::uint32_t, int>> spoke;  // (other vertex, local triangle)
  for (std::size_t v = 0; v < n; ++v) {
    const std::uint32_t begin = offsets[v], end = offsets[v + 1];
    if (end - begin < 2) continue;
    parent.resize(end - begin);
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    spoke.clear();
    for (std::uint32_t i = begin; i < end; ++i) {
      const auto& t = raw.triangles[incident[i]];
      for (auto w : t)
        if (w != v) spoke.emplace_back(w, int(i - begin));
    }
    std::sort(spoke.begin(), spoke.end());
    for (std::size_t i = 1; i < spoke.size(); ++i)
      if (spoke[i].first == spoke[i - 1].first) parent[find(spoke[i].second)] = find(spoke[i - 1].second);
    int fans = 0;
    for (int i = 0; i < int(parent.size()); ++i) fans += find(i) == i;
    if (fans > 1) ++stats.non_manifold_vertices;
  }
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const std::size_t k = std::min(values.size() - 1, std::size_t(q * double(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

}  // namespace

std::vector<Eigen::Vector3d> compute_vertex_normals(const TriMesh& mesh) {
  std::vector<Eigen::Vector3d> normals(mesh.n_vertices(), Eigen::Vector3d::Zero());
  for (auto f : mesh.faces()) {
    Eigen::Vector3d p[3];
    int idx[3];
    int k = 0;
    for (auto v : mesh.fv_range(f)) {
      idx[k] = v.idx();
      p[k++] = to_eigen(mesh.point(v));
    }
    Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double len = n.norm();
    if (!(len > 0)) continue;
    n /= len;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
      const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
      normals[idx[i]] += angle * n;
    }
  }
  for (auto& n : normals) {
    const double len = n.norm();
    if (len > 0) n /= len;
  }
  return normals;
}

std::vector<double> compute_mean_curvature(const TriMesh& mesh, const std::vector<Eigen::Vector3d>& normals) {
  const std::size_t n = mesh.n_vertices();
  std::vector<Eigen::Vector3d> laplace(n, Eigen::Vector3d::Zero());
  std::vector<double> area(n, 0.0);
  // Meyer, Desbrun, Schroeder, Barr 2003: K(x_i) = 1/(2 A_mixed) sum_j (cot a_ij + cot b_ij)(x_i - x_j),
  // and K = 2 H n. The mixed area uses Voronoi areas on non-obtuse triangles and the
  // area/2, area/4 split on obtuse ones, so the areas tile the surface.
  for (auto f : mesh.faces()) {
    int idx[3];
    Eigen::Vector3d p[3];
    int k = 0;
    for (auto v : mesh.fv_range(f)) {
      idx[k] = v.idx();
      p[k++] = to_eigen(mesh.point(v));
    }
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
  std::vector<double> curvature(n, 0.0);
  std::vector<char> on_boundary(n, 0);
  for (auto v : mesh.vertices()) {
    on_boundary[v.idx()] = mesh.is_boundary(v) || !mesh.is_manifold(v);
    if (area[v.idx()] > 0) curvature[v.idx()] = 0.25 * laplace[v.idx()].dot(normals[v.idx()]) / area[v.idx()];
  }
  // The cotangent Laplacian is incomplete at the boundary; borrow from interior neighbours.
  std::vector<double> boundary_value(n, 0.0);
  for (auto v : mesh.vertices()) {
    if (!on_boundary[v.idx()]) continue;
    double sum = 0;
    int count = 0;
    for (auto w : mesh.vv_range(v))
      if (!on_boundary[w.idx()]) sum += curvature[w.idx()], ++count;
    boundary_value[v.idx()] = count > 0 ? sum / count : 0.0;
  }
  for (std::size_t v = 0; v < n; ++v)
    if (on_boundary[v]) curvature[v] = boundary_value[v];
  return curvature;
}

std::size_t PreparedMesh::memory_bytes() const {
  // OpenMesh's array kernel: points, normals-free vertices (halfedge handle), halfedges, edges, faces.
  std::size_t bytes = sizeof(PreparedMesh);
  bytes += mesh.n_vertices() * (sizeof(TriMesh::Point) + sizeof(int) + 4);
  bytes += mesh.n_halfedges() * (3 * sizeof(int) + 4);
  bytes += mesh.n_edges() * 4 + mesh.n_faces() * (sizeof(int) + 4);
  bytes += source_triangle.capacity() * sizeof(std::uint32_t) + triangles.capacity() * 3 * sizeof(std::uint32_t);
  bytes += positions.capacity() * sizeof(Eigen::Vector3d) + vertex_normals.capacity() * sizeof(Eigen::Vector3d);
  bytes += mean_curvature.capacity() * sizeof(double);
  bytes += neighbor_offsets.capacity() * sizeof(std::uint32_t) + neighbors.capacity() * sizeof(std::uint32_t);
  bytes += neighbor_edge_lengths.capacity() * sizeof(double) + component.capacity() * sizeof(std::int32_t);
  for (const auto& w : warnings) bytes += w.capacity();
  return bytes;
}

std::shared_ptr<const PreparedMesh> prepare_mesh(RawMesh raw, const PrepareOptions& options) {
  const auto start = Clock::now();
  // OpenMesh prints add_face failures ("patch re-linking failed") to std::cerr; we handle and
  // report every such face ourselves, so its stream is switched off once for the process.
  static std::once_flag quiet;
  std::call_once(quiet, [] { omerr().disable(); });
  if (options.curvature_smoothing_passes < 0 || options.curvature_smoothing_passes > 100)
    throw InvalidInputError("curvature_smoothing_passes must be between 0 and 100");
  auto prepared = std::make_shared<PreparedMesh>();
  PreparedMesh& pm = *prepared;
  MeshStatistics& stats = pm.statistics;
  pm.warnings = std::move(raw.warnings);
  stats.file_vertices = raw.positions.size();
  stats.file_faces = raw.source_faces;
  count_non_manifold(raw, stats);

  TriMesh& mesh = pm.mesh;
  mesh.reserve(raw.positions.size(), raw.triangles.size() * 3 / 2, raw.triangles.size());
  for (const auto& p : raw.positions) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw MeshFormatError("a vertex has a non-finite coordinate");
    mesh.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
  }
  std::vector<TriMesh::VertexHandle> corners(3);
  std::size_t first_dropped = SIZE_MAX;
  std::size_t split_faces = 0;
  pm.source_triangle.reserve(raw.triangles.size());
  pm.triangles.reserve(raw.triangles.size());
  for (std::uint32_t t = 0; t < raw.triangles.size(); ++t) {
    const auto& tri = raw.triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      if (stats.dropped_faces++ == 0) first_dropped = t;
      continue;
    }
    for (int k = 0; k < 3; ++k) corners[k] = TriMesh::VertexHandle(int(tri[k]));
    // OpenMesh refuses faces that would make an edge or vertex non-manifold (it prints to
    // std::cerr when it does); we check first and, like OpenMesh's own reader, give such a
    // face its own copies of the vertices so it is kept and every id stays valid.
    bool fits = true;
    for (int k = 0; k < 3 && fits; ++k) {
      if (!mesh.is_boundary(corners[k])) fits = false;  // a closed fan takes no more faces
      const auto he = mesh.find_halfedge(corners[k], corners[(k + 1) % 3]);
      if (he.is_valid() && !mesh.is_boundary(he)) fits = false;  // that side of the edge is taken
    }
    TriMesh::FaceHandle face;
    if (fits) face = mesh.add_face(corners);
    if (!face.is_valid()) {
      for (int k = 0; k < 3; ++k) {
        const TriMesh::Point copy = mesh.point(corners[k]);  // add_vertex may reallocate the points
        corners[k] = mesh.add_vertex(copy);
      }
      stats.duplicated_vertices += 3;
      ++split_faces;
      face = mesh.add_face(corners);
    }
    pm.source_triangle.push_back(t);
    pm.triangles.push_back({std::uint32_t(corners[0].idx()), std::uint32_t(corners[1].idx()), std::uint32_t(corners[2].idx())});
  }
  if (stats.dropped_faces > 0) {
    std::ostringstream msg;
    msg << stats.dropped_faces << " degenerate triangle(s) with a repeated vertex index were dropped (first: input triangle "
        << first_dropped << "); face ids after it are shifted down";
    pm.warnings.push_back(msg.str());
  }
  if (split_faces > 0) {
    std::ostringstream msg;
    msg << split_faces << " triangle(s) would have made an edge or vertex non-manifold (or duplicate another) and were "
        << "given their own copies of their vertices (" << stats.duplicated_vertices
        << " vertices appended after the input's " << stats.file_vertices << ")";
    pm.warnings.push_back(msg.str());
  }
  if (mesh.n_faces() == 0) throw GeometryError("the mesh has no usable triangle");

  const std::size_t n = mesh.n_vertices();
  stats.vertices = n;
  stats.faces = mesh.n_faces();
  pm.positions.resize(n);
  for (auto v : mesh.vertices()) pm.positions[v.idx()] = to_eigen(mesh.point(v));

  // Adjacency in compressed rows, edge lengths beside it.
  pm.neighbor_offsets.assign(n + 1, 0);
  for (auto v : mesh.vertices()) pm.neighbor_offsets[v.idx() + 1] = pm.neighbor_offsets[v.idx()] + mesh.valence(v);
  pm.neighbors.resize(pm.neighbor_offsets[n]);
  pm.neighbor_edge_lengths.resize(pm.neighbor_offsets[n]);
  for (auto v : mesh.vertices()) {
    std::uint32_t k = pm.neighbor_offsets[v.idx()];
    for (auto w : mesh.vv_range(v)) {
      pm.neighbors[k] = std::uint32_t(w.idx());
      pm.neighbor_edge_lengths[k] = (pm.positions[w.idx()] - pm.positions[v.idx()]).norm();
      ++k;
    }
  }
  double edge_sum = 0;
  for (auto e : mesh.edges()) {
    edge_sum += mesh.calc_edge_length(e);
    if (mesh.is_boundary(e)) ++stats.boundary_edges;
  }
  stats.mean_edge_length = mesh.n_edges() > 0 ? edge_sum / double(mesh.n_edges()) : 0;
  if (!(stats.mean_edge_length > 0)) throw GeometryError("every edge of the mesh has zero length");

  // Components by breadth-first search over the adjacency.
  pm.component.assign(n, -1);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t s = 0; s < n; ++s) {
    if (pm.component[s] >= 0 || pm.neighbor_offsets[s + 1] == pm.neighbor_offsets[s]) continue;
    const auto id = std::int32_t(stats.components++);
    queue.assign(1, s);
    pm.component[s] = id;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const auto v = queue[head];
      for (auto k = pm.neighbor_offsets[v]; k < pm.neighbor_offsets[v + 1]; ++k)
        if (pm.component[pm.neighbors[k]] < 0) {
          pm.component[pm.neighbors[k]] = id;
          queue.push_back(pm.neighbors[k]);
        }
    }
  }
  for (std::uint32_t v = 0; v < n; ++v) stats.unreferenced_vertices += pm.component[v] < 0;

  // Boundary loops: follow next_halfedge around each unvisited boundary halfedge.
  std::vector<char> seen(mesh.n_halfedges(), 0);
  for (auto h : mesh.halfedges()) {
    if (!mesh.is_boundary(h) || seen[h.idx()]) continue;
    ++stats.boundary_loops;
    auto c = h;
    std::size_t guard = 0;
    do {
      seen[c.idx()] = 1;
      c = mesh.next_halfedge_handle(c);
    } while (c != h && !seen[c.idx()] && ++guard < mesh.n_halfedges());
  }

  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = Eigen::Vector3d::Constant(-HUGE_VAL);
  for (std::uint32_t v = 0; v < n; ++v)
    if (pm.component[v] >= 0) lo = lo.cwiseMin(pm.positions[v]), hi = hi.cwiseMax(pm.positions[v]);
  stats.bbox_min = {lo.x(), lo.y(), lo.z()};
  stats.bbox_max = {hi.x(), hi.y(), hi.z()};

  pm.vertex_normals = compute_vertex_normals(mesh);
  pm.mean_curvature = compute_mean_curvature(mesh, pm.vertex_normals);
  for (int pass = 0; pass < options.curvature_smoothing_passes; ++pass) {
    std::vector<double> smoothed(pm.mean_curvature);
    for (std::uint32_t v = 0; v < n; ++v) {
      const auto begin = pm.neighbor_offsets[v], end = pm.neighbor_offsets[v + 1];
      if (begin == end) continue;
      double sum = 0;
      for (auto k = begin; k < end; ++k) sum += pm.mean_curvature[pm.neighbors[k]];
      smoothed[v] = 0.5 * (pm.mean_curvature[v] + sum / double(end - begin));
    }
    pm.mean_curvature.swap(smoothed);
  }

  std::vector<double> magnitudes;
  magnitudes.reserve(n);
  stats.curvature_min = HUGE_VAL;
  stats.curvature_max = -HUGE_VAL;
  for (std::uint32_t v = 0; v < n; ++v) {
    if (pm.component[v] < 0) continue;
    magnitudes.push_back(std::abs(pm.mean_curvature[v]));
    stats.curvature_min = std::min(stats.curvature_min, pm.mean_curvature[v]);
    stats.curvature_max = std::max(stats.curvature_max, pm.mean_curvature[v]);
  }
  stats.abs_curvature_p50 = percentile(magnitudes, 0.5);
  stats.abs_curvature_p90 = percentile(magnitudes, 0.9);
  stats.abs_curvature_p99 = percentile(magnitudes, 0.99);
  // A flat mesh has no curvature at all; any positive scale then works.
  pm.curvature_scale = stats.abs_curvature_p90 > 0 ? stats.abs_curvature_p90 : 1.0 / stats.mean_edge_length;

  pm.prepare_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  return prepared;
}

}  // namespace featureline
