// The curvature stage: per-vertex curvature and the feature field every later stage reads
// (feature path costs, the marching search's f_C, the snake's potential of Eq. 13), plus the
// mesh's sharp creases. Computed once per mesh in prepare_mesh; nothing here depends on a
// request.
//
// The paper uses the one-ring (cotangent) mean curvature. On scans that field is dominated by
// noise, and on CAD tessellations (long skinny triangles) it is meaningless; so the default
// field fits a local height function (a degree-2 jet, as in Cazals and Pouget's osculating
// jets and CGAL's Monge fitting) over a neighbourhood whose radius follows the mesh's
// estimated noise, and takes its principal curvatures. Sharp edges are found by their
// dihedral angle and treated as features in their own right.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/cancellation.h"
#include "engine/enum_names.h"
#include "engine/executor.h"
#include "engine/valid_range.h"

namespace featureline {

enum class CurvatureMethod {
  cotangent,  ///< the paper: one-ring cotangent mean curvature H (Meyer et al. 2003)
  jet,        ///< principal curvatures of a weighted polynomial fit (a jet) over a neighbourhood radius
};
template <>
struct EnumNames<CurvatureMethod> {
  static constexpr std::array<std::pair<CurvatureMethod, const char*>, 2> entries{{{CurvatureMethod::jet, "jet"},
                                                                                  {CurvatureMethod::cotangent, "cotangent"}}};
};

/// The jet's height polynomial: quadric (degree 2, six coefficients) or cubic (degree 3, ten).
enum class JetDegree {
  automatic,  ///< cubic (at the mesh's border and beside creases: quadric, see CurvatureOptions::jet_degree)
  quadric,
  cubic,
};
template <>
struct EnumNames<JetDegree> {
  static constexpr std::array<std::pair<JetDegree, const char*>, 3> entries{
      {{JetDegree::automatic, "auto"}, {JetDegree::quadric, "quadric"}, {JetDegree::cubic, "cubic"}}};
};

struct CurvatureOptions {
  CurvatureMethod method = CurvatureMethod::jet;
  /// A quadric fitted over a wide disc across a bent crest reads the bend as curvature: the
  /// curvature peaks inside the bend (at 10-20% noise the fit radius is 6 local edge lengths,
  /// and a 5,000-triangle arc's refined line lay 0.22 grid spacings inside it). A cubic's odd
  /// terms take up the bend (Cazals and Pouget's jets of degree 3-4), on the narrow discs of
  /// clean meshes too: there a cubic put lines 0.002-0.011 grid spacings nearer the crest in 17
  /// of bench_accuracy's 18 clean cells (one 0.003 further). Automatic: cubics, but quadrics
  /// where a neighbourhood reaches the border or lies to one side (a crease cuts it off).
  JetDegree jet_degree = JetDegree::automatic;
  /// Jet neighbourhood radius in local edge lengths (the mean length of a vertex's edges).
  /// 0 chooses it from the estimated noise: 2 on clean meshes, growing to 6 at heavy noise; on
  /// noisy meshes (estimated noise 0.03 or more) of objects D > 134 mean edges across (the
  /// bounding box's diagonal), that radius times sqrt(D / 134), at most 12.
  double radius = 0;
  /// Laplacian passes over the principal curvatures afterwards; each replaces a value by the
  /// mean of itself and its neighbours' mean. -1 chooses them: none on an exact surface (estimated
  /// noise below 0.005 local edge lengths), else doubling runs of passes for as long as a run
  /// cuts the field's relative roughness to `smoothing_tolerance` or less (noise keeps falling,
  /// a smooth field's own variation does not), at most the limit.
  int smoothing_passes = -1;
  double smoothing_tolerance = 0.85;
  /// An edge whose faces' normals differ by more than this many degrees is a crease. 0 chooses
  /// it from the noise (at least 30 degrees, and well above the noise's own dihedral angles);
  /// negative: no creases.
  double crease_angle = 0;
};

/// Estimated noise (local edge lengths) from which crease marks are no longer exact: noise
/// unmarks some edges of a true crease and marks others beside it (clean CAD meshes read
/// 0.000-0.022, the same meshes at 10% noise 0.046-0.064).
constexpr double kNoisyCreaseNoise = 0.035;

/// A noise estimate read at fewer vertices than this says nothing of the mesh's noise
/// (CurvatureField::noise_samples).
constexpr std::size_t kMinNoiseSamples = 20;

/// Limits of the options, shared by validation, the JSON mapping and the API description.
struct CurvatureLimits {
  static constexpr double max_radius = 12;
  static constexpr int max_smoothing_passes = 100;
  static constexpr double max_crease_angle = 179;
  /// What compute_curvature_field accepts; api/options_table.cpp's limits lie inside.
  static constexpr ValidRange radius_range = closed_range(0, max_radius);
  static constexpr ValidRange smoothing_passes_range = closed_range(-1, max_smoothing_passes);
  static constexpr ValidRange smoothing_tolerance_range = open_range(0, 1);
  static constexpr ValidRange crease_angle_range = at_most(max_crease_angle);
};

/// \throw InvalidInputError when an option is outside its range (CurvatureLimits::*_range).
void check_curvature_options(const CurvatureOptions& options);

/// Wall time of each part of the curvature stage, milliseconds (bench_pipeline prints them).
struct CurvatureTimings {
  double mean_ms = 0;       ///< cotangent mean curvature
  double creases_ms = 0;    ///< dihedral angles, crease marks, chords (and folds on noisy meshes)
  double noise_ms = 0;      ///< the probe fits that estimate the noise
  double jet_ms = 0;        ///< the jet fit of every vertex at the chosen radius
  double smoothing_ms = 0;  ///< smoothing passes and the roughness measurements deciding them
};

struct CurvatureField {
  std::vector<double> mean;   ///< signed mean curvature (cotangent), positive on convex parts
  /// Signed principal curvatures, k_max >= k_min, positive where the surface is convex along
  /// that direction. The cotangent method sets both to H.
  std::vector<double> k_max, k_min;
  /// Crease flag per entry of the prepared mesh's adjacency rows (parallel to `neighbors`):
  /// +1 convex crease, -1 concave crease, 0 smooth edge.
  std::vector<std::int8_t> crease;
  std::vector<char> on_crease;  ///< per vertex: one of its edges is a crease
  /// Per adjacency entry: how sharply the edge folds, its dihedral angle over the crease angle
  /// (at most 1) in kFoldScale-ths, positive where convex, 0 on the border. Empty when creases
  /// are off or the noise is under kNoisyCreaseNoise. A crease mark is yes or no; on a noisy
  /// mesh the feature path reads the fold of the edges noise left unmarked
  /// (engine/initial_line.h, kFoldFeatureShare).
  std::vector<std::int8_t> fold;
  static constexpr int kFoldScale = 127;
  /// Per adjacency entry: an edge joining two crease vertices without being a crease, a chord
  /// across a face (a CAD cap's long diagonal cutting a rounded corner), which the feature path
  /// reads as no feature. On a noisy mesh (noise at least kNoisyCreaseNoise) an edge between
  /// vertices of crease runs the fits stop at (long runs, and short runs beside a long run of
  /// their sign) is no chord: noise unmarks some edges of a true crease, and a path forbidden
  /// them took a run of noise-marked edges elsewhere (a wing nut's line, 7 edges off its crease).
  std::vector<char> chord;
  double noise = 0;         ///< estimated RMS noise along the normal, in local edge lengths
  /// The same estimate in length units: a scanner's noise is a length, whatever the triangles'
  /// size, so where a line's edges are much shorter or longer than the mesh's typical ones
  /// (a wing nut's creases: 5 times shorter than their vertices' other edges) this is the noise
  /// its points carry.
  double noise_length = 0;
  /// Vertices whose probe fit gave the estimate (a sample of about 20,000 on large meshes). None
  /// where every vertex lies on a crease (a CAD exporter's tessellation: long skinny faces between
  /// the outlines of its faces, no vertex inside them): there the mesh says nothing of its noise.
  std::size_t noise_samples = 0;
  double radius = 0;        ///< jet radius used (local edge lengths); 0 for cotangent
  JetDegree jet_degree = JetDegree::automatic;  ///< the jets fitted (quadric for cotangent, unused)
  int smoothing_passes = 0; ///< Laplacian passes applied to k_max and k_min
  double crease_angle = 0;  ///< degrees; 0 when creases are off
  std::size_t crease_edges = 0;
  CurvatureTimings timings;
};

/// Adjacency in compressed rows: neighbours of v are neighbors[offsets[v] .. offsets[v+1]).
struct AdjacencyView {
  const std::vector<std::uint32_t>& offsets;
  const std::vector<std::uint32_t>& neighbors;
  const std::vector<double>& edge_lengths;  ///< parallel to `neighbors`: |P[neighbor] - P[v]|
};

/// The mesh as the curvature stage reads it: the prepared mesh's own tables (engine/prepared_mesh.h),
/// flat arrays walked in order, with no halfedge structure beside them.
struct MeshTablesView {
  const std::vector<Eigen::Vector3d>& positions;
  /// Corner vertex ids of each face, counter-clockwise seen from outside; no edge has more than
  /// two faces, and two faces on an edge run through it in opposite directions.
  const std::vector<std::array<std::uint32_t, 3>>& triangles;
  /// The face across edge k = (t[k], t[k+1]) of each face, UINT32_MAX on the boundary.
  const std::vector<std::array<std::uint32_t, 3>>& face_neighbors;
  const std::vector<char>& boundary_vertex;  ///< per vertex: on an edge with one face
  AdjacencyView adjacency;
};

/// The dihedral angles, the fits and the smoothing passes are split over `executor` (nullptr:
/// default_executor()); the field is the same whatever it is.
/// \throw InvalidInputError for options out of range; CancelledError once `cancel` is requested
///        (checked every 4096 vertices of the fits and every smoothing pass).
CurvatureField compute_curvature_field(const MeshTablesView& mesh, const std::vector<Eigen::Vector3d>& normals,
                                       const CurvatureOptions& options = {}, const Cancellation* cancel = nullptr,
                                       Executor* executor = nullptr);

/// The signed mean curvature of every vertex by the cotangent formula (exposed for tests).
std::vector<double> compute_mean_curvature(const MeshTablesView& mesh, const std::vector<Eigen::Vector3d>& normals);

/// Angle-weighted unit vertex normals.
std::vector<Eigen::Vector3d> compute_vertex_normals(const std::vector<Eigen::Vector3d>& positions,
                                                    const std::vector<std::array<std::uint32_t, 3>>& triangles);

/// Feature value of a vertex for lines of a given sign: +1 ridges (k_max, negative clipped to
/// 0), -1 valleys (-k_min, clipped), 0 either (the larger |k|). In curvature units.
inline double feature_value(const CurvatureField& field, std::uint32_t v, double sign) {
  if (sign > 0) return field.k_max[v] > 0 ? field.k_max[v] : 0;
  if (sign < 0) return field.k_min[v] < 0 ? -field.k_min[v] : 0;
  const double a = field.k_max[v] < 0 ? -field.k_max[v] : field.k_max[v];
  const double b = field.k_min[v] < 0 ? -field.k_min[v] : field.k_min[v];
  return a > b ? a : b;
}

/// The noise floor of feature values, times the local edge length h: a vertex's feature value k
/// bends the surface over the jets' radius R (local edge lengths) by k R^2 h^2 / 2, which must be
/// at least `signal_to_noise` times the estimated noise sigma h, so k >= (2 m sigma / R^2) / h.
/// R is 1 without jets (the cotangent field); 0 when the noise is not estimated.
inline double noise_floor_times_edge(const CurvatureField& field, double signal_to_noise) {
  const double radius = field.radius > 0 ? field.radius : 1.0;
  return 2 * signal_to_noise * field.noise / (radius * radius);
}

/// The principal curvature of larger magnitude, signed (what the curvature map shows).
inline double dominant_curvature(const CurvatureField& field, std::uint32_t v) {
  return -field.k_min[v] > field.k_max[v] ? field.k_min[v] : field.k_max[v];
}

/// dominant_curvature of every vertex: the signed field `/curvature` and `mesh.glb` carry.
inline std::vector<double> dominant_curvatures(const CurvatureField& field) {
  std::vector<double> out(field.k_max.size());
  for (std::size_t v = 0; v < out.size(); ++v) out[v] = dominant_curvature(field, std::uint32_t(v));
  return out;
}

}  // namespace featureline
