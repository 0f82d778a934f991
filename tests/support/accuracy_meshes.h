// Known-answer meshes and measures for accuracy tests and benchmarks (the refined
// line must never be worse than the initial one on noisy scans and CAD creases):
// reproducible Gaussian noise, a CAD-like rounded slab whose crease chains are known exactly,
// in the skinny tessellation CAD exporters write and in a fine one, exact point-to-polyline
// distances, and the crease chains of real CAD meshes.
//
// Deterministic like synthetic_meshes.h: randomness comes from std::mt19937_64 with the given
// seed and our own mapping to numbers (no std::*_distribution, whose output differs between
// standard libraries). Invalid arguments throw std::invalid_argument.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "engine/mesh_io.h"

namespace featureline::testing {

// ---------------------------------------------------------------------------------
// Edge lengths and noise
// ---------------------------------------------------------------------------------

/// Mean length over the mesh's unique undirected edges (each edge counted once however many
/// triangles share it); 0 for a mesh without triangles.
double mean_edge_length(const RawMesh& mesh);

/// The mesh with every vertex displaced by an independent Gaussian vector whose RMS length is
/// fraction * mean_edge_length(mesh) (per-coordinate sigma fraction * e / sqrt(3)). Vertex ids
/// and triangles are unchanged, so ids picked on the clean mesh stay valid. fraction 0 returns
/// the mesh unchanged; the same (mesh, fraction, seed) always gives the same positions.
/// \param mesh      the clean mesh
/// \param fraction  RMS displacement in mean edge lengths, >= 0 and finite
/// \param seed      seed of the std::mt19937_64 that draws the displacements
RawMesh with_noise(RawMesh mesh, double fraction, std::uint64_t seed);

// ---------------------------------------------------------------------------------
// A CAD-like part with known creases: the rounded slab
// ---------------------------------------------------------------------------------

enum class SlabTessellation {
  /// As CAD exporters write it: each side band is ONE row of quads from z = 0 to z = h, each
  /// split into two long skinny triangles; each cap is a zig-zag strip of long thin triangles
  /// over the outline's vertices only (from the middle vertex of the arc at (+a,+b) across to
  /// the middle vertex of the opposite arc), with no interior vertex.
  skinny,
  /// Reasonable triangles: the side band in rows about one outline edge high; each cap made of
  /// concentric offset rings of the outline (rounded rectangles with the same straight sides
  /// and radii shrinking in steps of about one edge length) around a regular grid over the
  /// inner rectangle [-(a-r), a-r] x [-(b-r), b-r], whose border vertices line up with the
  /// outline's side vertices; each corner ends in a small fan at the inner rectangle's corner.
  fine,
};

/// A rounded rectangle (half sizes a >= b, corner radius r) extruded from z = 0 to z = h.
struct RoundedSlabOptions {
  double half_x = 1.0;         ///< a, > corner_radius
  double half_y = 0.6;         ///< b, > corner_radius
  double corner_radius = 0.12; ///< r, > 0 (the default is about 1.6 side edge lengths: tight)
  double height = 0.4;         ///< h, > 0
  /// Edges per quarter arc (>= 1); the outline turns by 90/corner_segments degrees at each arc
  /// vertex, and the side band's vertical edges there have that dihedral angle.
  int corner_segments = 4;
  /// Edges on each straight side along x (length 2(a-r)), >= 1. The sides along y (length
  /// 2(b-r)) get max(1, round(side_segments * (b-r)/(a-r))) edges, about as long.
  int side_segments = 24;
  SlabTessellation tessellation = SlabTessellation::skinny;
};

/// A closed, manifold, outward oriented triangle mesh with its crease chains.
struct CadPart {
  RawMesh mesh;
  /// The top outline (z = h) in order, counter-clockwise seen from +z; consecutive ids and the
  /// last and first id are mesh edges: the closed chain of sharp 90-degree crease edges.
  std::vector<std::uint32_t> top_outline;
  /// The bottom outline (z = 0), same order and same (x, y) as top_outline vertex by vertex.
  std::vector<std::uint32_t> bottom_outline;
  double mean_edge_length = 0;  ///< mean_edge_length(mesh)
};

/// The rounded slab described by `options`. Outline vertex k of either loop lies exactly on
/// the analytic rounded rectangle (see rounded_rectangle_distance). The outline starts at the
/// bottom end of the side x = +a and runs counter-clockwise seen from +z: right side, arc at
/// (+a,+b), top side, arc at (-a,+b), left side, arc at (-a,-b), bottom side, arc at (+a,-b).
/// \throw std::invalid_argument for non-finite or out-of-range options
CadPart make_rounded_slab(const RoundedSlabOptions& options);

/// Signed distance in the xy plane from (x, y) to the rounded rectangle with half sizes a, b
/// and corner radius r centred at the origin (negative inside, 0 on the outline).
double rounded_rectangle_distance(double a, double b, double r, double x, double y);

// ---------------------------------------------------------------------------------
// Distances and crease chains
// ---------------------------------------------------------------------------------

/// Exact 3D distance from p to the polyline through `chain` (closing segment from the last
/// point to the first included when `closed`): the minimum over its segments of the exact
/// point-to-segment distance. A single point is a degenerate polyline (distance to it).
/// \throw std::invalid_argument when chain is empty
double distance_to_polyline(const std::vector<Eigen::Vector3d>& chain, bool closed, const Eigen::Vector3d& p);

/// A chain of sharp mesh edges.
struct CreaseChain {
  /// Vertex ids in order; consecutive ids are sharp mesh edges. A closed chain does not repeat
  /// its first id at the end (its closing edge is last -> first).
  std::vector<std::uint32_t> vertices;
  bool closed = false;
  std::size_t edges() const { return closed ? vertices.size() : (vertices.empty() ? 0 : vertices.size() - 1); }
};

/// The turn (degrees) above which find_crease_chains splits a chain at a vertex.
constexpr double kCreaseChainMaxTurnDegrees = 60.0;

/// Chains of sharp edges: an edge shared by exactly two triangles is sharp when the angle
/// between the two faces' unit normals exceeds `min_dihedral_degrees` (boundary, non-manifold
/// and zero-area-adjacent edges never are). Chains are split at vertices where the number of
/// incident sharp edges is not 2 (corners, ends) and where the chain turns by more than
/// kCreaseChainMaxTurnDegrees (the angle between the incoming and outgoing edge directions).
/// Walks start at split vertices (increasing id, their sharp edges by increasing neighbour id);
/// a walk that comes back to its start vertex gives a closed chain starting there. Cycles with
/// no split vertex at all follow, each a closed chain starting at its smallest vertex id and
/// continuing towards the smaller of that vertex's two neighbours. Chains with fewer than
/// `min_edges` edges are dropped.
std::vector<CreaseChain> find_crease_chains(const RawMesh& mesh, double min_dihedral_degrees, std::size_t min_edges);

/// Whether a and b are the same cycle of ids, up to rotation and direction.
bool same_cycle(std::vector<std::uint32_t> a, const std::vector<std::uint32_t>& b);

/// Positions of `ids` in `mesh`, in order.
std::vector<Eigen::Vector3d> positions_of(const RawMesh& mesh, const std::vector<std::uint32_t>& ids);

}  // namespace featureline::testing
