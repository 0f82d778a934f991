// The whole pipeline: initial line, strip, flattening, snake, map back (the paper's Fig. 1).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/crease_fit.h"
#include "engine/crest_localization.h"
#include "engine/executor.h"
#include "engine/feature_strip.h"
#include "engine/fitted_curve.h"
#include "engine/initial_line.h"
#include "engine/prepared_mesh.h"
#include "engine/snake.h"
#include "engine/trace.h"

namespace featureline {

struct FeatureLineOptions {
  InitialLineOptions initial;
  StripOptions strip;
  SnakeOptions snake;
  CrestOptions crest;              ///< sub-edge localisation of the snake's line (stage 3b)
  TraceOptions trace;              ///< how a line from one key follows its feature (engine/trace.h)
  bool refine = true;              ///< false: stop after the initial line
  /// A piece whose snake line reached its strip's outer rings (beyond 85% of them, or past the
  /// middle of the outermost) is refined again on a strip around the vertices nearest that line,
  /// and the stronger line kept: the initial edge path can cut a bend by more than the strip's
  /// rings (on fine meshes, up to 12 edges), and near its border a snake reads a field cut off
  /// on one side.
  bool second_strip = true;
  /// Interior keys pin the line (the crest localisation may still move it across the line to
  /// the crest: CrestOptions::move_keys)
  bool pin_interior_keys = true;
  /// A strip whose flattening folds over near the line is split in two (the paper's remedy for
  /// highly curved lines) until pieces are this short (in line edges).
  int min_piece_edges = 6;
  /// A piece (between keys) whose initial line runs along crease edges only (engine/curvature.h),
  /// at least this many, is kept exactly, corners included, on meshes whose estimated noise is
  /// below `exact_crease_noise`: a clean crease is the feature, smoothing it only cuts its
  /// bends. 0 refines creases like any other part.
  int exact_crease_edges = 2;
  /// Noise (RMS along the normal, local edge lengths) above which crease vertices are no longer
  /// trusted to lie on the true crease and crease runs are refined by the snake.
  double exact_crease_noise = kNoisyCreaseNoise;
  /// Crease runs on meshes noisier than that are re-fitted along the chain and put back on the
  /// surface (engine/crease_fit.h), and so are runs with unmarked edges on meshes that read clean
  /// (noise unmarks a few crease edges long before the estimate reaches exact_crease_noise);
  /// bandwidth 0 hands them to the snake like any other piece.
  CreaseFitOptions crease_fit;
  /// Never worse: a refined piece whose mean feature strength along it falls below this share
  /// of its initial line's is replaced by the initial line (and reported in `pieces`).
  double keep_initial_below = 0.9;
  /// A smooth space curve fitted beside the surface line, allowed to leave the surface
  /// (engine/fitted_curve.h); off by default.
  FittedCurveOptions fitted;

