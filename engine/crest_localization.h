// Stage 3b: sub-edge crest localisation. The snake (stage 3) settles where its image force
// balances its elasticity and rigidity, and its force is interpolated from per-vertex values, so
// on a smooth ridge it stops a tenth of an edge or more from the crest, and inside bends. This
// stage then places each point of the snake's line at the extremum of the feature field across
// the line, found inside triangles: a weighted quadratic fit of the field over the strip's
// vertices around the point (in the flattened strip's plane), whose maximum along the line's
// normal is the crest there, as image edge detectors fit a parabola across an edge for sub-pixel
// positions. Across a bent crest the fit measures from the line's own bend, so the bend is not
// read as an offset. The offsets, not the positions, are then smoothed along the line, so noise
// does not come back and a curved crest is not cut inside its bend. The line's ends (its keys)
// move to the crest too (move_keys): a key is a vertex picked near the feature, not on it.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "engine/feature_strip.h"
#include "engine/prepared_mesh.h"
#include "engine/snake.h"
#include "engine/valid_range.h"

namespace featureline {

struct CrestOptions {
  bool enabled = true;      ///< false: the snake's line as it settled (the paper's)
  /// Fit neighbourhood radius, in the strip's mean edge lengths: the crest's half width as fits
  /// at max(radius, the jet radius) measure it, within [the jet radius, max_radius] (and within
  /// the strip); without jets (the cotangent field) within [radius, max_radius]. A strip narrower
  /// than that is fitted across its whole width at estimated noise 0.03-0.09 (if 3 edges or more).
  double radius = 3.0;
  double max_radius = 8.0;
  double max_shift = 0.5;   ///< largest move of a point across the line, in the strip's mean edge lengths
  /// Largest move of a pinned end (a key) across the line. The snake brings the other points to
  /// within max_shift of the crest; a key stays on the vertex picked, and the vertex nearest a
  /// crest can lie further from it than half an edge (up to a triangle's circumradius).
  double max_key_shift = 1.0;
  int smoothing_passes = 4; ///< (1, 2, 1)/4 passes over the offsets along the line
  /// The line's pinned ends (its keys, and where a piece was split) move across the line to the
  /// crest too, within max_shift: a key is a vertex picked near the feature, and the line passes
  /// through the crest point nearest it. On a noisy mesh's crease runs the keys are re-fitted with
  /// the run (engine/crease_fit.h), as noisy as its other vertices. false: they stay on their
  /// vertices (the paper's pins).
  bool move_keys = true;
  /// Fits measure across the line from its bend (over three fit radii), so a bent crest is not
  /// read as an offset into the bend, on meshes whose estimated noise is below 0.09 local edge
  /// lengths (noisier, the line's bend follows its wander more than the crest's). false: from
  /// its tangent.
  bool follow_bend = true;
  /// Takes the field's blur out of bends. The jets and smoothing passes that make the field blur
  /// it, which moves the crest of a bent feature into its bend by sigma^2 / (2 R) to first order
  /// (sigma^2: the blur's variance per axis, R: the bend's radius); each point then moves three
  /// quarters of that out of the line's bend, on meshes whose field was smoothed (estimated noise
  /// 0.005 and more) and whose noise is under 0.09 local edge lengths, where the bend is gentle against the blur (sigma / R at most 0.1) and the blur
  /// narrow against the crest (sigma at most 0.75 of the fitted profile's half width), where the
  /// first-order shift holds (accuracy.md). From a noise of 0.05 the bend is the localised line's
  /// over ten fit radii (the snake's line wanders with the noisy field's crest).
  /// false: the field's crest is kept.
  bool unblur = true;

  static constexpr ValidRange radius_range = closed_range(1, 12);
  static constexpr ValidRange max_shift_range = closed_range(0, 2);
  static constexpr ValidRange max_key_shift_range = closed_range(0, 2);
  static constexpr ValidRange smoothing_passes_range = closed_range(0, 50);
};

/// \throw InvalidInputError when an option is outside its range.
void check_crest_options(const CrestOptions& options);

/// What one end of the line may do.
struct CrestEnd {
  bool movable = false;              ///< may move to the crest (with CrestOptions::move_keys)
  std::optional<StripPoint> placed;  ///< already placed (the piece on its other side moved it): it goes there
};

struct CrestResult {
  std::vector<StripPoint> points;  ///< the line; its ends moved only as `ends` allowed
  std::size_t moved = 0;           ///< points whose fit found a crest within max_shift, or placed ends
};

/// Moves the points of `points` (a line on the flattened strip) across the line to the crest of
/// the feature field of sign `feature_sign` (feature_value), as described above; its two ends
/// (front, back) only as `ends` says.
CrestResult localize_crest(const PreparedMesh& mesh, const FeatureStrip& strip, const FlatStrip& flat,
                           const std::vector<StripPoint>& points, double feature_sign, const CrestOptions& options = {},
                           const std::array<CrestEnd, 2>& ends = {});

}  // namespace featureline
