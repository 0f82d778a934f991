// Ridges and valleys whose crest is a curve, with a Gaussian profile across it measured along the
// curve's normal: z = amplitude * exp(-(d / width)^2), d the exact distance in xy to the crest
// curve. Across such a crest the normal curvature is -f''(d) / (1 + f'(d)^2)^(3/2), even in d, so
// the crest of the principal curvature (the feature the engine follows) is the curve itself: the
// truth is exact, bends included (make_ridge_field's profile is vertical, y - crest(x), so its
// feature leaves its crest curve slightly in bends). The distance field is smooth within the
// curve's smallest radius of curvature, which the generators keep at least 3 widths.
//
// The meshes are make_height_field's jittered Delaunay grids (irregular, edges following no
// curve). Deterministic like synthetic_meshes.h; invalid arguments throw std::invalid_argument.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tests/support/synthetic_meshes.h"

namespace featureline::testing {

enum class CrestCurve {
  /// A circle of radius 3 widths (0.75 at the default width) centred at (0, -0.5); the keys span
  /// its upper arc from 35 to 145 degrees (about 1.44 of arc).
  arc,
  /// y = 0.15 sin(pi x) + 0.1234 for x in [-0.8, 0.8]: bends both ways, smallest radius of
  /// curvature 1 / (0.15 pi^2) = 0.68, an inflection at x = 0.
  sine,
};

const char* to_string(CrestCurve curve);

struct CurvedCrestOptions {
  CrestCurve curve = CrestCurve::arc;
  int n = 111;                ///< grid points per side (about 2 (n - 1)^2 triangles)
  double jitter = 0.2;        ///< as in make_height_field
  std::uint64_t seed = 1;     ///< as in make_height_field
  double amplitude = 0.3;     ///< > 0 ridge, < 0 valley
  double width = 0.25;        ///< decay length of the profile across the crest
};

struct CurvedCrestField {
  HeightField field;  ///< mesh, height, spacing (its `crest` member is empty: the curve is not y(x) for every shape)
  CrestCurve curve = CrestCurve::arc;
  /// Exact xy distance from (x, y) to the crest curve.
  std::function<double(double, double)> distance;
  /// Signed xy offset from the crest curve towards the centre of curvature of its nearest point
  /// (> 0 inside the bend, < 0 outside; 0 sign at an inflection).
  std::function<double(double, double)> inward_offset;
  /// The crest point at parameter t in [0, 1] along the keys' span (t = 0 and 1: the end keys).
  std::function<Eigen::Vector2d(double)> crest_point;
};

/// The field described by `options`.
CurvedCrestField make_curved_crest_field(const CurvedCrestOptions& options);

/// A sine crest with the other options at their defaults (n grid points per side, jitter and
/// noise-free heights from `seed`; amplitude > 0 ridge, < 0 valley).
CurvedCrestField make_sine_crest_field(int n, std::uint64_t seed, double amplitude = 0.3);

/// The feature crest of a make_ridge_field field: where the larger principal curvature magnitude
/// peaks along the crest curve's normals. That field's profile is vertical (y - crest(x)), so in
/// its bends the peak lies off the curve, up to 0.00035 at the default bend 0.3 and width 0.25
/// (0.06 grid spacings at n = 351, 0.035 at n = 201): the truth a feature line can reach. A
/// polyline in the plane z = 0, one point every `step` in x over [x0, x1], each found by golden-
/// section search within 0.005 of the curve (curvatures from central differences of `height`).
/// \throw std::invalid_argument when the field has no crest curve or the range is empty
std::vector<Eigen::Vector3d> ridge_field_feature_crest(const HeightField& field, double x0, double x1, double step);

/// The vertices nearest the crest points at the given parameters (keys for lines on it).
std::vector<std::uint32_t> keys_on_curved_crest(const CurvedCrestField& field, const std::vector<double>& ts);

}  // namespace featureline::testing
