// Stage 3: snake (active contour) refinement of the line on the flattened strip, and
// stage 4: mapping every refined point back to the surface (paper Eqs. 12-15).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/cancellation.h"
#include "engine/enum_names.h"
#include "engine/feature_strip.h"
#include "engine/prepared_mesh.h"
#include "engine/surface_point.h"
#include "engine/valid_range.h"

namespace featureline {

/// How the image force of Eq. (15) is evaluated inside a flattened triangle.
enum class SnakeForce {
  /// The paper: |C|^p interpolated barycentrically, so its gradient is constant per triangle.
  /// Maxima of a linear interpolant sit on vertices, so the line is drawn towards vertices.
  paper,
  /// Per-vertex gradients (area-weighted means of the adjacent triangles' gradients), then
  /// interpolated barycentrically: a continuous force whose zero lies between vertices, where
  /// the crest is.
  smooth,
};
template <>
struct EnumNames<SnakeForce> {
  static constexpr std::array<std::pair<SnakeForce, const char*>, 2> entries{{{SnakeForce::paper, "paper"},
                                                                             {SnakeForce::smooth, "smooth"}}};
};

/// Distances are in units of the strip's mean edge length, curvature in units of the mesh's
/// curvature scale, so the defaults work at any mesh size and resolution.
struct SnakeOptions {
  double alpha = 0.02;  ///< elasticity weight of Eq. (12) (first differences)
  double beta = 8.0;    ///< rigidity weight of Eq. (12) (second differences)
  /// Time step of the semi-implicit Euler step (I + tau A) v' = v + tau kappa F. With
  /// normal_step the force is linearised too, so large steps are stable and only change how
  /// fast the line settles, not where (the paper's step, normal_step = false, used 1).
  double tau = 16.0;
  double kappa = 0.1;        ///< weight of the feature force, F = grad |C|^p
  double exponent = 2.0;     ///< p: the paper's Eq. (15) uses |C|^2
  double curvature_cap = 4;  ///< |C| is clamped at this (in curvature-scale units) so spikes do not dominate
  /// Largest move of a point in one iteration. normal_step: a trust region on the solved move,
  /// which does not change where the line settles; paper step: a cap on the force's step.
  double max_step = 0.25;
  int max_iterations = 300;  ///< iteration cap
  /// Stop when the line's shape changes by less than this per iteration: the mean distance of
  /// its points from the line as it was 2 * resample_every iterations earlier, divided by that
  /// count. Sliding along the line, resampling and a point oscillating in place do not count.
  double tolerance = 2e-4;
  double spacing = 0.5;  ///< target distance between snake points
  /// Iterations between resampling passes: points closer than spacing/2 are deleted, gaps over
  /// 3 spacing/2 filled, and with normal_step the points are then spread evenly along the line.
  int resample_every = 5;
  SnakeForce force = SnakeForce::smooth;
  /// paper step only: keep only the force's component normal to the line. The tangential part
  /// only slides points along the line, bunching them at curvature maxima (vertices) and making
  /// the discrete line jagged; the paper applies the whole gradient (false). The normal step
  /// moves points along the normal only, so there the force's normal component is all that acts.
  bool normal_force_only = true;
  /// smooth force only: a vertex whose neighbours on both sides of the line have at most
  /// (1 - sharp_crest_drop) of its |C|^p is a sharp crest (a crease); its gradient across the
  /// line is zeroed so the crease itself is where the force vanishes. 0 disables.
  double sharp_crest_drop = 0.5;
  /// +1: attract to ridges (H > 0) only, -1: valleys only, 0: as the line's trace or keys say
  /// (LineContext::feature_sign is what the stages follow).
  double feature_sign = 0;
  /// true: every iteration solves Eq. (15) for moves along each point's normal only, with the
  /// smooth force linearised (its restoring stiffness on the left-hand side), and the points are
  /// kept evenly spaced by the resampling passes. Sliding along the line changes nothing about
  /// the line, and in the paper's step it never settles: the bending term keeps drawing points
  /// into bends while resampling deletes them there. false: the paper's Eq. (15) on both
  /// coordinates, explicit in the force.
  bool normal_step = true;
  /// A strip whose 90th percentile of feature strength (|C| of the line's sign over the mesh's
  /// 90th percentile of |C|, capped at curvature_cap) is below this has no feature to find: no
  /// more of one than the mesh's own surface (on a scan, its noise). Its snake gets
  /// featureless_iterations, enough to smooth the initial line. 0: every strip is searched.
  double featureless_below = 1.0;
  int featureless_iterations = 20;  ///< iteration cap on a featureless strip

