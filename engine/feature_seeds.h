// Where a feature line could start: the mesh's crease chains and its strongest smooth ridge and
// valley vertices, found from the prepared mesh alone, so a user (the CLI, a script, a client
// without the browser page) can choose key vertices without picking them on screen.
//
// Crease chains follow the prepared mesh's crease edges (engine/curvature.h) of one sign; the
// smooth seeds are crests of its feature field (the paper's curvature field C, as the jet fit
// and smoothing left it), kept apart by non-maximum suppression and kept above the curvature
// the estimated noise alone could give. Nothing here re-derives curvature or creases.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "engine/cancellation.h"
#include "engine/enum_names.h"
#include "engine/prepared_mesh.h"
#include "engine/valid_range.h"

namespace featureline {

/// The two kinds of feature, with the engine's sign convention (+1 convex, -1 concave).
enum class FeatureSign : int {
  ridge = 1,    ///< convex: a convex crease, or a crest of k_max > 0
  valley = -1,  ///< concave: a concave crease, or a crest of -k_min > 0
};
template <>
struct EnumNames<FeatureSign> {
  static constexpr std::array<std::pair<FeatureSign, const char*>, 2> entries{
      {{FeatureSign::ridge, "ridge"}, {FeatureSign::valley, "valley"}}};
};

/// Where creases meet, the branch a line or chain goes on along turns at least this many degrees
/// less than any rival (FeatureSeedOptions::junction_turn, TraceOptions::follow_junctions);
/// otherwise which branch is meant is the user's choice.
constexpr double kJunctionMarginDegrees = 15;

struct FeatureSeedOptions {
  /// At most this many crease chains are returned (the longest first); 0 returns none.
  int max_crease_chains = 64;
  /// Chains of fewer edges are left out: the stubs where creases meet at a corner and single
  /// sharp edges of a coarse tessellation say little about where a line runs.
  int min_chain_edges = 3;
  /// A chain is split at a vertex where it turns by more than this many degrees between its two
  /// edges there (a sharp corner of one crease); 180 splits only at junctions.
  double corner_angle = 60;
  /// Where three or more crease edges of one sign meet (a junction), a chain goes on through the
  /// two that turn least, when they turn by at most this many degrees and every other edge
  /// turns kJunctionMarginDegrees more from either (noise marking a face's second edge beside the
  /// crease is no rival), as a traced line goes on through a junction (engine/trace.h): a T's
  /// straight crease is one chain, and on a noisy scan a crease is not cut wherever noise marks
  /// an edge beside it. 0 splits every chain at every junction.
  double junction_turn = 45;
  /// At most this many ridge vertices, and as many valley vertices, are returned (the strongest
  /// first); 0 returns none.
  int max_vertices_per_sign = 32;
  /// Seeds of one sign are further apart than this many local edge lengths (of the stronger
  /// seed): non-maximum suppression, so the seeds spread over the features instead of crowding
  /// on the strongest one.
  double spacing = 8;
  /// Ridge and valley vertices are more than this many rings of edges away from a crease and
  /// from the boundary: there the curvature fit sees one side only (on CAD tessellations and
  /// scan defects the field peaks beside every crease), and the crease is a chain already.
  int crease_clearance = 2;
  /// A seed's feature value is at least this share of the mesh's curvature scale (the 90th
  /// percentile of the feature value, PreparedMesh::curvature_scale).
  double min_strength = 0.5;
  /// A seed bends the surface, over the jet fit's radius R (local edge lengths h), by at least
  /// this many times the estimated noise sigma: k R^2 h^2 / 2 >= min_signal_to_noise * sigma h.
  /// A noisy flat mesh then has no seed (its curvatures are far below that floor); on clean
  /// meshes sigma is near 0 and the floor with it. 0 turns the floor off.
  double min_signal_to_noise = 8;

