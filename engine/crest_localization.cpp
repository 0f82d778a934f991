#include "engine/crest_localization.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "engine/errors.h"
#include "engine/internal/geometry.h"
#include "engine/internal/order_statistics.h"
#include "engine/internal/strip_walk.h"

namespace featureline {
namespace {

// The line's unit normal in the plane at interior point i (central difference of its neighbours).
Eigen::Vector2d normal_at(const std::vector<StripPoint>& points, std::size_t i) {
  const Eigen::Vector2d t = (points[i + 1].uv - points[i - 1].uv).normalized();
  return {-t.y(), t.x()};
}

// The normal at an end (front: 0, back: 1), from the chord to the first point `reach` along the
// line: the line's last few points bend towards the pinned vertex, and a normal from them alone
// would be tilted by that bend.
Eigen::Vector2d end_normal(const std::vector<StripPoint>& points, int end, double reach) {
  const std::size_t n = points.size();
  const std::size_t from = end == 0 ? 0 : n - 1;
  std::size_t to = from;
  for (std::size_t k = 1; k < n; ++k) {
    to = end == 0 ? k : n - 1 - k;
    if ((points[to].uv - points[from].uv).norm() >= reach) break;
  }
  const Eigen::Vector2d t = (end == 0 ? points[to].uv - points[from].uv : points[from].uv - points[to].uv).normalized();
  return {-t.y(), t.x()};
}

// The line's signed curvature at each point (> 0: it turns towards its normal `normals[i]`), from
// a least-squares parabola u = c0 + c1 a + c2 a^2 of the points within `baseline` of it (a along
// its tangent, u along its normal; curvature 2 c2): many points, so the snake's ripple on a noisy
// mesh averages out. A crest that bends is a parabola s = k a^2 / 2 in the frame of its tangent; a
// fit whose quadratic has no a^2 s term reads that bend as an offset of about k <a^2> / 2 (the
// weighted mean over the fit) towards the bend's centre: 0.05-0.1 grid spacings inside an arc of
// radius 3 crest widths on 5k-24k triangles (bench_accuracy). The fits therefore measure s from
// the line's own bend, which follows the crest's. (An a^2 s term in the fit would measure the bend
// too, but its unknown costs every fit precision: noisy lines came out 10-40% further off.)
std::vector<double> line_bends(const std::vector<StripPoint>& points, const std::vector<Eigen::Vector2d>& normals,
                               double baseline) {
  const std::size_t n = points.size();
  std::vector<double> bend(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d nu = normals[i], t(nu.y(), -nu.x());
    ParabolaFit fit(baseline);
    auto add = [&](std::size_t j) {
      const Eigen::Vector2d d = points[j].uv - points[i].uv;
      if (d.squaredNorm() > baseline * baseline) return false;
      fit.add(d.dot(t), d.dot(nu));
      return true;
    };
    add(i);
    for (std::size_t j = i; j-- > 0 && add(j);) {}
    for (std::size_t j = i + 1; j < n && add(j); ++j) {}
    bend[i] = fit.curvature();
  }
  return bend;
}

// line_bends of the line moved across itself by `offsets` (the crest fits' smoothed offsets).
std::vector<double> localised_bends(const std::vector<StripPoint>& points, const std::vector<Eigen::Vector2d>& normals,
                                    const std::vector<double>& offsets, double baseline) {
  std::vector<StripPoint> localised = points;
  for (std::size_t i = 0; i < points.size(); ++i) localised[i].uv += offsets[i] * normals[i];
  return line_bends(localised, normals, baseline);
}

// The placed strip vertices bucketed in square cells of the fit radius, so a fit visits the 3 x 3
// cells around its point instead of the whole strip (a 245k-triangle line's strip has thousands).
class VertexGrid {
 public:
  VertexGrid(const FlatStrip& flat, double cell) : cell_(cell) {
    low_ = Eigen::Vector2d::Constant(HUGE_VAL);
    Eigen::Vector2d high = Eigen::Vector2d::Constant(-HUGE_VAL);
    for (std::size_t v = 0; v < flat.uv.size(); ++v)
      if (flat.placed[v]) low_ = low_.cwiseMin(flat.uv[v]), high = high.cwiseMax(flat.uv[v]);
    if (!(high.x() >= low_.x())) return;
    // At most about 4 cells per placed vertex: a huge radius on a small strip is one cell.
    const double span = std::max(high.x() - low_.x(), high.y() - low_.y());
    cell_ = std::max(cell, span / (2 * std::sqrt(double(flat.uv.size())) + 1));
    columns_ = std::size_t((high.x() - low_.x()) / cell_) + 1;
    rows_ = std::size_t((high.y() - low_.y()) / cell_) + 1;
    cells_.resize(columns_ * rows_);
    for (std::size_t v = 0; v < flat.uv.size(); ++v)
      if (flat.placed[v]) cells_[index(flat.uv[v])].push_back(std::uint32_t(v));
  }
  /// Calls visit(v) for every vertex in the cells within one cell of p.
  template <typename Visit>
  void around(const Eigen::Vector2d& p, Visit visit) const {
    if (cells_.empty() || !p.allFinite()) return;
    const long cx = long(std::floor((p.x() - low_.x()) / cell_)), cy = long(std::floor((p.y() - low_.y()) / cell_));
    for (long y = std::max(0L, cy - 1); y <= std::min(long(rows_) - 1, cy + 1); ++y)
      for (long x = std::max(0L, cx - 1); x <= std::min(long(columns_) - 1, cx + 1); ++x)
        for (const std::uint32_t v : cells_[std::size_t(y) * columns_ + std::size_t(x)]) visit(v);
  }

