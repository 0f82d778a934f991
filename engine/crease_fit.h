// Refinement of a noisy crease run: the line along a chain of crease edges, re-estimated from
// the chain's noisy vertices and put back on the surface.
//
// On a clean mesh a crease run is the feature itself and is kept exactly (feature_line.cpp). On
// a noisy one its vertices scatter about the true crease by the noise, and the snake cannot help:
// its force reads a feature field that is sharpest exactly on those scattered crease edges, so it
// either stays on them or, through a bend, cuts across the sheets (measured: the snake's
// line 0.97-1.05x the initial line's distance to the true crease). The true crease is a smooth
// space curve; the noise is independent from vertex to vertex. A local quadratic regression of
// the chain's positions against arc length (Gaussian weights) averages the noise out along the
// crease while following its bends without the shrinking bias a plain average has (its window
// chosen vertex by vertex, engine/line_averaging.h: long where the crease runs straight, short
// near its bends); each vertex moves part way toward it, and the point is then put on the nearest point of the surface near
// its vertex, because the line must lie on the mesh. That last step sets a floor: the true crease
// itself lies off the noisy surface (bench_accuracy's "floor" column: 0.72-0.80 of the initial
// line's distance at 10% noise), so no line on the surface gets much closer than that.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/prepared_mesh.h"
#include "engine/snake.h"

namespace featureline {

struct CreaseFitOptions {
  /// Standard deviation of the Gaussian weights along the chain, in local edge lengths, when
  /// `confidence` is 0. 0 turns the fit off (the chain's vertices are returned as they are).
  double bandwidth = 2.5;
  /// > 0: each vertex's window is chosen from 1 to 11 local edge lengths as the widest whose
  /// estimate agrees with every narrower one within this many standard deviations (the mesh's
  /// noise estimate; engine/line_averaging.h). bench_accuracy, noisy CAD, refined / initial and
  /// lines worse than their initial line: the fixed bandwidth 0.892 and 9, confidence 0.7 0.896
  /// and 5, 1 0.886 and 6, 1.5 0.879 and 7 (step 0.5).
  double confidence = 1.0;
  /// The fit moves a vertex at most this far (local edge lengths); beyond that the chain turns
  /// too sharply for the bandwidth (a crease corner) and the vertex is kept.
  double max_shift = 0.5;
  /// How far each vertex moves toward the fitted crease before it is put back on the surface
  /// (0 stays, 1 goes all the way). The fit has its own error (a few vertices' worth of noise,
  /// and bias where the crease bends within the bandwidth), so the best estimate lies between
  /// the vertex and the fit: on noisy CAD creases (bench_accuracy) with the fixed bandwidth moving
  /// half way gave 0.86 of the initial line's distance with 12 of 252 lines worse, all the way 0.90
  /// with 33 worse; with the windows chosen per vertex (confidence 1) 0.5 gave 0.886 and 6 of 189
  /// lines worse, 0.6 0.878 and 6, 0.75 0.869 and 11, 1 0.874 and 17.
  double step = 0.6;
  /// A piece is fitted as a crease run when at least this share of its edges are crease edges
  /// (noise unmarks some edges of a true crease: their dihedral angle dips under the threshold;
  /// on the 10%-noisy rocker arm and wing nut, whose creases are near 30 degrees, half of a
  /// short piece's edges can lose the mark). bench_accuracy, noisy CAD: 0.5 left 13 of 252 lines
  /// worse than their initial line (the snake refined weak creases in the noisy field), 0.25
  /// left 9 at the same 0.85 ratio; 0.1 and 0 gave back accuracy (0.86, 0.90). Smooth fields
  /// are unchanged (their pieces have no crease edges of the line's sign). On a mesh that reads
  /// clean only a piece with unmarked edges whose line runs on smoothly (no turn over 45 degrees,
  /// unlike a bend that crosses faces) is fitted; one of crease edges only is kept exactly.
  double min_crease_share = 0.25;
  /// How far each interior point of a noisy crease run then moves toward the line's fitted space
  /// curve (engine/fitted_curve.h: crease points where two planes fit the sides, averaged along
  /// the line) before it is put on the nearest point of the surface around its vertex again; 0
  /// keeps the crease fit's points. The curve, drawn from the whole neighbourhood rather than
  /// the run's own vertices, lies nearer the true crease than the run (bench_accuracy, noisy
  /// CAD: 0.51-0.63 of the initial line's distance on smooth creases); the surface point nearest
  /// it is then nearer the floor (the true crease's own distance to the noisy surface). Noisy
  /// CAD, distance above the floor per line: 0 0.0160 units, 0.3 0.0138, 0.5 0.0133, 0.7
  /// 0.0130, with lines worse than their initial line 6, 9, 11, 11. Off by default: it costs the
  /// fitted curve on every line with a noisy crease run, asked for or not, and scans have many
  /// (bench_pipeline medians at 0.5: noisy CAD lines 0.2 -> 7 ms, the armadillo's random lines
  /// 0.8 -> 10 ms, the dragon's 1.2 -> 14 ms).
  double curve_pull = 0;
};

struct CreaseFitResult {
  /// One point per chain vertex; fixed vertices (by default the two ends) unchanged.
  std::vector<SurfacePoint> points;
  std::size_t kept_vertices = 0;  ///< free vertices left in place (max_shift exceeded)
  double mean_shift = 0;          ///< mean distance moved by the free points, local edge lengths
};

/// Re-estimates the crease through `chain` (consecutive mesh vertices joined by edges) and maps
/// it onto the surface. `fixed` (per chain vertex; empty: the two ends) marks the vertices that
/// stay where they are: pins shared with the rest of the line.
CreaseFitResult fit_noisy_crease(const PreparedMesh& mesh, const std::vector<std::uint32_t>& chain,
                                 const CreaseFitOptions& options = {}, std::vector<char> fixed = {});

/// Moves each point of `points` marked in `pullable` the share `pull` of the way toward the
/// nearest point of the polyline `curve` (closed: its last point joins its first), and then onto
/// the nearest point of the surface around the vertex the point lies nearest (CreaseFitOptions::
/// curve_pull). Both follow the same line in the same order.
void pull_toward_curve(const PreparedMesh& mesh, const std::vector<Eigen::Vector3d>& curve, bool closed,
                       const std::vector<char>& pullable, double pull, std::vector<SurfacePoint>& points);

/// The point of the triangles around `v` (the faces of v and of its neighbours) nearest to `x`.
SurfacePoint nearest_surface_point_near(const PreparedMesh& mesh, std::uint32_t v, const Eigen::Vector3d& x);

}  // namespace featureline
