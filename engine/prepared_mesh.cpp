#include "engine/prepared_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include <OpenMesh/Core/System/omstream.hh>

#include "engine/errors.h"
#include "engine/executor.h"
#include "engine/internal/geometry.h"
#include "engine/internal/order_statistics.h"
#include "engine/internal/stopwatch.h"
#include "engine/tri_mesh.h"

namespace featureline {
namespace {

using Clock = std::chrono::steady_clock;

Eigen::Vector3d to_eigen(const TriMesh::Point& p) { return {p[0], p[1], p[2]}; }

// Counts edges with more than two triangles and vertices whose triangles form more than
// one edge-connected fan, on the input soup (before OpenMesh had to split anything).
void count_non_manifold(const RawMesh& raw, MeshStatistics& stats) {
  // Edges bucketed by their lower end (a counting sort, as in build_face_neighbors), then
  // counted by their upper end inside each bucket: a handful of entries each.
  const std::size_t n = raw.positions.size();
  auto degenerate_triangle = [](const std::array<std::uint32_t, 3>& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; };
  std::vector<std::uint32_t> offsets(n + 1, 0);
  for (const auto& t : raw.triangles)
    if (!degenerate_triangle(t))
      for (int k = 0; k < 3; ++k) ++offsets[std::min(t[k], t[(k + 1) % 3]) + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<std::uint32_t> upper(offsets.back());
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (const auto& t : raw.triangles)
    if (!degenerate_triangle(t))
      for (int k = 0; k < 3; ++k) upper[fill[std::min(t[k], t[(k + 1) % 3])]++] = std::max(t[k], t[(k + 1) % 3]);
  for (std::size_t v = 0; v < n; ++v) {
    const auto first = upper.begin() + offsets[v], last = upper.begin() + offsets[v + 1];
    std::sort(first, last);
    for (auto i = first; i != last;) {
      auto j = i;
      while (j != last && *j == *i) ++j;
      if (j - i > 2) ++stats.non_manifold_edges;
      i = j;
    }
  }

  // Fans: per vertex, union the incident triangles that share an edge through the vertex.
  const VertexFaces incident = build_vertex_faces(raw.triangles, n);
  auto degenerate = [&](std::uint32_t f) {
    const auto& t = raw.triangles[f];
    return t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
  };
  UnionFind fans;
  std::vector<std::uint32_t> faces;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> spoke;  // (other vertex, local triangle)
  for (std::uint32_t v = 0; v < n; ++v) {
    faces.clear();
    for (auto it = incident.begin(v); it != incident.end(v); ++it)
      if (!degenerate(*it)) faces.push_back(*it);
    if (faces.size() < 2) continue;
    fans.reset(faces.size());
    spoke.clear();
    for (std::uint32_t i = 0; i < faces.size(); ++i)
      for (auto w : raw.triangles[faces[i]])
        if (w != v) spoke.emplace_back(w, i);
    std::sort(spoke.begin(), spoke.end());
    for (std::size_t i = 1; i < spoke.size(); ++i)
      if (spoke[i].first == spoke[i - 1].first) fans.unite(spoke[i].second, spoke[i - 1].second);
    std::size_t roots = 0;
    for (std::uint32_t i = 0; i < faces.size(); ++i) roots += fans.is_root(i);
    if (roots > 1) ++stats.non_manifold_vertices;
  }
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  return value_of_rank(values, std::min(values.size() - 1, std::size_t(q * double(values.size() - 1) + 0.5)));
}

// True when a triangle over the same three vertices as `corners` (in either orientation) is
// already in the mesh. Only asked for faces OpenMesh refused, so it costs nothing on clean meshes.
bool repeats_a_face(const TriMesh& mesh, const std::vector<TriMesh::VertexHandle>& corners) {
  for (auto f : mesh.vf_range(corners[0])) {
    int shared = 0;
    for (auto v : mesh.fv_range(f)) shared += v == corners[1] || v == corners[2];
    if (shared == 2) return true;
  }
  return false;
}

// Refuses the mesh as soon as what is built so far shows it cannot fit the memory bound.
void check_prepared_bound(const TriMesh& mesh, std::size_t max_bytes) {
  if (max_bytes == 0) return;
  const std::size_t needed = preparation_bytes_lower_bound(mesh.n_vertices(), mesh.n_faces());
  if (needed > max_bytes)
    throw LimitExceededError("the prepared mesh needs more than " + std::to_string(needed >> 20) + " MiB (" +
                             std::to_string(mesh.n_vertices()) + " vertices and " + std::to_string(mesh.n_faces()) +
                             " triangles so far), more than the " + std::to_string(max_bytes >> 20) + " MiB it may use");
}

void warn_dropped_faces(PreparedTables& pm, std::size_t first_dropped, std::size_t first_repeated, std::size_t split_faces) {
  const MeshStatistics& stats = pm.statistics;
  if (stats.dropped_faces > 0) {
    std::ostringstream msg;
    msg << stats.dropped_faces << " degenerate triangle(s) with a repeated vertex index were dropped (first: input triangle "
        << first_dropped << "); face ids after it are shifted down";
    pm.warnings.push_back(msg.str());
  }
  if (stats.repeated_faces > 0) {
    std::ostringstream msg;
    msg << stats.repeated_faces << " triangle(s) over the same three vertices as an earlier one were dropped (first: input triangle "
        << first_repeated << "); face ids after it are shifted down";
    pm.warnings.push_back(msg.str());
  }
  if (split_faces > 0) {
    std::ostringstream msg;
    msg << split_faces << " triangle(s) would have made an edge or vertex non-manifold and were "
        << "given their own copies of their vertices (" << stats.duplicated_vertices
        << " vertices appended after the input's " << stats.file_vertices << ")";
    pm.warnings.push_back(msg.str());
  }
}

// A vertex where fans of triangles meet only at it (two cones tip to tip, a lid touching its pot
// at a point) takes every face at once when each fan has a free border there, so no face is
// split off: say so rather than leave it to the non-manifold count. Only read on meshes whose
// soup has such vertices.
void warn_pinched_vertices(const TriMesh& mesh, PreparedTables& pm) {
  std::size_t pinched = 0;
  int first = -1;
  for (const auto v : mesh.vertices())
    if (!mesh.is_manifold(v) && pinched++ == 0) first = v.idx();
  if (pinched == 0) return;
  std::ostringstream msg;
  msg << pinched << " vertex(es) join fans of triangles that meet only there (first: vertex " << first
      << "); each is kept as one vertex, so a line through it may pass from one fan to another";
  pm.warnings.push_back(msg.str());
}

// Adds the soup's triangles to `mesh` and pm.triangles in input order. OpenMesh refuses faces
// that would make an edge or vertex non-manifold (its error stream is switched off in
// prepare_mesh); like OpenMesh's own reader, we give such a face its own copies of the vertices
// so it is kept and every id stays valid. Degenerate triangles (a repeated index) and repeats of
// a triangle already added are dropped (a repeat would take three vertex copies each: one
// triangle repeated 8 million times had made 24 million vertices); all are reported in
// pm.warnings. The memory bound is checked before the first face and every 4096 faces.
void add_triangles(const RawMesh& raw, TriMesh& mesh, PreparedTables& pm, std::size_t max_bytes,
                   const Cancellation* cancel) {
  MeshStatistics& stats = pm.statistics;
  if (max_bytes != 0 && preparation_bytes_lower_bound(raw.positions.size(), 0) > max_bytes)
    throw LimitExceededError("the mesh's " + std::to_string(raw.positions.size()) + " vertices alone need more than the " +
                             std::to_string(max_bytes >> 20) + " MiB a prepared mesh may use");
  mesh.reserve(raw.positions.size(), raw.triangles.size() * 3 / 2, raw.triangles.size());
  for (const auto& p : raw.positions) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      throw MeshFormatError("a vertex has a non-finite coordinate");
    mesh.add_vertex(TriMesh::Point(p[0], p[1], p[2]));
  }
  std::vector<TriMesh::VertexHandle> corners(3);
  std::size_t first_dropped = SIZE_MAX, first_repeated = SIZE_MAX;
  std::size_t split_faces = 0;
  pm.source_triangle.reserve(raw.triangles.size());
  pm.triangles.reserve(raw.triangles.size());
  for (std::uint32_t t = 0; t < raw.triangles.size(); ++t) {
    if ((t & 4095) == 0) {
      throw_if_cancelled(cancel);
      check_prepared_bound(mesh, max_bytes);
    }
    const auto& tri = raw.triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      if (stats.dropped_faces++ == 0) first_dropped = t;
      continue;
    }
    for (int k = 0; k < 3; ++k) corners[k] = TriMesh::VertexHandle(int(tri[k]));
    // add_face checks before it changes anything: a closed fan takes no more faces, a side of
    // an edge that is taken takes no other, and a fan it cannot re-link refuses the face.
    TriMesh::FaceHandle face = mesh.add_face(corners);
    if (!face.is_valid()) {
      if (repeats_a_face(mesh, corners)) {
        if (stats.repeated_faces++ == 0) first_repeated = t;
        continue;
      }
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
  check_prepared_bound(mesh, max_bytes);
  warn_dropped_faces(pm, first_dropped, first_repeated, split_faces);
}

// Vertex adjacency in compressed rows with edge lengths beside it; the mean edge length and
// the boundary edge count.
void build_vertex_adjacency(const TriMesh& mesh, PreparedTables& pm) {
  const std::size_t n = mesh.n_vertices();
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
    if (mesh.is_boundary(e)) ++pm.statistics.boundary_edges;
  }
  pm.statistics.mean_edge_length = mesh.n_edges() > 0 ? edge_sum / double(mesh.n_edges()) : 0;
  if (!(pm.statistics.mean_edge_length > 0)) throw GeometryError("every edge of the mesh has zero length");
}

// The first face of OpenMesh's circulation around each vertex (not the lowest face id): the
// face answers have always reported for points on vertices.
void record_vertex_faces(const TriMesh& mesh, PreparedTables& pm) {
  pm.vertex_face.assign(mesh.n_vertices(), UINT32_MAX);
  for (auto v : mesh.vertices()) {
    const auto faces = mesh.vf_range(v);
    if (faces.begin() != faces.end()) pm.vertex_face[std::size_t(v.idx())] = std::uint32_t((*faces.begin()).idx());
  }
}

// Components by breadth-first search over the adjacency; unreferenced vertices get -1.
void label_components(PreparedTables& pm) {
  const std::size_t n = pm.positions.size();
  MeshStatistics& stats = pm.statistics;
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
}

// Boundary loops (following next_halfedge around each unvisited boundary halfedge) and the
// bounding box of the referenced vertices.
void measure_boundary_and_box(const TriMesh& mesh, PreparedTables& pm) {
  MeshStatistics& stats = pm.statistics;
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
  for (std::uint32_t v = 0; v < pm.positions.size(); ++v)
    if (pm.component[v] >= 0) lo = lo.cwiseMin(pm.positions[v]), hi = hi.cwiseMax(pm.positions[v]);
  stats.bbox_min = {lo.x(), lo.y(), lo.z()};
  stats.bbox_max = {hi.x(), hi.y(), hi.z()};
}

// Closed components (every edge of their faces has a face across) are counted, and those whose
// signed volume is negative have faces that point inward: the curvature's signs come out
// reversed there (convex edges read as valleys). With `outward` their faces are turned (corners
// 1 and 2 swapped; edge k = (t[k], t[k+1]) then runs over the old edge 2 - k, so the faces across
// swap to match); either way a warning says so.
constexpr double kFlatShell = 1e-3;

void orient_closed_components(PreparedTables& pm, bool outward) {
  MeshStatistics& stats = pm.statistics;
  std::vector<char> open(stats.components, 0);
  std::vector<double> volume(stats.components, 0), magnitude(stats.components, 0);
  const Eigen::Vector3d centre = 0.5 * (Eigen::Vector3d(stats.bbox_min.data()) + Eigen::Vector3d(stats.bbox_max.data()));
  for (std::uint32_t f = 0; f < pm.triangles.size(); ++f) {
    const auto& t = pm.triangles[f];
    const auto c = std::size_t(pm.component[t[0]]);
    for (int k = 0; k < 3; ++k) open[c] |= pm.face_neighbors[f][k] == kNoIndex;
    const Eigen::Vector3d a = pm.positions[t[0]] - centre, b = pm.positions[t[1]] - centre, d = pm.positions[t[2]] - centre;
    const double v = a.dot(b.cross(d)) / 6;
    volume[c] += v;
    magnitude[c] += std::abs(v);
  }
  std::vector<char> inward(stats.components, 0);
  for (std::size_t c = 0; c < stats.components; ++c) {
    stats.closed_components += !open[c];
    // A closed shell with next to no volume (both sides of a sheet) has no inside to point at.
    inward[c] = !open[c] && volume[c] < -kFlatShell * magnitude[c];
    stats.inward_components += inward[c];
  }
  if (stats.inward_components == 0) return;
  if (outward)
    for (std::uint32_t f = 0; f < pm.triangles.size(); ++f) {
      if (!inward[std::size_t(pm.component[pm.triangles[f][0]])]) continue;
      std::swap(pm.triangles[f][1], pm.triangles[f][2]);
      std::swap(pm.face_neighbors[f][0], pm.face_neighbors[f][2]);
      ++stats.flipped_faces;
    }
  std::ostringstream msg;
  msg << "the faces of " << stats.inward_components << " of " << stats.closed_components
      << " closed part(s) pointed inward (negative volume), "
      << (outward ? "and were turned outward so that convex edges read as ridges (" + std::to_string(stats.flipped_faces) + " faces)"
                  : "so convex edges read as valleys");
  pm.warnings.push_back(msg.str());
}

// The face tables every request reads (built once here).
void build_face_tables(PreparedTables& pm) {
  const std::size_t n = pm.positions.size();
  pm.vertex_faces = build_vertex_faces(pm.triangles, n);
  pm.face_neighbors = build_face_neighbors(pm.triangles, n);
  pm.boundary_vertex.assign(n, 0);
  for (std::uint32_t f = 0; f < pm.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (pm.face_neighbors[f][k] == kNoIndex) pm.boundary_vertex[pm.triangles[f][k]] = pm.boundary_vertex[pm.triangles[f][(k + 1) % 3]] = 1;
}

// Curvature range and percentiles of the feature value; the curvature scale.
void measure_curvature(PreparedTables& pm) {
  MeshStatistics& stats = pm.statistics;
  std::vector<double> magnitudes;
  magnitudes.reserve(pm.positions.size());
  stats.curvature_min = HUGE_VAL;
  stats.curvature_max = -HUGE_VAL;
  for (std::uint32_t v = 0; v < pm.positions.size(); ++v) {
    if (pm.component[v] < 0) continue;
    magnitudes.push_back(feature_value(pm.curvature, v, 0));
    stats.curvature_min = std::min(stats.curvature_min, dominant_curvature(pm.curvature, v));
    stats.curvature_max = std::max(stats.curvature_max, dominant_curvature(pm.curvature, v));
  }
  stats.abs_curvature_p50 = percentile(magnitudes, 0.5);
  stats.abs_curvature_p90 = percentile(magnitudes, 0.9);
  stats.abs_curvature_p99 = percentile(magnitudes, 0.99);
  // A flat mesh has no curvature at all; any positive scale then works.
  pm.curvature_scale = stats.abs_curvature_p90 > 0 ? stats.abs_curvature_p90 : 1.0 / stats.mean_edge_length;
}

}  // namespace

VertexFaces build_vertex_faces(const std::vector<std::array<std::uint32_t, 3>>& tris, std::size_t n_vertices) {
  VertexFaces vf;
  vf.offsets.assign(n_vertices + 1, 0);
  for (const auto& t : tris)
    for (auto v : t) ++vf.offsets[v + 1];
  std::partial_sum(vf.offsets.begin(), vf.offsets.end(), vf.offsets.begin());
  vf.faces.resize(vf.offsets.back());
  std::vector<std::uint32_t> fill(vf.offsets.begin(), vf.offsets.end() - 1);
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (auto v : tris[f]) vf.faces[fill[v]++] = f;
  return vf;
}

std::vector<std::array<std::uint32_t, 3>> build_face_neighbors(const std::vector<std::array<std::uint32_t, 3>>& tris,
                                                               std::size_t n_vertices) {
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
  std::vector<std::array<std::uint32_t, 3>> across(tris.size(), {kNoIndex, kNoIndex, kNoIndex});
  for (std::size_t v = 0; v < n_vertices; ++v)
    for (auto i = offsets[v]; i < offsets[v + 1]; ++i) {
      int found = 0;
      std::uint32_t match = kNoIndex;
      for (auto j = offsets[v]; j < offsets[v + 1]; ++j)
        if (j != i && entries[j].upper == entries[i].upper) ++found, match = entries[j].face;
      across[entries[i].face][entries[i].k] = found == 1 ? match : kNoIndex;
    }
  return across;
}

std::size_t PreparedMesh::memory_bytes() const {
  std::size_t bytes = sizeof(PreparedMesh);
  bytes += t_.vertex_face.capacity() * sizeof(std::uint32_t);
  bytes += t_.source_triangle.capacity() * sizeof(std::uint32_t) + t_.triangles.capacity() * 3 * sizeof(std::uint32_t);
  bytes += t_.positions.capacity() * sizeof(Eigen::Vector3d) + t_.vertex_normals.capacity() * sizeof(Eigen::Vector3d);
  bytes += (t_.curvature.mean.capacity() + t_.curvature.k_max.capacity() + t_.curvature.k_min.capacity()) * sizeof(double);
  bytes += t_.curvature.crease.capacity() + t_.curvature.on_crease.capacity() + t_.curvature.chord.capacity() +
           t_.curvature.fold.capacity();
  bytes += t_.neighbor_offsets.capacity() * sizeof(std::uint32_t) + t_.neighbors.capacity() * sizeof(std::uint32_t);
  bytes += t_.neighbor_edge_lengths.capacity() * sizeof(double) + t_.component.capacity() * sizeof(std::int32_t);
  bytes += (t_.vertex_faces.offsets.capacity() + t_.vertex_faces.faces.capacity()) * sizeof(std::uint32_t);
  bytes += t_.face_neighbors.capacity() * 3 * sizeof(std::uint32_t) + t_.boundary_vertex.capacity();
  bytes += t_.vertex_index.memory_bytes() + t_.landmarks.memory_bytes();
  for (const auto& w : t_.warnings) bytes += w.capacity();
  return bytes;
}

std::shared_ptr<const PreparedMesh> prepare_mesh(RawMesh raw, const PrepareOptions& options, const Cancellation* cancel) {
  const auto start = Clock::now();
  auto clock = start;
  // OpenMesh prints add_face failures ("patch re-linking failed") to std::cerr; we handle and
  // report every such face ourselves, so its stream is switched off once for the process.
  static std::once_flag quiet;
  std::call_once(quiet, [] { omerr().disable(); });
  PreparedTables pm;
  MeshStatistics& stats = pm.statistics;
  pm.warnings = std::move(raw.warnings);
  stats.file_vertices = raw.positions.size();
  stats.file_faces = raw.source_faces;
  Executor& executor = executor_or_default(options.executor);
  // OpenMesh's halfedge kernel builds the topology (and refuses non-manifold faces); the tables
  // every request reads are taken from it, and it is released before the curvature stage.
  auto mesh_ptr = std::make_unique<TriMesh>();
  {
    // The non-manifold counts read only the soup, so they are made beside OpenMesh's insertion
    // (serial, the largest part of this stage).
    MeshStatistics counted;
    executor.run_beside([&raw, &counted] { count_non_manifold(raw, counted); },
                        [&] { add_triangles(raw, *mesh_ptr, pm, options.max_memory_bytes, cancel); });
    stats.non_manifold_edges = counted.non_manifold_edges;
    stats.non_manifold_vertices = counted.non_manifold_vertices;
  }
  if (stats.non_manifold_vertices > 0) warn_pinched_vertices(*mesh_ptr, pm);
  if (mesh_ptr->n_faces() == 0) throw GeometryError("the mesh has no usable triangle");

  const TriMesh& mesh = *mesh_ptr;
  const std::size_t n = mesh.n_vertices();
  stats.vertices = n;
  stats.faces = mesh.n_faces();
  pm.positions.resize(n);
  for (auto v : mesh.vertices()) pm.positions[v.idx()] = to_eigen(mesh.point(v));
  pm.timings.triangles_ms = lap_ms(clock);
  // Beside the vertex adjacency (OpenMesh circulators, serial): the face tables, which read
  // only the triangle list. Each writes its own members of pm.
  executor.run_beside(
      [&pm] {
        auto own_clock = StageClock::now();
        build_face_tables(pm);
        pm.timings.tables_ms = lap_ms(own_clock);
      },
      [&] {
        build_vertex_adjacency(mesh, pm);
        record_vertex_faces(mesh, pm);
        label_components(pm);
        measure_boundary_and_box(mesh, pm);
        pm.timings.adjacency_ms = lap_ms(clock);
      });
  mesh_ptr.reset();
  orient_closed_components(pm, options.orient_outward);
  lap_ms(clock);  // the wait for the face tables, if any, is theirs
  // Beside the normals and the curvature field (whose creases and mean curvature are serial):
  // the k-d tree, which reads only the positions and components.
  executor.run_beside(
      [&pm] {
        auto own_clock = StageClock::now();
        pm.vertex_index = VertexIndex(pm.positions, pm.component);
        pm.timings.index_ms = lap_ms(own_clock);
      },
      [&] {
        throw_if_cancelled(cancel);
        pm.vertex_normals = compute_vertex_normals(pm.positions, pm.triangles);
        pm.timings.normals_ms = lap_ms(clock);
        const MeshTablesView tables{pm.positions, pm.triangles, pm.face_neighbors, pm.boundary_vertex, {pm.neighbor_offsets, pm.neighbors, pm.neighbor_edge_lengths}};
        pm.curvature = compute_curvature_field(tables, pm.vertex_normals, options.curvature, cancel, &executor);
        pm.timings.curvature_ms = lap_ms(clock);
      });
  stats.curvature_method = to_string(options.curvature.method);
  stats.noise = pm.curvature.noise;
  stats.noise_length = pm.curvature.noise_length;
  stats.noise_samples = pm.curvature.noise_samples;
  stats.curvature_radius = pm.curvature.radius;
  if (options.curvature.method == CurvatureMethod::jet) stats.jet_degree = to_string(pm.curvature.jet_degree);
  stats.curvature_smoothing_passes = pm.curvature.smoothing_passes;
  stats.crease_angle = pm.curvature.crease_angle;
  stats.crease_edges = pm.curvature.crease_edges;
  measure_curvature(pm);

  auto prepared = std::make_shared<PreparedMesh>(std::move(pm));
  PreparedTables& kept = prepared->t_;
  kept.landmarks = build_path_landmarks(*prepared, executor, cancel);
  kept.timings.landmarks_ms = lap_ms(clock);
  kept.prepare_ms = ms_since(start);
  return prepared;
}

double PreparedMesh::local_edge_length(std::uint32_t v) const {
  const auto begin = t_.neighbor_offsets[v], end = t_.neighbor_offsets[v + 1];
  if (begin == end) return t_.statistics.mean_edge_length;
  double sum = 0;
  for (auto k = begin; k < end; ++k) sum += t_.neighbor_edge_lengths[k];
  return sum / double(end - begin);
}

}  // namespace featureline
