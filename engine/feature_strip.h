// Stage 2: the feature strip around the initial line and its flattening into the plane
// (the paper's "Parameterization of feature strip", Eq. 11 and Fig. 5).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/enum_names.h"
#include "engine/line_context.h"
#include "engine/prepared_mesh.h"
#include "engine/valid_range.h"

namespace featureline {

/// How the strip is laid out in the plane.
enum class StripFlattening {
  /// The paper (Fig. 5): the line laid out with its edge lengths and turning angles, then the
  /// other vertices placed outwards ring by ring by similar triangles. Errors compound with
  /// every ring: on 20%-noisy meshes a third of an 8-ring strip's triangles come out more
  /// than 35% stretched and are left out of the snake's domain (bench_accuracy).
  similar_triangles,
  /// Least-squares conformal map of the whole strip at once (one sparse solve): every
  /// triangle as close to similar to its 3D shape as all the others allow, so noise spreads
  /// out instead of compounding.
  conformal,
  /// similar_triangles where it drops at most StripOptions::max_dropped_share of the strip's
  /// triangles from the snake's domain (max_dropped_share_noisy on noisy meshes; clean meshes:
  /// it is exact on developable strips and cheaper), conformal elsewhere.
  automatic,
};
template <>
struct EnumNames<StripFlattening> {
  static constexpr std::array<std::pair<StripFlattening, const char*>, 3> entries{
      {{StripFlattening::automatic, "automatic"},
       {StripFlattening::conformal, "conformal"},
       {StripFlattening::similar_triangles, "similar-triangles"}}};
};

struct StripOptions {
  StripFlattening flattening = StripFlattening::automatic;
  /// Rings of the strip around the line (the paper's k). 0 chooses from the line's length in
  /// edges: 2 below `dense_line_edges`, 3 from it, 4 from twice, 6 from four, 8 from eight times it.
  int rings = 0;
  int dense_line_edges = 12;
  /// A flattened triangle whose edge lengths differ from the surface's by more than this
  /// fraction is left out of the snake's domain. Averaging the placements of a vertex that
  /// closes many triangles with the line (the centre of a fan, a cone tip) can distort its
  /// triangles arbitrarily; the snake must not be steered by them.
  double max_edge_distortion = 0.35;

  /// What the strip accepts (check_strip_options); api/options_table.cpp's limits lie inside.
  static constexpr int max_rings = 8;
  static constexpr ValidRange rings_range = closed_range(0, max_rings);
  /// StripFlattening::automatic keeps the paper's layout while it drops at most this share of
  /// the strip's triangles from the snake's domain (flatten_strip says why these values).
  static constexpr double max_dropped_share = 0.05;
  static constexpr double max_dropped_share_noisy = 0.03;
};

/// \throw InvalidInputError when an option is outside its range (StripOptions::*_range).
void check_strip_options(const StripOptions& options);

/// A strip of the mesh around an open line, with its own compact indices.
struct FeatureStrip {
  std::vector<std::uint32_t> vertices;                   ///< mesh vertex id of each local vertex
  std::vector<int> ring;                                 ///< topological distance of each local vertex to the line
  /// Index in `line` of the line vertex each local vertex was first reached from (its own for
  /// the line's vertices): where along the line it lies.
  std::vector<std::uint32_t> line_position;
  std::vector<std::array<std::uint32_t, 3>> triangles;   ///< local indices, the mesh's orientation
  std::vector<std::uint32_t> faces;                      ///< mesh face id of each local triangle
  /// Neighbouring local triangle across the edge opposite corner k, or -1 at the strip's border.
  std::vector<std::array<std::int32_t, 3>> triangle_neighbors;
  std::vector<std::uint32_t> line;                       ///< local indices of the line's vertices, in order
  int rings = 0;
  double mean_edge_length = 0;                           ///< over the strip's triangles
  double mean_squared_edge_length = 0;                   ///< over the strip's triangles
};

/// The k-ring meshes of the line's vertices (faces whose three vertices are all within k rings).
/// \pre `line` is a simple open path of mesh vertices (consecutive ones adjacent).
FeatureStrip extract_feature_strip(const PreparedMesh& mesh, const std::vector<std::uint32_t>& line,
                                   const StripOptions& options = {});

struct FlatStrip {
  std::vector<Eigen::Vector2d> uv;   ///< plane position of each local vertex (unplaced: NaN)
  std::vector<char> placed;          ///< whether each local vertex got a position
  std::vector<char> triangle_valid;  ///< triangle has all corners placed and positive area
  std::size_t flipped_triangles = 0; ///< placed triangles whose orientation reversed (fold-overs)
  std::size_t distorted_triangles = 0;  ///< triangles left out for exceeding max_edge_distortion
  std::size_t flipped_near_line = 0; ///< of those, how many touch the line (these break the snake)
  std::size_t first_flip_line_index = 0;  ///< index in `line` of the first flip touching it, where to split
};

/// Lays the strip out in the plane (StripOptions::flattening), then marks the triangles the
/// snake may use: placed, not folded over, edges within max_edge_distortion of their 3D
/// lengths. On a line whose context says the mesh is noisy the automatic layout solves strips
/// the paper's layout drops max_dropped_share_noisy of, instead of max_dropped_share.
FlatStrip flatten_strip(const PreparedMesh& mesh, const FeatureStrip& strip, const StripOptions& options,
                        const LineContext& line);

/// The plane polyline of the line's vertices, turning angles from the surface (exposed for tests).
std::vector<Eigen::Vector2d> embed_line(const PreparedMesh& mesh, const std::vector<std::uint32_t>& line);

}  // namespace featureline
