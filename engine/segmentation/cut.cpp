// Which edges the lines cut: snap mode (mesh edges through the vertices nearest the line, the
// paper's basic method) and remesh mode (new edges along the line itself, Fig. 8).
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "engine/internal/edge_search.h"
#include "engine/segmentation/remesh.h"
#include "engine/segmentation/stages.h"
#include "engine/segmentation/trace.h"

namespace featureline {
namespace {

/// A line's chain of mesh vertices; linked[k]: chain[k-1] -- chain[k] is a mesh edge (not a gap).
struct VertexChain {
  std::vector<std::uint32_t> vertices;
  std::vector<char> linked;
};

/// Appends v to the chain, joined to its last vertex by the shortest edge path (a gap when the
/// two lie on parts of the mesh that share no edge).
void extend_chain(const PreparedMesh& mesh, VertexChain& chain, std::uint32_t v, std::size_t& gaps) {
  if (chain.vertices.empty()) {
    chain.vertices.push_back(v);
    chain.linked.push_back(0);
    return;
  }
  const auto last = chain.vertices.back();
  if (v == last) return;
  if (mesh.are_neighbors(last, v)) {
    chain.vertices.push_back(v);
    chain.linked.push_back(1);
    return;
  }
  const auto path = shortest_path_between(mesh, last, v, HUGE_VAL);
  if (path.empty()) {  // across parts of the mesh that share no edge: a gap in the chain
    ++gaps;
    chain.vertices.push_back(v);
    chain.linked.push_back(0);
    return;
  }
  chain.vertices.insert(chain.vertices.end(), path.begin() + 1, path.end());
  chain.linked.resize(chain.vertices.size(), 1);
}

/// Whether a-b is an edge of exactly one face (on the mesh's boundary).
bool is_boundary_edge(const PreparedMesh& mesh, std::uint32_t a, std::uint32_t b) {
  int faces = 0;
  for (const std::uint32_t f : mesh.faces_around(a)) faces += corner_of(mesh.triangles()[f], b) >= 0;
  return faces == 1;
}

/// Drops each vertex b of a chain a -> b -> c where a-c is a boundary edge: a line running
/// along the border within a fraction of an edge snaps to border and inner vertices in turn,
/// and the detour through b would cut face (a, b, c) off as a one-face segment; the cut along
/// the border edge itself separates nothing.
void follow_the_border(const PreparedMesh& mesh, VertexChain& chain) {
  VertexChain kept;
  for (std::size_t i = 0; i < chain.vertices.size(); ++i) {
    const bool detour = i > 0 && i + 1 < chain.vertices.size() && chain.linked[i] && chain.linked[i + 1] &&
                        !kept.vertices.empty() && kept.vertices.back() == chain.vertices[i - 1] &&
                        is_boundary_edge(mesh, chain.vertices[i - 1], chain.vertices[i + 1]);
    if (detour) continue;
    kept.vertices.push_back(chain.vertices[i]);
    kept.linked.push_back(chain.linked[i]);
  }
  chain = std::move(kept);
}

/// The paper: "the vertices nearest to the obtained feature line are finally chosen as the
/// segmentation line": the nearest corner of each refined point, consecutive ones joined.
VertexChain nearest_vertex_chain(const PreparedMesh& mesh, const FeatureLineResult& line, std::size_t& gaps) {
  VertexChain chain;
  for (const auto& s : line.refined) {
    const Triangle& t = mesh.triangles()[s.face];
    const Eigen::Vector3d x = mesh.point_at(s.face, s.barycentric);
    std::uint32_t nearest = t[0];
    for (auto v : t)
      if ((mesh.positions()[v] - x).squaredNorm() < (mesh.positions()[nearest] - x).squaredNorm()) nearest = v;
    extend_chain(mesh, chain, nearest, gaps);
  }
  if (line.closed && chain.vertices.size() > 2) extend_chain(mesh, chain, chain.vertices.front(), gaps);
  follow_the_border(mesh, chain);
  return chain;
}

/// Joins each loose end of open line i to the boundary or another chain within attach_distance
/// (in edge lengths at the end) by the shortest edge path, cutting it too.
void attach_chain_ends(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                       const std::vector<VertexChain>& chains, std::size_t i, double attach_distance, CutEdges& cuts,
                       CutReport& report) {
  for (int end = 0; end < 2; ++end) {
    const auto v = end == 0 ? chains[i].vertices.front() : chains[i].vertices.back();
    auto attached = [&](std::uint32_t w) {
      if (mesh.boundary_vertex()[w]) return true;
      for (std::size_t j = 0; j < lines.size(); ++j)
        if (j != i && std::find(chains[j].vertices.begin(), chains[j].vertices.end(), w) != chains[j].vertices.end())
          return true;
      return false;
    };
    if (attached(v)) continue;
    const double attach_radius = attach_distance * mesh.local_edge_length(v);
    const auto path = attach_radius > 0 ? shortest_path_to(mesh, v, attached, attach_radius) : std::vector<std::uint32_t>{};
    if (path.empty()) {
      report.loose_ends.push_back("line " + std::to_string(i) + " ends at vertex " + std::to_string(v) +
                                  ", on neither the mesh boundary nor another line");
      continue;
    }
    for (std::size_t k = 1; k < path.size(); ++k) cuts.emplace(edge_key(path[k - 1], path[k]), int(i));
  }
}

/// Is `l` on the mesh boundary (a boundary vertex, or a point of a boundary edge)?
bool on_mesh_boundary(const PreparedMesh& mesh, const SurfaceLocation& l) {
  if (l.kind == SurfaceLocation::vertex) return mesh.boundary_vertex()[l.a] != 0;
  if (l.kind != SurfaceLocation::edge) return false;
  const Triangle& t = mesh.triangles()[l.home];
  for (int k = 0; k < 3; ++k)
    if (mesh.face_neighbors()[l.home][k] == kNoIndex && lies_on_edge(l, t[k], t[(k + 1) % 3])) return true;
  return false;
}

/// The nearest boundary vertex or refined point of another line within attach_distance (in
/// edge lengths of the end's face) of end point e of line i, when there is one.
std::optional<SurfacePoint> attachment_for(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                           std::size_t i, const SurfaceLocation& l, double attach_distance) {
  const Eigen::Vector3d x = position_of(mesh, l);
  const auto& home = mesh.triangles()[l.home];
  double best = attach_distance *
                (mesh.local_edge_length(home[0]) + mesh.local_edge_length(home[1]) + mesh.local_edge_length(home[2])) / 3;
  std::optional<SurfacePoint> join;
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v)
    if (mesh.boundary_vertex()[v] && (mesh.positions()[v] - x).norm() <= best)
      best = (mesh.positions()[v] - x).norm(), join = surface_point_at_vertex(mesh, v);
  for (std::size_t j = 0; j < lines.size(); ++j)
    if (j != i)
      for (const auto& s : lines[j].refined)
        if ((s.position - x).norm() <= best) best = (s.position - x).norm(), join = s;
  return join;
}

/// Line i's refined points, each loose end extended to the boundary or another line nearby.
std::vector<SurfacePoint> points_with_attached_ends(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                                    std::size_t i, double attach_distance, double snap,
                                                    CutReport& report) {
  std::vector<SurfacePoint> points = lines[i].refined;
  if (lines[i].closed) return points;
  for (int end = 0; end < 2; ++end) {
    const SurfacePoint& e = end == 0 ? points.front() : points.back();
    const SurfaceLocation l = locate_in_face(mesh.triangles(), e.face, e.barycentric, snap);
    if (on_mesh_boundary(mesh, l)) continue;
    const auto join = attachment_for(mesh, lines, i, l, attach_distance);
    if (!join) {
      const Eigen::Vector3d x = position_of(mesh, l);
      std::ostringstream msg;
      msg << "line " << i << " ends at (" << x.x() << ", " << x.y() << ", " << x.z()
          << "), on neither the mesh boundary nor another line";
      report.loose_ends.push_back(msg.str());
      continue;
    }
    if (end == 0) points.insert(points.begin(), *join);
    else points.push_back(*join);
  }
  return points;
}

/// The points' distinct locations in order (a closed line back to its first).
std::vector<SurfaceLocation> line_locations(const PreparedMesh& mesh, const std::vector<SurfacePoint>& points,
                                            bool closed, double snap) {
  std::vector<SurfaceLocation> locations;
  for (const auto& s : points) {
    const auto l = locate_in_face(mesh.triangles(), s.face, s.barycentric, snap);
    if (locations.empty() || !same_location(locations.back(), l)) locations.push_back(l);
  }
  if (closed && locations.size() > 2 && !same_location(locations.back(), locations.front()))
    locations.push_back(locations.front());
  return locations;
}

}  // namespace