  /// What find_feature_seeds accepts; api/options_table.cpp's limits lie inside.
  static constexpr ValidRange max_crease_chains_range = finite_from(0);
  static constexpr ValidRange min_chain_edges_range = finite_from(1);
  static constexpr ValidRange corner_angle_range = closed_range(0, 180);
  static constexpr ValidRange junction_turn_range = closed_range(0, 180);
  static constexpr ValidRange max_vertices_per_sign_range = finite_from(0);
  static constexpr ValidRange spacing_range = finite_from(0);
  static constexpr ValidRange crease_clearance_range = finite_from(0);
  static constexpr ValidRange min_strength_range = finite_from(0);
  static constexpr ValidRange min_signal_to_noise_range = finite_from(0);
};

/// \throw InvalidInputError when an option is outside its range (FeatureSeedOptions::*_range).
void check_feature_seed_options(const FeatureSeedOptions& options);

/// A maximal chain of crease edges of one sign.
struct CreaseChainSeed {
  /// Vertex ids in order, consecutive ids joined by crease edges of `sign`. An open chain runs
  /// from its lower-id end; a closed one does not repeat its first vertex (its closing edge is
  /// last -> first).
  std::vector<std::uint32_t> vertices;
  bool closed = false;
  FeatureSign sign = FeatureSign::ridge;
  double length = 0;            ///< sum of its edges' lengths (closing edge included)
  double dihedral_degrees = 0;  ///< mean dihedral angle of its edges, weighted by edge length
  std::size_t edges() const { return closed ? vertices.size() : vertices.empty() ? 0 : vertices.size() - 1; }
};

/// A vertex on the crest of the smooth feature field of one sign.
struct FeatureVertexSeed {
  std::uint32_t vertex = 0;
  FeatureSign sign = FeatureSign::ridge;
  /// The principal curvature the feature is made of: k_max (> 0) on ridges, k_min (< 0) in valleys.
  double curvature = 0;
  /// |curvature| over the mesh's curvature scale (1: the 90th percentile of the feature value).
  double strength = 0;
  /// Unit tangent of the crest through the vertex (the direction along which the feature field
  /// falls slowest), sign chosen so its largest component is positive; std::nullopt where the
  /// field falls about as fast every way (an isolated peak, not a line).
  std::optional<Eigen::Vector3d> direction;
};

/// What the search saw, for reports and for tuning the options.
struct FeatureSeedStatistics {
  std::size_t crease_chains = 0;  ///< chains of at least min_chain_edges edges, before the cap
  std::size_t short_chains = 0;   ///< chains left out for having fewer edges
  /// Vertices where three or more crease edges of one sign meet, counted per sign.
  std::size_t junctions = 0;
  /// Vertices of two crease edges of one sign split for turning by more than corner_angle.
  std::size_t corners = 0;
  /// Vertices clear of creases and the boundary whose feature value passes both floors, per sign.
  std::size_t ridge_candidates = 0, valley_candidates = 0;
  /// The noise floor (min_signal_to_noise) as a strength at the mesh's mean edge length; 0 when
  /// the noise is not estimated (cotangent curvature) or the floor is off.
  double noise_floor_strength = 0;
  double elapsed_ms = 0;
};

struct FeatureSeeds {
  std::vector<CreaseChainSeed> crease_chains;      ///< longest first (ties: lower first vertex)
  std::vector<FeatureVertexSeed> ridge_vertices;   ///< strongest first (ties: lower id)
  std::vector<FeatureVertexSeed> valley_vertices;  ///< strongest first (ties: lower id)
  FeatureSeedStatistics stats;
};

/// Crease chains and ridge and valley seeds of `mesh`.
///
/// Crease chains: the crease edges of each sign (PreparedMesh::curvature.crease) joined into
/// maximal chains, split at vertices where the number of crease edges of that sign is not 2
/// (unless a junction's straightest pair goes on, options.junction_turn) and where the chain
/// turns by more than options.corner_angle. A cycle with no such vertex is one
/// closed chain from its lowest vertex id; a walk that returns to its split vertex is closed too.
///
/// Ridge and valley seeds: vertices more than crease_clearance rings from creases and the
/// boundary whose feature value
/// (feature_value of their sign) passes min_strength and the noise floor, and which lie on a
/// crest of that field: a quadratic fitted to the field over their two rings (not across
/// creases) falls across the crest faster than it rises along it and peaks within half an edge
/// of the vertex, and no vertex across the crest in those rings is more than 10% stronger.
/// Taken strongest first, each at least `spacing` local edge lengths from the seeds already taken.
///
/// Work is linear in the mesh (the candidates are sorted; each is compared with at most
/// max_vertices_per_sign seeds and fitted once); the same mesh and options give the same answer.
/// \throw InvalidInputError for options out of range; CancelledError once `cancel` is requested.
FeatureSeeds find_feature_seeds(const PreparedMesh& mesh, const FeatureSeedOptions& options = {},
                                const Cancellation* cancel = nullptr);

}  // namespace featureline