 private:
  std::size_t index(const Eigen::Vector2d& q) const {
    const auto x = std::min(columns_ - 1, std::size_t((q.x() - low_.x()) / cell_));
    const auto y = std::min(rows_ - 1, std::size_t((q.y() - low_.y()) / cell_));
    return y * columns_ + x;
  }
  double cell_;
  Eigen::Vector2d low_;
  std::size_t columns_ = 0, rows_ = 0;
  std::vector<std::vector<std::uint32_t>> cells_;
};

// The field across the line near one point, from a weighted fit
// g(s, a) = c0 + c1 s + c2 s^2 + c3 a + c4 a s + c5 a^2 over the placed strip vertices within
// `radius` (s across the line, a along it; Gaussian weights, sigma = radius / 2).
struct CrestFit {
  double offset = std::nan("");  ///< s* = -c1 / (2 c2), the maximum across the line at a = 0; NaN: none (or too flat)
  double half_width = std::nan("");  ///< where the fitted profile falls to half its peak (strip units)
};

// Noise (the mesh's estimate, local edge lengths) from which fits stay in the tangent's frame: the
// line's bend there follows the snake's wander more than the crest's (bench_accuracy at 30% noise,
// estimated 0.104-0.109: lines 0.01-0.03 grid spacings further off in the line's frame; at 20%,
// 0.071-0.074, 0.02-0.03 nearer on curved crests).
constexpr double kBendFrameMaxNoise = 0.09;

// A strip narrower than the jets (a few rings on a coarse noisy mesh, whose jets span 5-6 edges)
// is fitted across its whole width when that is at least this many edges, rather than left to
// the snake, whose line sits inside bends: bench_accuracy's 5,000-24,200-triangle cells at 10-20%
// noise came nearer in 22 of 24 (arc valley 5,000 at 10%: 0.113 -> 0.049 grid spacings; valley
// 24,200 at 20%: 0.124 -> 0.090), two further (arc ridge 24,200 at 20%: 0.097 -> 0.102). Not at
// kBendFrameMaxNoise and above: at 30% such fits moved cells both ways (0.146 -> 0.095, 0.116 ->
// 0.142).
constexpr double kNarrowestStripFit = 3;
// ... on meshes at least this noisy (estimated, local edge lengths: the fields it was measured on
// at 10-20% noise read 0.037-0.074). Below it a mesh counts as clean for the fits here: symmetric
// windows (symmetric_reach) apply below it. On cleaner scans the narrow strips' fits cost more
// than they bring: on the bunny (0.021) lines took 45% longer along features and 25% with keys
// anywhere (bench_pipeline medians 0.55 -> 0.80 and 1.58 -> 1.96 ms) from 0.015, though the
// 5,000-triangle fields at 5% noise (0.018-0.020), left to the snake, lie inside their bends
// (arcs 0.107 / 0.113 grid spacings, 0.039 / 0.028 fitted across).
constexpr double kNarrowStripMinNoise = 0.03;

// A crest is where the field falls off across the line by at least this share of its peak
// within the fit radius; flatter fields (a cylinder's circle, a plane) have no crest to find.
constexpr double kMinCrestDrop = 0.02;

// What the fits read of the strip: its layout, its vertices bucketed, the field and the creases.
struct FitInput {
  const FlatStrip& flat;
  const VertexGrid& grid;
  const std::vector<double>& field;
  const std::vector<char>& on_crease;
  double crease_reach;  ///< a crease vertex this close to a point leaves it where it is
  double edge;          ///< the strip's mean edge length
  bool symmetric;       ///< cut both sides to the shorter one where the strip's border cuts one short (symmetric_reach)
};

// How far across the line (in fit radii) a fit takes its vertices. Where the strip's border cuts
// one side of the fit's disc short (the line is off the strip's middle: the strip follows the
// initial edge path, which cuts bends and strays), a quadratic over the lopsided window reads the
// peak's skew as an offset, towards the side with more of the peak: on a clean 245,000-triangle
// arc 0.025 grid spacings inside the bend. Both sides are then cut to the shorter one, when that
// falls short of the radius by more than an edge (nearer, it is only where the vertices happen to
// lie) and still reaches half of it (fewer vertices leave the fit too noisy). Both sides reach
// `low` and `high` radii (scaled); HUGE_VAL: no cut.
double symmetric_reach(double low, double high, double radius, double edge) {
  const double reach = std::min(low, high);
  return reach >= 0.5 && reach * radius < radius - edge ? reach : HUGE_VAL;
}

CrestFit fit_crest(const FitInput& in, const Eigen::Vector2d& p, const Eigen::Vector2d& n, double bend, double radius,
                   double min_drop) {
  const FlatStrip& flat = in.flat;
  const Eigen::Vector2d t(n.y(), -n.x());
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  const double inv_two_sigma2 = 2.0 / (radius * radius);  // 1 / (2 (radius / 2)^2)
  // Across the line measured from its bend (line_bends), scaled: a well-conditioned system.
  auto across = [&](const Eigen::Vector2d& d) { return (d.dot(n) - 0.5 * bend * d.dot(t) * d.dot(t)) / radius; };
  double across_min = 0, across_max = 0;
  in.grid.around(p, [&](std::uint32_t v) {
    const Eigen::Vector2d d = flat.uv[v] - p;
    if (d.squaredNorm() > radius * radius) return;
    const double s = across(d);
    across_min = std::min(across_min, s), across_max = std::max(across_max, s);
  });
  const double reach = in.symmetric ? symmetric_reach(-across_min, across_max, radius, in.edge) : HUGE_VAL;
  int used = 0;
  bool crease = false;
  in.grid.around(p, [&](std::uint32_t v) {
    const Eigen::Vector2d d = flat.uv[v] - p;
    const double d2 = d.squaredNorm();
    if (d2 > radius * radius) return;
    const double s = across(d);
    if (std::abs(s) > reach) return;
    crease = crease || (in.on_crease[v] && d2 <= in.crease_reach * in.crease_reach);
    const double a = d.dot(t) / radius;
    Eigen::Matrix<double, 6, 1> row;
    row << 1, s, s * s, a, a * s, a * a;
    const double w = std::exp(-d2 * inv_two_sigma2);
    // The lower triangle only: the LDLT below reads no other.
    const Eigen::Matrix<double, 6, 1> weighted = w * row;
    for (int j = 0; j < 6; ++j)
      for (int i = j; i < 6; ++i) normal_matrix(i, j) += weighted[i] * row[j];
    rhs.noalias() += w * in.field[v] * row;
    ++used;
  });
  CrestFit fit;
  // Six unknowns, and vertices on both sides of the line: otherwise the fit extrapolates. A
  // crease is a kink, not a peak a quadratic describes: the snake and the crease fit place lines
  // there (a fit across noisy rocker-arm creases had moved lines 0.02 edge lengths off).
  if (crease || used < 8 || across_min > -0.25 || across_max < 0.25) return fit;
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal_matrix);
  if (solver.info() != Eigen::Success) return fit;
  const Eigen::Matrix<double, 6, 1> c = solver.solve(rhs);
  if (!c.allFinite() || !(c[2] < 0)) return fit;
  const double s = -c[1] / (2 * c[2]);
  const double peak = c[0] - c[1] * c[1] / (4 * c[2]);
  if (peak > 0) fit.half_width = std::sqrt(peak / (-2 * c[2])) * radius;
  if (-c[2] >= min_drop * std::abs(peak)) fit.offset = s * radius;
  return fit;
}

// The fit radius for the whole line: the crest's half width (median over the line's points from
// fits at radius `smallest`), within [lowest, largest]. A fit over the crest's own width
// averages the field's ripple best: on a fine mesh a crest 40 edges wide is almost flat over
// two edges, and a short fit there follows the ripple rather than the crest.
double line_fit_radius(const FlatStrip& flat, const std::vector<double>& field, const std::vector<char>& on_crease,
                       double crease_reach, double edge, bool symmetric, const std::vector<StripPoint>& points,
                       double smallest, double largest, double lowest) {
  std::vector<double> widths;
  const VertexGrid grid(flat, smallest);
  const FitInput in{flat, grid, field, on_crease, crease_reach, edge, symmetric};
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    const CrestFit fit = fit_crest(in, points[i].uv, normal_at(points, i), 0, smallest, 0);
    if (std::isfinite(fit.half_width)) widths.push_back(fit.half_width);
  }
  if (widths.empty()) return smallest;
  return std::clamp(median_of(std::move(widths)), lowest, std::max(smallest, largest));
}

