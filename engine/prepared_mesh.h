// The prepared mesh: loaded once, validated, with adjacency, normals and curvature
// precomputed. Immutable after prepare_mesh returns, so the server shares one
// instance between threads without copying or locking.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "engine/curvature.h"
#include "engine/mesh_io.h"
#include "engine/path_landmarks.h"
#include "engine/vertex_index.h"

namespace featureline {

struct PrepareOptions {
  CurvatureOptions curvature;  ///< the feature field and creases (engine/curvature.h)
  /// Refuse (LimitExceededError) a mesh whose preparation could not stay within this many bytes
  /// (preparation_bytes_lower_bound of the vertices and kept triangles, checked before anything is
  /// built and again as vertex copies for non-manifold faces are made); 0: no bound.
  std::size_t max_memory_bytes = 0;
  /// A closed component whose faces point inward (negative signed volume: an exporter's
  /// reversed winding) reads convex edges as valleys; true turns its faces outward (their
  /// second and third corners swapped), false keeps them and warns.
  bool orient_outward = true;
  /// Where the parallel parts run (the curvature's loops, and the tables, counts and k-d tree
  /// built beside other stages); nullptr: default_executor(). The server passes its engine pool.
  /// The prepared mesh is the same whatever it is.
  Executor* executor = nullptr;
};

/// Counts and measures of a prepared mesh, as `featureline info` and the server report them.
struct MeshStatistics {
  std::size_t vertices = 0;               ///< vertices of the prepared mesh (file vertices + duplicates)
  std::size_t faces = 0;                  ///< triangles of the prepared mesh
  std::size_t file_vertices = 0;          ///< vertex records in the input
  std::size_t file_faces = 0;             ///< polygons in the input (before triangulation)
  std::size_t components = 0;             ///< edge-connected components that have faces
  std::size_t boundary_loops = 0;         ///< cycles of boundary edges
  std::size_t boundary_edges = 0;         ///< edges with one face
  std::size_t non_manifold_edges = 0;     ///< input edges shared by more than two triangles
  std::size_t non_manifold_vertices = 0;  ///< input vertices whose triangles form more than one fan
  std::size_t unreferenced_vertices = 0;  ///< vertices used by no triangle
  std::size_t dropped_faces = 0;          ///< degenerate triangles (a repeated vertex index) not added
  std::size_t duplicated_vertices = 0;    ///< vertex copies added so non-manifold triangles fit
  std::size_t repeated_faces = 0;         ///< triangles over the same three vertices as an earlier one, not added
  std::size_t closed_components = 0;      ///< components in which every edge has two faces
  std::size_t inward_components = 0;      ///< closed components whose faces pointed inward (negative volume)
  std::size_t flipped_faces = 0;          ///< faces of those turned outward (PrepareOptions::orient_outward)
  double mean_edge_length = 0;
  std::array<double, 3> bbox_min{0, 0, 0};
  std::array<double, 3> bbox_max{0, 0, 0};
  /// Range of the dominant signed curvature (the principal curvature of larger magnitude).
  double curvature_min = 0, curvature_max = 0;
  /// Feature value (larger |k|) percentiles 50, 90, 99 (the 90th is the scale the engine normalises by).
  double abs_curvature_p50 = 0, abs_curvature_p90 = 0, abs_curvature_p99 = 0;
  std::string curvature_method;   ///< "jet" or "cotangent"
  double noise = 0;               ///< estimated RMS noise along the normal, in local edge lengths
  double noise_length = 0;        ///< the same in length units (CurvatureField::noise_length)
  std::size_t noise_samples = 0;  ///< vertices it was read at (CurvatureField::noise_samples)
  double curvature_radius = 0;    ///< jet radius used, local edge lengths (0: cotangent)
  std::string jet_degree;         ///< "quadric" or "cubic": the jets fitted ("" with cotangent)
  int curvature_smoothing_passes = 0;  ///< Laplacian passes over the principal curvatures
  double crease_angle = 0;        ///< dihedral angle above which an edge is a crease, degrees
  std::size_t crease_edges = 0;   ///< edges sharper than that
};

/// Wall time of each stage of prepare_mesh, milliseconds (bench_pipeline prints them; the
/// curvature stage's own parts are in PreparedMesh::curvature.timings). The face tables are
/// built beside the adjacency and the k-d tree beside the normals and curvature, each timed on
/// whichever thread ran it (another of the executor's when one was idle), so all six can add up
/// to more than the whole; the other four cannot.
struct PrepareTimings {
  double triangles_ms = 0;  ///< non-manifold counts, the OpenMesh mesh and the triangle list
  double adjacency_ms = 0;  ///< vertex adjacency, components, boundary loops, bounding box
  double tables_ms = 0;     ///< faces around vertices, faces across edges, boundary flags (beside adjacency)
  double index_ms = 0;      ///< the k-d tree of vertices (beside normals and curvature)
  double normals_ms = 0;    ///< vertex normals
  double curvature_ms = 0;  ///< compute_curvature_field, all of it
  double landmarks_ms = 0;  ///< build_path_landmarks
};

/// Faces around each vertex in compressed rows: the faces of v, in increasing id order, are
/// faces[offsets[v] .. offsets[v+1]).
struct VertexFaces {
  std::vector<std::uint32_t> offsets, faces;
  const std::uint32_t* begin(std::uint32_t v) const { return faces.data() + offsets[v]; }
  const std::uint32_t* end(std::uint32_t v) const { return faces.data() + offsets[v + 1]; }
};

/// A run of ids in one of the prepared mesh's compressed rows, for range-for.
struct IdRange {
  const std::uint32_t* first;
  const std::uint32_t* last;
  const std::uint32_t* begin() const { return first; }
  const std::uint32_t* end() const { return last; }
  std::size_t size() const { return std::size_t(last - first); }
};

/// The faces around each of n_vertices vertices of `triangles`.
VertexFaces build_vertex_faces(const std::vector<std::array<std::uint32_t, 3>>& triangles, std::size_t n_vertices);

/// Face adjacency: result[f][k] is the face on the other side of edge k = (t[k], t[k+1]) of face
/// f, or UINT32_MAX on boundary edges and on edges with more than two faces.
std::vector<std::array<std::uint32_t, 3>> build_face_neighbors(const std::vector<std::array<std::uint32_t, 3>>& triangles,
                                                               std::size_t n_vertices);

/// The tables of a prepared mesh, as prepare_mesh builds them: vertex i is input vertex i (copies
/// made for non-manifold faces follow the input's vertices). OpenMesh builds the topology while
/// the mesh is prepared and is dropped afterwards.
struct PreparedTables {
  /// Input triangle index of each mesh face (faces keep input order; only dropped ones are missing).
  std::vector<std::uint32_t> source_triangle;
  /// Corner vertex ids of each face in the input's corner order, or with its second and third
  /// corners swapped where its closed component was turned outward (statistics.flipped_faces);
  /// barycentric coordinates in results refer to this order.
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<Eigen::Vector3d> positions;       ///< copy of the points for cache-friendly access
  std::vector<Eigen::Vector3d> vertex_normals;  ///< angle-weighted, unit length (zero when isolated)
  /// Curvature and the feature field (see engine/curvature.h): curvature.mean is the signed mean
  /// curvature H (cotangent formula, mixed Voronoi areas; Meyer et al. 2003, the discrete mean
  /// curvature the paper cites), positive on convex ridges, 1/r on a sphere of radius r;
  /// curvature.k_max / k_min the principal curvatures every engine stage reads; curvature.crease
  /// the sharp edges, parallel to `neighbors`.
  CurvatureField curvature;
  /// Vertex adjacency in compressed rows: neighbours of v are
  /// neighbors[neighbor_offsets[v] .. neighbor_offsets[v+1]).
  std::vector<std::uint32_t> neighbor_offsets;
  std::vector<std::uint32_t> neighbors;
  std::vector<double> neighbor_edge_lengths;  ///< parallel to `neighbors`
  std::vector<std::int32_t> component;        ///< component id per vertex, -1 for unreferenced vertices
  /// Face tables over `triangles`, built once here for every request that walks faces
  /// (segmentation, the feature strip): faces around each vertex, the face across each edge
  /// (build_face_neighbors), and whether each vertex is on an edge with one face.
  VertexFaces vertex_faces;
  /// The face a point on vertex v reports (surface_point_at_vertex): the first of OpenMesh's
  /// circulation around v, as answers have always given; UINT32_MAX for unreferenced vertices.
  std::vector<std::uint32_t> vertex_face;
  std::vector<std::array<std::uint32_t, 3>> face_neighbors;
  std::vector<char> boundary_vertex;
  /// Nearest-vertex queries over the vertices that belong to a triangle (keys given as points).
  VertexIndex vertex_index;
  /// Reference curvature magnitude: the 90th percentile of the feature value (the larger |k|;
  /// never zero). Engine stages
  /// measure curvature in units of this, so options do not depend on the mesh's scale.
  double curvature_scale = 1;
  /// Lower bounds of feature-path costs for the path searches (engine/path_landmarks.h).
  PathLandmarks landmarks;
  MeshStatistics statistics;
  std::vector<std::string> warnings;
  double prepare_ms = 0;
  PrepareTimings timings;
};

/// Everything a request reads: the tables of PreparedTables, immutable once prepared (the server
/// shares one instance between threads), and the queries the stages ask of them.
class PreparedMesh {
 public:
  explicit PreparedMesh(PreparedTables tables) : t_(std::move(tables)) {}

