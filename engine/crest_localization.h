// Stage 3b: sub-edge crest localisation. The snake (stage 3) settles where its image force
// balances its elasticity and rigidity, and its force is interpolated from per-vertex values, so
// on a smooth ridge it stops a tenth of an edge or more from the crest, and inside bends. This
// stage then places each point of the snake's line at the extremum of the feature field across
// the line, found inside triangles: a weighted quadratic fit of the field over the strip's
// vertices around the point (in the flattened strip's plane), whose maximum along the line's
// normal is the crest there, as image edge detectors fit a parabola across an edge for sub-pixel
// positions. The offsets, not the positions, are then smoothed along the line, so noise does not
// come back and a curved crest is not cut inside its bend.
#pragma once

#include <vector>

#include "engine/feature_strip.h"
#include "engine/prepared_mesh.h"
#include "engine/snake.h"
#include "engine/valid_range.h"

namespace featureline {

struct CrestOptions {
  bool enabled = true;      ///< false: the snake's line as it settled (the paper's)
  /// Fit neighbourhood radius, in the strip's mean edge lengths: the crest's half width as fits
  /// at `radius` measure it, within [radius, max_radius] (and within the strip).
  double radius = 3.0;
  double max_radius = 8.0;
  double max_shift = 0.5;   ///< largest move of a point across the line, in the strip's mean edge lengths
  int smoothing_passes = 4; ///< (1, 2, 1)/4 passes over the offsets along the line

  static constexpr ValidRange radius_range = closed_range(1, 12);
  static constexpr ValidRange max_shift_range = closed_range(0, 2);
  static constexpr ValidRange smoothing_passes_range = closed_range(0, 50);
};

/// \throw InvalidInputError when an option is outside its range.
void check_crest_options(const CrestOptions& options);

struct CrestResult {
  std::vector<StripPoint> points;  ///< the line, ends unchanged
  std::size_t moved = 0;           ///< interior points whose fit found a crest within max_shift
};

/// Moves the interior points of `points` (a line on the flattened strip, ends pinned) across the
/// line to the crest of the feature field of sign `feature_sign` (feature_value), as described above.
CrestResult localize_crest(const PreparedMesh& mesh, const FeatureStrip& strip, const FlatStrip& flat,
                           const std::vector<StripPoint>& points, double feature_sign, const CrestOptions& options = {});

}  // namespace featureline