// (1, 2, 1)/4 passes over the offsets, each weighted by whether its fit found a crest; the
// line's ends keep theirs (their own fit's, where they may move; otherwise 0) at full weight: a
// mirrored end smoothed with a line still bending towards its old vertex would be pulled back.
std::vector<double> smooth_offsets(const std::vector<double>& offsets, int passes) {
  const std::size_t n = offsets.size();
  std::vector<double> value(n), weight(n);
  for (std::size_t i = 0; i < n; ++i) {
    const bool found = std::isfinite(offsets[i]);
    value[i] = found ? offsets[i] : 0;
    weight[i] = found || i == 0 || i + 1 == n ? 1 : 0;
  }
  std::vector<double> next_value(n), next_weight(n);
  for (int pass = 0; pass < passes; ++pass) {
    next_value = value, next_weight = weight;
    for (std::size_t i = 1; i + 1 < n; ++i) {
      next_value[i] = 0.25 * (value[i - 1] * weight[i - 1] + 2 * value[i] * weight[i] + value[i + 1] * weight[i + 1]);
      next_weight[i] = 0.25 * (weight[i - 1] + 2 * weight[i] + weight[i + 1]);
      next_value[i] = next_weight[i] > 0 ? next_value[i] / next_weight[i] : 0;
    }
    value.swap(next_value), weight.swap(next_weight);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!(weight[i] > 0)) value[i] = 0;
  return value;
}