CutEdges cut_along_nearest_vertices(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                    const SegmentationOptions& options, CutReport& report, const Cancellation* cancel) {
  CutEdges cuts;
  std::vector<VertexChain> chains;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    throw_if_cancelled(cancel);
    chains.push_back(nearest_vertex_chain(mesh, lines[i], report.gaps[i]));
  }
  // Open ends join the boundary or another line nearby (a path search per end).
  for (std::size_t i = 0; i < lines.size(); ++i) {
    throw_if_cancelled(cancel);
    if (!lines[i].closed) attach_chain_ends(mesh, lines, chains, i, options.attach_distance, cuts, report);
  }
  for (std::size_t i = 0; i < lines.size(); ++i)
    for (std::size_t k = 1; k < chains[i].vertices.size(); ++k)
      if (chains[i].linked[k]) cuts.emplace(edge_key(chains[i].vertices[k - 1], chains[i].vertices[k]), int(i));
  return cuts;
}

RemeshedCut cut_along_lines_by_remeshing(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                         const SegmentationOptions& options, CutReport& report, const Cancellation* cancel) {
  const double snap = std::max(options.remesh_snap, 1e-6);
  const Tracer tracer(mesh, snap);
  Remesher remesher(mesh, snap);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    throw_if_cancelled(cancel);
    const auto points = points_with_attached_ends(mesh, lines, i, options.attach_distance, snap, report);
    const auto locations = line_locations(mesh, points, lines[i].closed, snap);
    std::vector<TraceStep> steps;
    for (std::size_t k = 1; k < locations.size(); ++k) {
      const auto how = tracer.trace(locations[k - 1], locations[k], steps);
      report.fallbacks += how == Traced::along_edges;
      report.gaps[i] += how == Traced::gap;
    }
    throw_if_cancelled(cancel);  // traced; splitting its faces is the other half of a line's work
    auto x = remesher.locate(locations.front());
    for (const auto& step : steps) x = step.gap ? remesher.locate(step.to) : remesher.walk(x, step.to, step.face, int(i));
  }
  return remesher.take();
}

}  // namespace featureline