  // What the snake accepts (check_snake_options); api/options_table.cpp's limits lie inside.
  static constexpr ValidRange alpha_range = at_least(0);
  static constexpr ValidRange beta_range = at_least(0);
  static constexpr ValidRange tau_range = above(0);
  static constexpr ValidRange kappa_range = at_least(0);
  static constexpr ValidRange exponent_range = above(0);
  static constexpr ValidRange curvature_cap_range = above(0);
  static constexpr ValidRange max_step_range = above(0);
  static constexpr ValidRange max_iterations_range = at_least(0);
  static constexpr ValidRange featureless_below_range = at_least(0);
  static constexpr ValidRange spacing_range = above(0.01);
  static constexpr ValidRange resample_every_range = at_least(1);
};

/// \throw InvalidInputError when an option is outside its range (SnakeOptions::*_range).
void check_snake_options(const SnakeOptions& options);

/// A point on the strip, hence on the surface.
struct StripPoint {
  std::uint32_t triangle = 0;  ///< local strip triangle
  Eigen::Vector3d barycentric{1, 0, 0};  ///< w.r.t. the triangle's corners in strip (= mesh face) order
  Eigen::Vector2d uv{0, 0};              ///< plane position (strip units, not scaled)
};

struct SnakeResult {
  std::vector<StripPoint> points;  ///< first and last are the pinned ends
  int iterations = 0;
  /// Shape change per iteration over the last convergence window (edge lengths; see
  /// SnakeOptions::tolerance).
  double last_displacement = 0;
  bool converged = false;
  double strip_strength = 0;  ///< the strip's 90th percentile of feature strength (SnakeOptions::featureless_below)
  bool featureless = false;   ///< below featureless_below: the snake only smoothed the line
};

/// The 90th percentile over the strip's vertices of the feature strength the force follows:
/// |C| of the line's sign in curvature-scale units (the mesh's own 90th percentile of |C|),
/// capped as the force caps it. Below SnakeOptions::featureless_below the strip is featureless.
double strip_feature_strength(const PreparedMesh& mesh, const FeatureStrip& strip, const SnakeOptions& options,
                              const LineContext& line);

/// Refines the strip's line; both ends of the line stay pinned. The line's points never
/// leave the strip: a point pushed past the strip's border stops on it.
/// \throw CancelledError once `cancel` is requested (checked every iteration).
SnakeResult refine_with_snake(const PreparedMesh& mesh, const FeatureStrip& strip, const FlatStrip& flat,
                              const SnakeOptions& options = {}, const LineContext& line = {},
                              const Cancellation* cancel = nullptr);

/// Stage 4: maps strip points to faces, barycentric coordinates and 3D points.
std::vector<SurfacePoint> map_to_surface(const PreparedMesh& mesh, const FeatureStrip& strip,
                                         const std::vector<StripPoint>& points);

/// Locates `target` by walking across strip triangles from `start`. Returns the point found;
/// when the walk meets the strip's border the point is clamped onto it.
StripPoint locate_by_walking(const FeatureStrip& strip, const FlatStrip& flat, std::uint32_t start,
                             const Eigen::Vector2d& target);

}  // namespace featureline