// The field's blur moves a bent crest into its bend. Smoothing a field f whose crest runs along a
// circle of radius R with a kernel of variance sigma^2 per axis gives f + sigma^2 / 2 Lap f to first
// order; across the crest Lap f = f'' + f' / R, so the smoothed field peaks sigma^2 / (2 R) inside
// the bend, whatever the crest's profile. The field's blur is that of its jets (a weighted
// polynomial fit's second derivatives are the surface's blurred by kJetBlur r^2 per axis for
// Gaussian weights of sigma r / 2 over a disc of radius r: numerically, quadric and cubic alike)
// and of its smoothing passes (each averages a vertex half with its neighbours' mean: a quarter of
// their mean squared distance per axis).
constexpr double kJetBlur = 0.109;

// The field's blur variance per axis (squared strip units) on a strip of mean edge length h and
// mean squared edge length h2.
double field_blur_variance(const CurvatureField& field, double h, double h2) {
  return kJetBlur * field.radius * field.radius * h * h + 0.25 * field.smoothing_passes * h2;
}

// The blur is taken out (CrestOptions::unblur) where the field was smoothed (from 0.005 noise,
// kExactSurfaceNoise in engine/curvature.cpp) on meshes whose estimated noise (local edge lengths)
// lies under kBendFrameMaxNoise: there the blur is several edges wide (bench_accuracy's fields at
// 10% noise read 0.036-0.037, at 20% 0.071-0.074). On clean meshes the blur is the radius-2 jets'
// (sigma about 0.66 edges, a shift under 0.02 edges in these bends). Taken out only from 0.03,
// lightly noisy fields (2-5%, 0.007-0.020) lay inside their bends: the 80,000-triangle arcs at 2%
// 0.060 / 0.067 grid spacings (+0.058 / +0.061 inward), more than at 10%; now 0.036 / 0.037.
// Below kUnblurMaxNoise the bend is the line's over three fit
// radii (the bent frame's); from it, the snake's line wanders with the noisy field's crest and
// its bend over three radii follows the wander as much as the crest (the correction moved 20%
// cells both ways: 24,200-triangle sine ridge 0.098 -> 0.138 grid spacings), so the bend is read
// from the localised line (the fits' smoothed offsets applied) over kWanderBendSpan fit radii.
constexpr double kUnblurMaxNoise = 0.05;
// Over 6 fit radii the bend read on a straight crest's localised line at 20% noise was large
// enough that it was shrunk toward 0 by 0.04 / sigma; with the jets as wide against the object on
// fine meshes (sigma 5.4 edges at 245,000 triangles) that took almost all of a real bend's
// correction away (0.003-0.04 edges applied where sigma^2 / 2R is 0.12), and the 245,000-triangle
// curved crests at 20% lay 0.09-0.11 grid spacings inside their bends. Over 10 radii, unshrunk:
// bench_accuracy's 20% cells, 12 nearer (245,000-triangle arcs 0.121 / 0.130 -> 0.095 / 0.104,
// sines 0.124 / 0.133 -> 0.107 / 0.110; 80,000-triangle arcs 0.107 / 0.099 -> 0.101 / 0.093), 4
// further (the straight 245,000-triangle ridge and valley 0.079 / 0.076 -> 0.083 / 0.084, the
// 24,200-triangle sine ridge 0.077 -> 0.081, valley 0.068 -> 0.070); over 6 unshrunk or shrunk by
// 0.01 / sigma, or over 14 unshrunk, the 245,000-triangle sine valley stayed above 0.114.
constexpr double kWanderBendSpan = 10;
// The blur's width (sigma) times the line's curvature up to which the first-order shift is
// applied. Beyond it, on the 5,000-triangle arcs (0.13-0.14), the lines lay nearer than the
// shift predicts (0.02-0.05 grid spacings inside the bend, not 0.15) and the correction put
// them further off on the other side.
constexpr double kUnblurMaxBend = 0.1;
// ... and where the blur is narrow against the crest: sigma at most this share of the fitted
// profile's half width. The shift is a first-order expansion in sigma; measured on
// bench_accuracy's fields at 10% noise, the field's own crest lay 0.85 of sigma^2 / 2R into the
// bend at 245,000 triangles (sigma / half width 0.44), 0.4-0.8 at 24,200 (0.53-0.60), and at
// 5,000 (0.84) the correction put sines further off.
constexpr double kUnblurMaxWidthShare = 0.75;
// The share of the first-order shift taken: the measured offsets above lie below it, and the
// full shift put the 24,200-triangle sines further off (0.052 -> 0.067 grid spacings) where
// three quarters take every 10% curved cell nearer.
constexpr double kUnblurGain = 0.75;

}  // namespace