  /// What detect_feature_line accepts; api/options_table.cpp's limits lie inside.
  static constexpr ValidRange min_piece_edges_range = at_least(2);
};

/// Checks the options detect_feature_line checks before it starts (min_piece_edges) and those
/// its stages check when they run (strip, snake), so options built in code fail up front.
/// \throw InvalidInputError naming the first option out of its range.
void check_feature_line_options(const FeatureLineOptions& options);

struct FeatureLineRequest {
  std::vector<std::uint32_t> keys;
  bool closed = false;
  /// One key: the line is the feature through it, traced both ways (engine/trace.h) instead of
  /// joined between keys; the trace decides whether it is closed.
  bool trace = false;
  FeatureLineOptions options;
  /// Stops the work early with CancelledError when requested (deadline, client gone); null: never.
  const Cancellation* cancel = nullptr;
  /// Where the line's pieces are refined side by side (the server passes its engine pool, whose
  /// idle threads then help); null: default_executor(). The answer is the same on any executor.
  Executor* executor = nullptr;
};

/// Which line a piece of the answer is.
enum class PieceKept {
  refined,     ///< the snake's line (crest-localised when CrestOptions::enabled)
  initial,     ///< the initial line: the snake's was worse, the piece is one edge, or its strip could not be refined
  crease,      ///< an exact crease run of a clean mesh, as it is
  crease_fit,  ///< a noisy crease run re-fitted by engine/crease_fit.h
};
template <>
struct EnumNames<PieceKept> {
  static constexpr std::array<std::pair<PieceKept, const char*>, 4> entries{{{PieceKept::refined, "refined"},
                                                                            {PieceKept::initial, "initial"},
                                                                            {PieceKept::crease, "crease"},
                                                                            {PieceKept::crease_fit, "crease fit"}}};
};

/// How one piece of the line (between pinned points) was produced.
struct PieceReport {
  std::uint32_t from = 0, to = 0;  ///< mesh vertices at its ends
  std::size_t edges = 0;           ///< initial line edges in it
  PieceKept kept = PieceKept::refined;
  std::string reason;              ///< why the initial line was kept
  int iterations = 0;              ///< snake iterations, on both strips when second_strip
  bool iteration_cap = false;      ///< the snake stopped at its iteration cap, not converged
  /// Its line is the snake's on a second strip, taken around the vertices nearest the first
  /// snake's line when that line reached its strip's outer rings (FeatureLineOptions::second_strip).
  bool second_strip = false;
  /// The strip held no feature (SnakeOptions::featureless_below): the snake only smoothed the
  /// initial line, in at most featureless_iterations
  bool featureless = false;
  double initial_strength = 0;     ///< mean feature strength along the initial line
  double refined_strength = 0;     ///< ... along the snake's line (0 when not refined)
};

struct StageTimings {
  double initial_ms = 0, strip_ms = 0, flatten_ms = 0, snake_ms = 0, total_ms = 0;
};

struct FeatureLineResult {
  /// The line's keys: the request's, or for a traced line its ends (a closed one: its first
  /// vertex and the vertex half way round).
  std::vector<std::uint32_t> keys;
  bool closed = false;
  std::optional<TraceResult> trace;  ///< how a traced line was found
  InitialLineResult initial;
  std::vector<Eigen::Vector3d> initial_points;
  /// The refined line on the surface. A closed line does not repeat its first point.
  std::vector<SurfacePoint> refined;
  double refined_length = 0;
  /// Per key, where the refined line passes it: the point the crest localisation moved it to
  /// (CrestOptions::move_keys) or its vertex; an interior key left unpinned (pin_interior_keys
  /// false): the refined point nearest it.
  std::vector<Eigen::Vector3d> key_points;
  std::vector<double> key_moves;  ///< per key, the distance from its vertex to key_points (mesh units)
  bool refined_by_snake = false;
  int iterations = 0;           ///< snake iterations summed over pieces
  std::size_t strip_faces = 0;  ///< strip triangles summed over pieces
  std::size_t pieces = 0;       ///< pieces refined separately (segments, halves of loops, splits)
  std::size_t splits = 0;       ///< pieces split because their flattening folded over
  std::vector<PieceReport> piece_reports;  ///< one per piece, in line order
  StageTimings timings;
  std::vector<std::string> warnings;
  /// The fitted space curve, when FeatureLineOptions::fitted.enabled (its time is its own, not
  /// in `timings`).
  std::optional<FittedCurveResult> fitted;
};

/// Runs the pipeline on a prepared mesh. Thread-safe: the mesh is only read.
/// \throw InvalidInputError, GeometryError
FeatureLineResult detect_feature_line(const PreparedMesh& mesh, const FeatureLineRequest& request);

/// Mean feature strength (feature value of the line's sign over the curvature scale, capped
/// at `cap`) along a polyline of surface points, weighted by arc length; values inside faces
/// are interpolated barycentrically. The "never worse" test compares lines with it.
double mean_feature_strength(const PreparedMesh& mesh, const std::vector<SurfacePoint>& points, double feature_sign,
                             double cap);

/// Length of a polyline of surface points (closing segment included when `closed`).
double polyline_length(const std::vector<SurfacePoint>& points, bool closed);

}  // namespace featureline
