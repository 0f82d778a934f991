// A feature line from one click: the ridge, valley or crease through a vertex, followed both
// ways until it ends, closes on itself, reaches the boundary or meets a junction of creases.
// The traced path replaces stage 1 (the initial line through keys); strip, snake and the
// guards then refine it like any other line (engine/feature_line.h).
//
// Creases are followed edge by edge along the crease edges of the seed's sign (through a
// junction along the branch that turns least, when it turns little); gaps that noise opens in a
// crease chain are bridged when the chain resumes a few edges ahead. Smooth ridges and valleys
// are followed by steps of a few edge lengths: ahead of the current vertex, the strongest
// vertex of the feature field across the path is the next crest point (re-centring on the
// field's maximum after each step), joined by the feature-weighted edge path.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "engine/cancellation.h"
#include "engine/enum_names.h"
#include "engine/feature_seeds.h"
#include "engine/prepared_mesh.h"
#include "engine/valid_range.h"

namespace featureline {

/// Which feature a trace follows.
enum class TraceSign {
  automatic,  ///< a crease's sign when the click is near a crease; else the sign of the larger curvature
  ridge,
  valley,
};
template <>
struct EnumNames<TraceSign> {
  static constexpr std::array<std::pair<TraceSign, const char*>, 3> entries{
      {{TraceSign::automatic, "auto"}, {TraceSign::ridge, "ridge"}, {TraceSign::valley, "valley"}}};
};

/// Why one end of a traced line is where it is.
enum class TraceStop {
  closed,       ///< the two ends met: the line is a loop
  feature_end,  ///< the feature fades (smooth: below the stop strength; crease: the chain ends)
  boundary,     ///< the mesh's boundary
  junction,     ///< creases meet and no branch continues the line (or junctions are not followed)
  line_met,     ///< the line ran into itself away from its other end
  max_edges,    ///< the line reached its length limit
};
template <>
struct EnumNames<TraceStop> {
  static constexpr std::array<std::pair<TraceStop, const char*>, 6> entries{{{TraceStop::closed, "closed"},
                                                                            {TraceStop::feature_end, "feature-end"},
                                                                            {TraceStop::boundary, "boundary"},
                                                                            {TraceStop::junction, "junction"},
                                                                            {TraceStop::line_met, "line-met"},
                                                                            {TraceStop::max_edges, "max-edges"}}};
};

struct TraceOptions {
  TraceSign sign = TraceSign::automatic;
  /// The longest traced line, in edges (also bounded by the initial line's max_edges).
  int max_edges = 1000;
  /// A smooth step whose mean feature value falls below this share of the seed's ends the trace.
  double stop_strength = 0.3;
  /// ... and so does one whose feature bends the surface, over the jet fit's radius R (local edge
  /// lengths h), by less than this many times the estimated noise sigma: k R^2 h^2 / 2 < m sigma h
  /// (the floor FeatureSeedOptions::min_signal_to_noise sets for seeds). 0 turns it off.
  double min_signal_to_noise = 4;
  /// Length of a smooth step, in local edge lengths: longer steps ride over noise, shorter ones
  /// follow tighter bends.
  double step = 3;
  /// The most a smooth step may turn from the line's direction, and the most a crease may turn at
  /// a junction for the trace to continue along it, degrees.
  double max_turn = 45;
  /// At a junction of creases, continue along the branch that turns least (when it turns at most
  /// max_turn and clearly less than the others); false stops at every junction.
  bool follow_junctions = true;
  /// A crease chain that breaks off (noise unmarks some of its edges) is continued when a crease
  /// vertex of its sign lies within this many edges ahead; 0 never bridges.
  int max_gap_edges = 3;
  /// The clicked vertex moves to a crease within this many rings of edges, or else up the feature
  /// field for at most this many edges, before the trace starts.
  int snap_rings = 2;

  static constexpr ValidRange max_edges_range = finite_from(2);
  static constexpr ValidRange stop_strength_range = closed_range(0, 0.99);
  static constexpr ValidRange min_signal_to_noise_range = closed_range(0, 100);
  static constexpr ValidRange step_range = closed_range(1, 10);
  static constexpr ValidRange max_turn_range = closed_range(0, 90);
  static constexpr ValidRange max_gap_edges_range = closed_range(0, 10);
  static constexpr ValidRange snap_rings_range = closed_range(0, 10);
};

/// \throw InvalidInputError naming the first option outside its range (TraceOptions::*_range).
void check_trace_options(const TraceOptions& options);

struct TraceEnd {
  std::uint32_t vertex = 0;
  TraceStop reason = TraceStop::feature_end;
};

/// A vertex where three or more crease edges of the line's sign meet.
struct TraceJunction {
  std::uint32_t vertex = 0;
  std::size_t branches = 0;  ///< crease edges of the sign at the vertex
  bool followed = false;     ///< the line continues through it (false: an end of the line)
};

struct TraceResult {
  std::uint32_t clicked = 0;  ///< the vertex the trace was asked from
  std::uint32_t seed = 0;     ///< where it started, after snapping to the feature
  FeatureSign sign = FeatureSign::ridge;
  bool on_crease = false;  ///< the seed is on a crease of the sign
  /// Vertex ids along the line; consecutive ids are mesh edges. A closed line does not repeat
  /// its first vertex.
  std::vector<std::uint32_t> vertices;
  bool closed = false;
  /// The ends of the line: ends[0] at vertices.front(), ends[1] at vertices.back(); a closed
  /// line's ends are both `closed`, at its first vertex.
  std::array<TraceEnd, 2> ends;
  std::vector<TraceJunction> junctions;  ///< met along the line, in the order found
  double seed_strength = 0;  ///< the seed's feature value over the mesh's curvature scale
  std::size_t steps = 0;     ///< steps taken (crease edges and smooth steps)
  double length = 0;         ///< sum of the edge lengths (closing edge included)
  double elapsed_ms = 0;
};

/// The feature through `vertex`, traced both ways (see the file comment).
///
/// Work is bounded by options.max_edges steps, each searching a disc of a few edge lengths.
/// \throw InvalidInputError for options out of range or a vertex id out of range;
///        GeometryError when there is no feature to follow at the vertex (no crease within
///        snap_rings, and the field there is below the noise floor or no crest: it falls across
///        by less than 5% within two edge lengths) or the line would be a single vertex;
///        CancelledError once `cancel` is requested.
TraceResult trace_feature(const PreparedMesh& mesh, std::uint32_t vertex, const TraceOptions& options = {},
                          const Cancellation* cancel = nullptr);

}  // namespace featureline