void check_crest_options(const CrestOptions& o) {
  using C = CrestOptions;
  if (!C::radius_range.contains(o.radius) || !C::radius_range.contains(o.max_radius) || !C::max_shift_range.contains(o.max_shift) ||
      !C::max_key_shift_range.contains(o.max_key_shift) ||
      !C::smoothing_passes_range.contains(o.smoothing_passes))
    throw InvalidInputError("crest options out of range (radius, max_radius " + describe(C::radius_range) + ", max_shift, max_key_shift " +
                            describe(C::max_shift_range) + ", smoothing_passes " + describe(C::smoothing_passes_range) + ")");
}

CrestResult localize_crest(const PreparedMesh& mesh, const FeatureStrip& strip, const FlatStrip& flat,
                           const std::vector<StripPoint>& points, double feature_sign, const CrestOptions& o,
                           const std::array<CrestEnd, 2>& ends) {
  CrestResult result;
  result.points = points;
  if (!o.enabled || points.size() < 3 || !(strip.mean_edge_length > 0)) return result;
  std::vector<double> field(strip.vertices.size());
  std::vector<char> on_crease(strip.vertices.size());
  for (std::size_t v = 0; v < field.size(); ++v) {
    field[v] = feature_value(mesh.curvature(), strip.vertices[v], feature_sign);
    on_crease[v] = mesh.curvature().on_crease.empty() ? 0 : mesh.curvature().on_crease[strip.vertices[v]];
  }
  const double h = strip.mean_edge_length;
  // Creases marked by noise are scattered; a crease the line follows has its vertices within
  // about an edge of the line.
  const double crease_reach = 1.5 * h;
  // The strip reaches `rings` edges from its line: a narrower strip than the smallest fit would
  // leave the fit extrapolating (a 5-edge piece on 2 rings of a noisy part was moved off).
  const double largest = std::min(o.max_radius, double(strip.rings)) * h;
  // Never finer than the jet fits the field came from where the strip allows: on a noisy mesh
  // their radius grows with the noise, and a shorter fit across the line follows the noise they
  // left. A narrower strip is fitted across its whole width (kNarrowestStripFit).
  const double smallest = std::max(o.radius, mesh.curvature().radius) * h;
  double measuring = smallest;
  const bool narrow = largest < smallest;
  const double noise = mesh.curvature().noise;
  if (narrow) {
    if (!(largest >= kNarrowestStripFit * h && noise >= kNarrowStripMinNoise && noise < kBendFrameMaxNoise)) return result;
    measuring = largest;
  }
  // The half width is measured at `measuring`, the fit may then be as narrow as the jets: where a
  // clean crest's peak is narrower than that, a wider fit reads a bend as an offset into it
  // (bench_accuracy's 5,000-triangle sines: 0.054 grid spacings off at 3 edges, 0.025 at the jets'
  // 2.2). Without jets (the cotangent field) `measuring` stays the floor.
  const double jets = mesh.curvature().radius;
  const double lowest = jets > 0 ? std::min(measuring, jets * h) : measuring;
  // A strip narrower than the measuring fits is fitted across its whole width: nothing to measure.
  // Fits on exact or clean meshes take a symmetric window (symmetric_reach); on noisy ones the
  // cut costs the fit vertices it needs (bench_accuracy, 8 seeds: 24,200-80,000-triangle curved
  // crests at 10-30% noise 14 cells nearer, 5 further, the arc ridge at 80,000 and 20% 0.128 ->
  // 0.154 grid spacings).
  const bool symmetric = noise < kNarrowStripMinNoise;
  const double radius = narrow ? largest
                               : line_fit_radius(flat, field, on_crease, crease_reach, h, symmetric, points, measuring,
                                                 largest, lowest);
  const std::size_t n = points.size();
  std::vector<double> offsets(n, std::nan(""));
  std::vector<Eigen::Vector2d> normals(n);
  for (std::size_t i = 1; i + 1 < n; ++i) normals[i] = normal_at(points, i);
  normals.front() = end_normal(points, 0, radius), normals.back() = end_normal(points, 1, radius);
  // The bend over three fit radii: the crest's, not the line's ripple at the scale of one fit,
  // which measuring from it would amplify (a ripple bent one way reads as a crest bent the other).
  const bool bent_frame = o.follow_bend && noise < kBendFrameMaxNoise;
  const std::vector<double> bends = bent_frame ? line_bends(points, normals, 3 * radius) : std::vector<double>(n, 0.0);
  const VertexGrid grid(flat, radius);
  const FitInput in{flat, grid, field, on_crease, crease_reach, h, symmetric};
  std::array<bool, 2> moves{false, false};  // ends whose fit found a crest within reach
  std::vector<double> half_widths(n, std::nan(""));
  for (std::size_t i = 0; i < n; ++i) {
    const bool end = i == 0 || i + 1 == n;
    const CrestEnd& at = ends[i == 0 ? 0 : 1];
    if (end && at.placed) {
      // Where the piece beside it put this end: both pieces meet there.
      offsets[i] = (at.placed->uv - points[i].uv).dot(normals[i]);
      result.points[i] = *at.placed;
      ++result.moved;
      continue;
    }
    if (end && !(at.movable && o.move_keys)) {
      offsets[i] = 0;
      continue;
    }
    const CrestFit fit = fit_crest(in, points[i].uv, normals[i], bends[i], radius, kMinCrestDrop);
    const double s = fit.offset;
    half_widths[i] = fit.half_width;
    const double reach = (end ? o.max_key_shift : o.max_shift) * h;
    if (std::abs(s) <= reach) offsets[i] = s, ++result.moved;
    else if (end) offsets[i] = 0;  // no crest within reach: the end stays on its vertex
    else continue;
    if (end) moves[i == 0 ? 0 : 1] = std::abs(s) <= reach;
  }
  std::vector<double> smoothed = smooth_offsets(offsets, o.smoothing_passes);
  if (o.unblur && mesh.curvature().smoothing_passes > 0 && noise < kBendFrameMaxNoise) {
    const double variance = field_blur_variance(mesh.curvature(), h, strip.mean_squared_edge_length);
    const double sigma = std::sqrt(variance);
    const bool wandering = noise >= kUnblurMaxNoise;
    const std::vector<double> line_bend = wandering ? localised_bends(points, normals, smoothed, kWanderBendSpan * radius)
                                          : bent_frame ? bends
                                                       : line_bends(points, normals, 3 * radius);
    for (std::size_t i = 0; i < n; ++i) {
      const bool end = i == 0 || i + 1 == n;
      if ((end && !moves[i == 0 ? 0 : 1]) || (!end && !std::isfinite(offsets[i]) && smoothed[i] == 0)) continue;
      if (sigma * std::abs(line_bend[i]) <= kUnblurMaxBend && sigma <= kUnblurMaxWidthShare * half_widths[i])
        smoothed[i] -= kUnblurGain * 0.5 * variance * line_bend[i];
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const bool end = i == 0 || i + 1 == n;
    if (end && !moves[i == 0 ? 0 : 1]) continue;
    if (smoothed[i] != 0) move_along_segment(strip, flat, result.points[i], points[i].uv + smoothed[i] * normals[i]);
  }
  return result;
}

}  // namespace featureline
