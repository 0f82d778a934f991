// A fitted space curve beside the surface line: the feature estimated from the line's
// neighbourhood and allowed to leave the (noisy) surface, as reverse-engineering tools give
// their feature curves.
//
// Every line the pipeline answers lies on the mesh (segmentation cuts along it). On a noisy scan
// of a CAD part the true crease lies off the noisy surface, so no line on it gets closer than the
// surface floor (bench_accuracy: 0.72-0.84 of the initial line's distance at 10% noise). The
// paper stops at the surface line; this stage goes further, from the vertices around the line:
//  - at a crease (marked crease edges of the line's sign near it) the two sides are fitted by
//    planes (Gaussian-weighted, re-weighted least squares, vertices re-assigned to the nearer
//    plane) and the crease point is the point of their intersection nearest the surface line,
//    moved toward the line's own point as far as the two agree within the noise;
//  - elsewhere (a smooth ridge: no two distinct sides) a quadric height field is fitted across
//    the line and the point is put on it, which removes the noise along the normal and keeps
//    the surface line's place across it (the crest was already located inside triangles);
//  - where a fit is ill-conditioned or refused (sides nearly coplanar, too few vertices, residuals
//    above the noise, a fitted point far from the line, a sharp bend of the line within the
//    radius) and on exact crease runs of a clean mesh, the surface line's own point is kept.
// On a noisy mesh's crease runs those points are then averaged along the line over windows chosen
// point by point (engine/line_averaging.h): long where the crease runs straight, short near its
// bends. A mesh with no vertex off its creases (a CAD exporter's skinny tessellation) reads no
// noise; there the runs' own scatter about a smooth curve says whether they are noisy. A
// penalised cubic B-spline (Eilers and Marx's P-spline: uniform knots, a second-difference
// penalty on the control points, re-weighted against outlying points) is fitted through the
// points with a stated spacing of control points, split at corners of the line, and sampled as a
// polyline; the averaged points stand as they are (the spline's penalty would round the crease's
// bends again). Measured against the truth in docs/accuracy.md#the-fitted-curve: far
// closer than the surface line where the line lies off a well-sampled crease, two thirds of the
// initial line's distance on noisy CAD parts.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/prepared_mesh.h"
#include "engine/surface_point.h"
#include "engine/valid_range.h"

namespace featureline {

struct FittedCurveOptions {
  bool enabled = false;  ///< compute the fitted curve (FeatureLineResult::fitted)
  /// Radius of the neighbourhood fitted around each point of the line, in local edge lengths:
  /// wide enough to average the noise of a few dozen vertices per side, narrow enough that a
  /// side is nearly planar and a neighbouring feature rarely falls in. On a noisy mesh a marked
  /// crease's sides are fitted over a neighbourhood three times as long along the line.
  double radius = 3.0;
  /// Distance between the spline's control points along the line, in the line's mean local
  /// edge length (the answer reports it as control points per unit length).
  double control_spacing = 2.0;
  /// Weight of the second-difference penalty on the control points, relative to the data
  /// weight per control point; 0: least squares on the control points alone.
  double smoothing = 1.0;
  /// Two fitted sides closer than this to coplanar (the angle between their normals, degrees)
  /// are no crease: the surface fit is used there.
  double min_dihedral = 10.0;
  /// A fitted point further than this from the surface line (local edge lengths) is not
  /// trusted: the surface line's point is used there.
  double max_shift = 1.5;
  /// The spline is split where the line turns by more than this within about an edge
  /// (degrees): a corner of creases is kept, not rounded.
  double corner_angle = 45.0;
  /// On a noisy mesh's crease runs, each point is averaged along the line over the widest window
  /// whose estimate agrees with every narrower one within this many of its standard deviations
  /// (engine/line_averaging.h); 0: the spline alone.
  double run_averaging = 0.7;

  static constexpr ValidRange radius_range = closed_range(1.5, 12);
  static constexpr ValidRange control_spacing_range = closed_range(0.5, 50);
  static constexpr ValidRange smoothing_range = closed_range(0, 1000);
  static constexpr ValidRange min_dihedral_range = closed_range(0, 90);
  static constexpr ValidRange max_shift_range = closed_range(0.1, 10);
  static constexpr ValidRange corner_angle_range = closed_range(10, 180);
  static constexpr ValidRange run_averaging_range = closed_range(0, 10);
};

/// \throw InvalidInputError naming the first option outside its range.
void check_fitted_curve_options(const FittedCurveOptions& options);

struct FittedCurveResult {
  /// The curve sampled about every half local edge; a closed curve does not repeat its first point.
  std::vector<Eigen::Vector3d> points;
  bool closed = false;
  double length = 0;                 ///< of the polyline (closing segment included when closed)
  std::size_t control_points = 0;    ///< summed over the spline's pieces
  /// Distance between control points (the option in model units; a piece rounds it so its
  /// length holds a whole number of intervals).
  double control_spacing = 0;
  std::size_t corners = 0;           ///< where the spline was split
  /// Shares of the curve's points by where they came from: crease planes, the surface fit, an
  /// exact crease run of a clean mesh kept as it is, and the surface line itself where the fits
  /// were refused or ill-conditioned (the fallback). They sum to 1.
  double crease_share = 0, surface_share = 0, exact_share = 0, fallback_share = 0;
  /// Share of the curve's points averaged along a noisy mesh's crease run (whatever their source).
  double averaged_share = 0;
  double elapsed_ms = 0;
};

/// The surface line a curve is fitted beside.
struct FittedCurveLine {
  std::vector<SurfacePoint> points;  ///< in order; a closed line does not repeat its first point
  bool closed = false;
  double feature_sign = 0;           ///< +1 ridge, -1 valley, 0 any
  /// Per point, whether it lies on the feature itself (an exact crease run of a clean mesh: the
  /// crease is the mesh's own edges there, and the curve keeps it). Empty: no point is.
  std::vector<char> exact;
  /// Per point, whether it lies on a crease run of a noisy mesh (re-fitted by engine/crease_fit.h):
  /// the curve's points there are averaged along the line. Empty: none is.
  std::vector<char> noisy_crease;
  /// The line's own edge length (its initial line's mean edge), the unit of the stations, the
  /// control points and the fits; local edges can be far longer (a CAD part's long cap
  /// diagonals). 0: the mean local edge length along the line.
  double edge_length = 0;
};

/// Fits the curve beside `line` as the module comment says.
/// \throw InvalidInputError when an option is outside its range.
FittedCurveResult fit_feature_curve(const PreparedMesh& mesh, const FittedCurveLine& line,
                                    const FittedCurveOptions& options = {});

}  // namespace featureline