  // The tables (PreparedTables says what each holds).
  const std::vector<std::uint32_t>& source_triangle() const { return t_.source_triangle; }
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const { return t_.triangles; }
  const std::vector<Eigen::Vector3d>& positions() const { return t_.positions; }
  const std::vector<Eigen::Vector3d>& vertex_normals() const { return t_.vertex_normals; }
  const CurvatureField& curvature() const { return t_.curvature; }
  const std::vector<std::uint32_t>& neighbor_offsets() const { return t_.neighbor_offsets; }
  const std::vector<std::uint32_t>& neighbors() const { return t_.neighbors; }
  const std::vector<double>& neighbor_edge_lengths() const { return t_.neighbor_edge_lengths; }
  const std::vector<std::int32_t>& component() const { return t_.component; }
  const VertexFaces& vertex_faces() const { return t_.vertex_faces; }
  const std::vector<std::uint32_t>& vertex_face() const { return t_.vertex_face; }
  const std::vector<std::array<std::uint32_t, 3>>& face_neighbors() const { return t_.face_neighbors; }
  const std::vector<char>& boundary_vertex() const { return t_.boundary_vertex; }
  const VertexIndex& vertex_index() const { return t_.vertex_index; }
  double curvature_scale() const { return t_.curvature_scale; }
  const PathLandmarks& landmarks() const { return t_.landmarks; }
  const MeshStatistics& statistics() const { return t_.statistics; }
  const std::vector<std::string>& warnings() const { return t_.warnings; }
  double prepare_ms() const { return t_.prepare_ms; }
  const PrepareTimings& timings() const { return t_.timings; }

