// The whole pipeline: initial line, strip, flattening, snake, map back (the paper's Fig. 1).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/feature_strip.h"
#include "engine/initial_line.h"
#include "engine/prepared_mesh.h"
#include "engine/snake.h"

namespace featureline {

struct FeatureLineOptions {
  InitialLineOptions initial;
  StripOptions strip;
  SnakeOptions snake;
  bool refine = true;              ///< false: stop after the initial line
  bool pin_interior_keys = true;   ///< interior keys stay where the user put them
  /// A strip whose flattening folds over near the line is split in two (the paper's remedy for
  /// highly curved lines) until pieces are this short (in line edges).
  int min_piece_edges = 6;
};

struct FeatureLineRequest {
  std::vector<std::uint32_t> keys;
  bool closed = false;
  FeatureLineOptions options;
};

struct StageTimings {
  double initial_ms = 0, strip_ms = 0, flatten_ms = 0, snake_ms = 0, total_ms = 0;
};

struct FeatureLineResult {
  std::vector<std::uint32_t> keys;
  bool closed = false;
  InitialLineResult initial;
  std::vector<Eigen::Vector3d> initial_points;
  /// The refined line on the surface. A closed line does not repeat its first point.
  std::vector<SurfacePoint> refined;
  double refined_length = 0;
  bool refined_by_snake = false;
  int iterations = 0;           ///< snake iterations summed over pieces
  std::size_t strip_faces = 0;  ///< strip triangles summed over pieces
  std::size_t pieces = 0;       ///< pieces refined separately (segments, halves of loops, splits)
  std::size_t splits = 0;       ///< pieces split because their flattening folded over
  StageTimings timings;
  std::vector<std::string> warnings;
};

/// Runs the pipeline on a prepared mesh. Thread-safe: the mesh is only read.
/// \throw InvalidInputError, GeometryError
FeatureLineResult detect_feature_line(const PreparedMesh& mesh, const FeatureLineRequest& request);

/// The surface point sitting exactly on mesh vertex v (barycentric 1 on one face corner).
SurfacePoint surface_point_at_vertex(const PreparedMesh& mesh, std::uint32_t v);

/// Length of a polyline of surface points (closing segment included when `closed`).
double polyline_length(const std::vector<SurfacePoint>& points, bool closed);

}  // namespace featureline
