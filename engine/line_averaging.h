// Averaging noisy points along a line with a window chosen point by point.
//
// A noisy crease run's points scatter about the true crease by errors that are independent from
// edge to edge, so averaging them along the line cuts the noise; but a window longer than the
// stretch over which the crease is nearly a parabola bends it off (a plain smoothing spline
// rounds a CAD part's curved crease by more than the noise it removes: bench_accuracy, noisy CAD,
// 0.80 -> 1.01 of the initial line's distance). Each point is therefore the local quadratic
// regression of its neighbours against arc length (Gaussian weights; a quadratic follows a bend
// without the shrinking bias of a plain average), over the widest of a ladder of bandwidths whose
// estimate still agrees, within `confidence` standard deviations, with every narrower one: the
// intersection of confidence intervals rule (Goldenshluger and Nemirovski 1997, Katkovnik 1999).
// Where the line runs straight the windows grow long; near a bend the bias makes wider estimates
// disagree and the window stops short.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "engine/valid_range.h"

namespace featureline {

struct LineAveragingOptions {
  /// Half-width of each estimate's confidence interval, in its standard deviations: smaller stops
  /// the windows sooner (less bias, more noise). bench_accuracy, noisy CAD, the fitted curve over
  /// the initial line's distance: 0.5 -> 0.68, 0.7 -> 0.67 (fewest lines worse than the surface
  /// line), 1 -> 0.67, 2 -> 0.73.
  double confidence = 0.7;
  /// Points per independent error: points sampled more densely than the noise varies share their
  /// errors, and an average over them is noisier than their count says.
  double points_per_error = 1;

  static constexpr ValidRange confidence_range = above(0);
  static constexpr ValidRange points_per_error_range = at_least(1);
};

/// The line to average: points in order at arc-length parameters u (increasing).
struct AveragedLineInput {
  std::vector<double> u;
  std::vector<Eigen::Vector3d> points;
  /// Per point: averaged (1) or kept as it is (0).
  std::vector<char> movable;
  /// Per point: a corner no window reaches across (the corner's own point is kept).
  std::vector<char> corner;
  /// > 0: the line is closed and u is periodic with this period.
  double period = 0;
  /// Bandwidths are multiples of this length: the narrowest is one unit, the widest eleven.
  double unit = 1;
  /// Standard deviation of one point's error along each axis (model units).
  double sigma = 0;
};

struct AveragedLine {
  std::vector<Eigen::Vector3d> points;
  /// Per point: the bandwidth chosen, in units (0 where the point was kept).
  std::vector<double> bandwidth;
};

/// Averages the movable points of `line` as the module comment says.
/// \throw InvalidInputError when an option is outside its range.
AveragedLine average_along_line(const AveragedLineInput& line, const LineAveragingOptions& options = {});

}  // namespace featureline