  std::size_t n_vertices() const { return t_.positions.size(); }
  /// The faces around vertex v, in increasing id order.
  IdRange faces_around(std::uint32_t v) const { return {t_.vertex_faces.begin(v), t_.vertex_faces.end(v)}; }
  std::size_t n_faces() const { return t_.triangles.size(); }

  static constexpr std::uint32_t kNoEdge = UINT32_MAX;
  /// The slot of edge a-b in a's adjacency row (an index into neighbors, neighbor_edge_lengths
  /// and curvature.crease), or kNoEdge when a and b are not neighbours.
  std::uint32_t edge_slot(std::uint32_t a, std::uint32_t b) const {
    for (auto k = t_.neighbor_offsets[a]; k < t_.neighbor_offsets[a + 1]; ++k)
      if (t_.neighbors[k] == b) return k;
    return kNoEdge;
  }
  bool are_neighbors(std::uint32_t a, std::uint32_t b) const { return edge_slot(a, b) != kNoEdge; }
  /// Whether the edge in adjacency slot k is a crease of `sign` (+1 ridge, -1 valley; any when 0).
  bool is_crease_slot(std::uint32_t k, double sign) const {
    const auto crease = t_.curvature.crease[k];
    return crease != 0 && (sign == 0 || crease == sign);
  }
  /// Whether a-b is an edge and a crease of `sign` (+1 ridge, -1 valley; any when 0).
  bool is_crease(std::uint32_t a, std::uint32_t b, double sign) const {
    const auto k = edge_slot(a, b);
    return k != kNoEdge && is_crease_slot(k, sign);
  }
  /// Mean length of v's edges: the unit of distance near v. Meshes mix edges 100 times apart
  /// in length (CAD tessellations, adaptive remeshes, separate parts), so a mesh-wide mean edge
  /// says little about the edges a line is walking on. The mesh-wide mean for isolated vertices.
  double local_edge_length(std::uint32_t v) const;
  /// The point of face f at barycentric coordinates b (w.r.t. its corners in `triangles` order;
  /// any type indexed 0..2: Barycentric, Eigen::Vector3d).
  template <typename Weights>
  Eigen::Vector3d point_at(std::uint32_t f, const Weights& b) const {
    const auto& t = t_.triangles[f];
    return b[0] * t_.positions[t[0]] + b[1] * t_.positions[t[1]] + b[2] * t_.positions[t[2]];
  }
  /// Feature strength in [0, 1] of vertex v: its feature value for lines of `feature_sign`
  /// (engine/curvature.h) over the curvature scale, clamped.
  double feature_strength(std::uint32_t v, double feature_sign) const {
    const double s = feature_value(t_.curvature, v, feature_sign) / t_.curvature_scale;
    return s > 1 ? 1 : s;
  }
  /// The vertex nearest p among those that belong to a triangle (the lowest id among equally
  /// near ones). \pre p is finite.
  std::uint32_t nearest_vertex(const Eigen::Vector3d& p) const { return t_.vertex_index.nearest(p); }
  /// Bytes this object holds (measured from container capacities), for cache budgets.
  std::size_t memory_bytes() const;

 private:
  // The landmarks are measured over the finished tables, through the queries above.
  friend std::shared_ptr<const PreparedMesh> prepare_mesh(RawMesh, const PrepareOptions&, const Cancellation*);
  PreparedTables t_;
};

/// Builds the prepared mesh from a raw triangle soup.
/// \throw GeometryError when no usable triangle remains; CancelledError once `cancel` is
///        requested (checked every 4096 faces and through the curvature stage).
std::shared_ptr<const PreparedMesh> prepare_mesh(RawMesh raw, const PrepareOptions& options = {},
                                                 const Cancellation* cancel = nullptr);

}  // namespace featureline
