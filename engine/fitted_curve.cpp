#include "engine/fitted_curve.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "engine/errors.h"
#include "engine/internal/geometry.h"
#include "engine/internal/order_statistics.h"
#include "engine/internal/stopwatch.h"
#include "engine/internal/vertex_map.h"
#include "engine/line_averaging.h"

namespace featureline {
namespace {

// Stations (the points the fits are made at) are this far apart along the line, in its edge
// length (FittedCurveLine::edge_length): two per edge, so each control interval holds several.
constexpr double kStationSpacing = 0.5;
// Vertices closer than this to the line (local edge lengths) are left out of the first side
// fits: the surface line may lie that far off the true crease.
constexpr double kSideGap = 0.5;
// ... and closer than this to the fitted crease from then on (a noisy crease's vertices belong
// to both sides equally).
constexpr double kCreaseGap = 0.25;
// Where the mesh marks a crease, its fit reaches this many fit radii along the line (a Gaussian
// that many times longer along it than across): the sides' planes average the noise of three
// times the vertices. Their residuals are then measured over the whole ball of that radius, so a
// crease point is trusted only where both sides stay planar that far out; near a corner or where
// a side curves, a plane fit is biased and the surface line is the better point (bench_accuracy,
// noisy CAD: the fitted curve 0.95 of the initial line's distance with the round neighbourhood,
// 0.80 with this one).
constexpr double kCreaseStretch = 3.0;
// ... shortened along a bending line to where the bend takes it this many local edge lengths off
// its tangent (a ring-shaped crease 13 edges in radius: 0.25 grid spacings off at 10% noise with
// the full stretch, 0.15 with this limit and 0.14 with the round neighbourhood).
constexpr double kStretchSagitta = 1.0;
// Fewest vertices a side, or the surface, is fitted from.
constexpr int kMinSideVertices = 6;
constexpr int kMinSurfaceVertices = 10;
// Re-weighting rounds of the robust fits (Tukey's biweight, c = 4.685 robust sigmas).
constexpr int kRobustRounds = 3;
constexpr double kTukey = 4.685;
// Two planes are the better model of a neighbourhood when their residuals' median is below this
// share of a quadric's: a quadric follows a smooth ridge, not a crease's kink.
constexpr double kCreaseResidualShare = 0.75;
// A crease fit is trusted where its sides' median absolute residual is at most this many times
// the mesh's estimated noise (RMS along the normal, a length: CurvatureField::noise_length; a
// normal distribution's median absolute value is 0.67 of it), taken as at least kCleanNoise
// local edge lengths.
constexpr double kResidualPerNoise = 1.5;
constexpr double kCleanNoise = 0.01;
// A sharp bend of the surface line: it turns by more than this (radians) between its directions
// over the edge before and the edge after a point. bench_accuracy's rounded slab turns 22.5
// degrees at each of the 4 vertices of a corner arc; a ring of radius 13 edges 4.4 per edge.
constexpr double kSharpBend = 15 * M_PI / 180;
// The distance between a crease point and the line's (in units of the noise estimate) at which
// the blended point lies three quarters of the way from the line's point to the crease point
// (half way when they coincide, all the way when they lie far apart).
constexpr double kBlendNoise = 4.0;
// Estimated noise (local edge lengths) below which a mesh is clean for the curve's ends
// (smooth_points): bench_accuracy's clean fields read 0.000-0.004, at 10% noise 0.036.
constexpr double kCleanMeshNoise = 0.02;
// A crease run's scatter read at fewer points than this says nothing (exact_run_scatter).
constexpr std::size_t kMinRunResiduals = 5;
// A corner's point weighs this much more than others, so the spline pieces meet there.
constexpr double kCornerWeight = 1e3;

enum class Source { crease, surface, exact, line };

struct Station {
  Eigen::Vector3d p;     ///< on the surface line
  double u = 0;          ///< arc length along the line
  std::uint32_t seed = 0;  ///< a mesh vertex near p
  double edge = 1;       ///< local edge length there (at most the line's edge)
  bool exact = false;    ///< on an exact crease run (FittedCurveLine::exact)
  bool noisy_crease = false;  ///< on a noisy mesh's crease run (FittedCurveLine::noisy_crease)
};

// The line resampled at even arc length (the closing segment included for a closed line, whose
// stations do not repeat the first); `unit` is its edge length (FittedCurveLine::edge_length).
std::vector<Station> stations_along(const PreparedMesh& pm, const FittedCurveLine& line, double& unit, double& length) {
  const bool closed = line.closed;
  std::vector<SurfacePoint> path = line.points;
  std::vector<char> exact = line.exact, noisy = line.noisy_crease;
  exact.resize(path.size(), 0);
  noisy.resize(path.size(), 0);
  if (closed) path.push_back(line.points.front()), exact.push_back(exact.front()), noisy.push_back(noisy.front());
  std::vector<double> s(path.size(), 0.0);
  for (std::size_t i = 1; i < path.size(); ++i) s[i] = s[i - 1] + (path[i].position - path[i - 1].position).norm();
  length = s.back();
  unit = line.edge_length;
  if (!(unit > 0)) {
    unit = 0;
    for (const auto& q : line.points) unit += pm.local_edge_length(nearest_corner(pm, q));
    unit /= double(line.points.size());
  }
  const double spacing = kStationSpacing * unit;
  const std::size_t intervals = std::max<std::size_t>(closed ? 4 : 1, std::size_t(std::lround(length / spacing)));
  const std::size_t count = closed ? intervals : intervals + 1;
  std::vector<Station> stations(count);
  std::size_t segment = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const double u = length * double(i) / double(intervals);
    while (segment + 2 < path.size() && s[segment + 1] < u) ++segment;
    const double span = s[segment + 1] - s[segment];
    const double f = span > 0 ? std::clamp((u - s[segment]) / span, 0.0, 1.0) : 0.0;
    Station& st = stations[i];
    st.p = (1 - f) * path[segment].position + f * path[segment + 1].position;
    st.u = u;
    st.seed = nearest_corner(pm, path[f < 0.5 ? segment : segment + 1]);
    st.edge = std::min(pm.local_edge_length(st.seed), unit);
    st.exact = exact[segment] && exact[segment + 1];
    st.noisy_crease = noisy[segment] && noisy[segment + 1];
  }
  return stations;
}

// The mesh vertices within a ball, found by walking edges from a vertex near its centre.
class Neighbourhood {
 public:
  explicit Neighbourhood(std::size_t vertices) { seen_.begin(vertices); }
  const std::vector<std::uint32_t>& gather(const PreparedMesh& pm, std::uint32_t seed, const Eigen::Vector3d& centre,
                                           double radius) {
    seen_.begin(pm.n_vertices());
    found_.clear();
    found_.push_back(seed);
    seen_.set(seed, 0);
    for (std::size_t head = 0; head < found_.size(); ++head) {
      const std::uint32_t v = found_[head];
      for (auto k = pm.neighbor_offsets()[v]; k < pm.neighbor_offsets()[v + 1]; ++k) {
        const std::uint32_t w = pm.neighbors()[k];
        if (seen_.contains(w)) continue;
        seen_.set(w, 0);
        if ((pm.positions()[w] - centre).norm() <= radius) found_.push_back(w);
      }
    }
    return found_;
  }
  bool contains(std::uint32_t v) const { return seen_.contains(v); }

 private:
  StampedMap seen_;
  std::vector<std::uint32_t> found_;
};

// Tukey's biweight of residual r at robust scale sigma.
double tukey(double r, double sigma) {
  const double x = r / (kTukey * sigma);
  return std::abs(x) >= 1 ? 0.0 : (1 - x * x) * (1 - x * x);
}

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero(), point = Eigen::Vector3d::Zero();
  bool ok = false;
};

// Weighted least-squares plane (the covariance's smallest eigenvector through the weighted
// centroid), its normal turned toward `up`.
Plane fit_plane(const std::vector<Eigen::Vector3d>& x, const std::vector<double>& w, const Eigen::Vector3d& up) {
  Plane plane;
  double total = 0;
  int used = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) total += w[i], centroid += w[i] * x[i], used += w[i] > 0;
  if (used < kMinSideVertices || !(total > 0)) return plane;
  centroid /= total;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) covariance += w[i] * (x[i] - centroid) * (x[i] - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  if (eigen.info() != Eigen::Success) return plane;
  // A side whose vertices lie along a line has no plane.
  if (!(eigen.eigenvalues()(1) > 1e-6 * eigen.eigenvalues()(2))) return plane;
  plane.normal = eigen.eigenvectors().col(0);
  if (plane.normal.dot(up) < 0) plane.normal = -plane.normal;
  plane.point = centroid;
  plane.ok = true;
  return plane;
}

// The local frame at a station: the mean surface normal, the line's direction and across it.
struct Frame {
  Eigen::Vector3d normal, along, across;
};

// What one station's neighbourhood says: its vertices, their Gaussian weights, and the frame.
struct Patch {
  /// The line's curvature in the tangent plane (toward +across): the sides are told apart by
  /// their distance from the line bent so, not from its tangent.
  double bend = 0;
  std::vector<Eigen::Vector3d> x;
  std::vector<double> gauss;
  Frame frame;
  double edge = 1;
};

// A side's plane as the equation normal . (x - p) = offset, normal of unit length.
struct SidePlane {
  Eigen::Vector3d normal;
  double offset = 0;
};

// How far d (from a point of the line) lies across the line bent by patch.bend, along `across`.
double across_bent_line(const Patch& patch, const Eigen::Vector3d& d, const Eigen::Vector3d& across) {
  const double along = d.dot(patch.frame.along);
  return d.dot(across) - 0.5 * patch.bend * along * along;
}

// The point of both planes nearest p: p + a nA + b nB from the 2 x 2 normal equations; nothing
// when the planes are closer to parallel than `min_sine`.
std::optional<Eigen::Vector3d> nearest_common_point(const SidePlane& a, const SidePlane& b, const Eigen::Vector3d& p,
                                                    double min_sine) {
  const double c = a.normal.dot(b.normal), sine2 = 1 - c * c;
  if (!(sine2 > min_sine * min_sine) || sine2 < 1e-12) return std::nullopt;
  const double x = (a.offset - c * b.offset) / sine2, y = (b.offset - c * a.offset) / sine2;
  return p + x * a.normal + y * b.normal;
}

// One side refitted as a height field over its plane, h = c0 + c1 a + c2 u + c3 a^2 + c4 a u
// (a along the line, u across it in the plane, h along its normal, centred at p): the a^2 and
// a u terms take up the side's bending along the line (a curved crease), which would otherwise
// shift a plane fitted over the neighbourhood off the crease at p. Its tangent plane at a = 0.
std::optional<SidePlane> side_tangent_plane(const Patch& patch, const Plane& plane, const std::vector<double>& w,
                                            const Eigen::Vector3d& p, double& residual) {
  Eigen::Vector3d along = patch.frame.along - patch.frame.along.dot(plane.normal) * plane.normal;
  if (!(along.norm() > 1e-6)) return std::nullopt;
  along.normalize();
  const Eigen::Vector3d across = plane.normal.cross(along);
  Eigen::Matrix<double, 5, 5> normal = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> rhs = Eigen::Matrix<double, 5, 1>::Zero();
  auto coordinates = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = (x - p) / patch.edge;  // scaled, so the system is well conditioned
    return Eigen::Vector3d(d.dot(along), d.dot(across), d.dot(plane.normal));
  };
  auto basis = [](const Eigen::Vector3d& q) {
    Eigen::Matrix<double, 5, 1> b;
    b << 1, q.x(), q.y(), q.x() * q.x(), q.x() * q.y();
    return b;
  };
  for (std::size_t i = 0; i < patch.x.size(); ++i) {
    if (!(w[i] > 0)) continue;
    const Eigen::Vector3d q = coordinates(patch.x[i]);
    normal += w[i] * basis(q) * basis(q).transpose();
    rhs += w[i] * q.z() * basis(q);
  }
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> solver(normal);
  if (solver.info() != Eigen::Success || !solver.isPositive() || !(std::abs(normal.determinant()) > 1e-12))
    return std::nullopt;
  const Eigen::Matrix<double, 5, 1> c = solver.solve(rhs);
  if (!c.allFinite()) return std::nullopt;
  std::vector<double> magnitudes;
  for (std::size_t i = 0; i < patch.x.size(); ++i)
    if (w[i] > 0) {
      const Eigen::Vector3d q = coordinates(patch.x[i]);
      magnitudes.push_back(std::abs(q.z() - c.dot(basis(q))) * patch.edge);
    }
  residual = median_of(magnitudes);
  // h - c1 a - c2 u = c0 at a = 0, in unscaled coordinates.
  const Eigen::Vector3d n = plane.normal - c(1) * along - c(2) * across;
  return SidePlane{n.normalized(), c(0) * patch.edge / n.norm()};
}

// The point where the two fitted sides meet nearest p, or nothing when the sides are not two
// distinct planes there. `residual` gets the fit's median absolute residual.
std::optional<Eigen::Vector3d> crease_point(const Patch& patch, const Eigen::Vector3d& p, const FittedCurveOptions& o,
                                            double& residual) {
  const std::size_t n = patch.x.size();
  std::vector<int> side(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = across_bent_line(patch, patch.x[i] - p, patch.frame.across);
    side[i] = s > kSideGap * patch.edge ? 1 : s < -kSideGap * patch.edge ? -1 : 0;
  }
  std::vector<double> robust(n, 1.0), w[2] = {std::vector<double>(n), std::vector<double>(n)};
  Plane planes[2];
  const double min_sine = std::sin(o.min_dihedral * M_PI / 180);
  for (int round = 0; round <= kRobustRounds; ++round) {
    for (int k = 0; k < 2; ++k) {
      const int want = k == 0 ? 1 : -1;
      for (std::size_t i = 0; i < n; ++i) w[k][i] = side[i] == want ? patch.gauss[i] * robust[i] : 0.0;
      planes[k] = fit_plane(patch.x, w[k], patch.frame.normal);
      if (!planes[k].ok) return std::nullopt;
    }
    const auto point = nearest_common_point({planes[0].normal, planes[0].normal.dot(planes[0].point - p)},
                                            {planes[1].normal, planes[1].normal.dot(planes[1].point - p)}, p, min_sine);
    if (!point) return std::nullopt;
    if (round == kRobustRounds) break;
    // Re-assign every vertex to the side of the fitted crease it lies on, then weigh it by its
    // residual to its side's plane (outliers and a third face near a corner drop out).
    Eigen::Vector3d across = planes[0].normal.cross(planes[1].normal).cross(patch.frame.normal);
    if (!(across.norm() > 1e-12)) return std::nullopt;
    if (across.dot(patch.frame.across) < 0) across = -across;
    across.normalize();
    std::vector<double> residuals[2];
    std::vector<double> r(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double s = across_bent_line(patch, patch.x[i] - *point, across);
      side[i] = s > kCreaseGap * patch.edge ? 1 : s < -kCreaseGap * patch.edge ? -1 : 0;
      if (side[i] == 0) continue;
      const Plane& plane = planes[side[i] > 0 ? 0 : 1];
      r[i] = plane.normal.dot(patch.x[i] - plane.point);
      residuals[side[i] > 0 ? 0 : 1].push_back(std::abs(r[i]));
    }
    const double floor = 1e-3 * patch.edge;
    const double sigma[2] = {std::max(floor, 1.4826 * median_of(residuals[0])), std::max(floor, 1.4826 * median_of(residuals[1]))};
    for (std::size_t i = 0; i < n; ++i) robust[i] = side[i] == 0 ? 0.0 : tukey(r[i], sigma[side[i] > 0 ? 0 : 1]);
  }
  // The sides' tangent planes at p's cross-section, their bending along the line taken up.
  double residuals[2] = {0, 0};
  const auto a = side_tangent_plane(patch, planes[0], w[0], p, residuals[0]);
  const auto b = side_tangent_plane(patch, planes[1], w[1], p, residuals[1]);
  if (!a || !b) return std::nullopt;
  residual = 0.5 * (residuals[0] + residuals[1]);
  return nearest_common_point(*a, *b, p, min_sine);
}

// The robust quadric height field h = c0 + c1 a + c2 s + c3 a^2 + c4 a s + c5 s^2 over the
// frame (a along the line, s across it, h along the normal) centred at p: the point on it above
// p, or nothing when too few vertices carry weight. `residual` gets its median absolute residual.
std::optional<Eigen::Vector3d> surface_point(const Patch& patch, const Eigen::Vector3d& p, double& residual) {
  const std::size_t n = patch.x.size();
  if (n < std::size_t(kMinSurfaceVertices)) return std::nullopt;
  // Vertices on both sides of the line, or the fit across it is an extrapolation (a CAD part's
  // outline whose faces reach across the part with no vertex in between).
  int sides[2] = {0, 0};
  for (const auto& x : patch.x) {
    const double s = (x - p).dot(patch.frame.across);
    if (std::abs(s) > kSideGap * patch.edge) ++sides[s > 0 ? 0 : 1];
  }
  if (std::min(sides[0], sides[1]) < kMinSideVertices / 2) return std::nullopt;
  std::vector<double> robust(n, 1.0), r(n, 0.0);
  Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero();
  for (int round = 0; round <= kRobustRounds; ++round) {
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d d = (patch.x[i] - p) / patch.edge;  // scaled, so the system is well conditioned
      const double a = d.dot(patch.frame.along), s = d.dot(patch.frame.across), h = d.dot(patch.frame.normal);
      Eigen::Matrix<double, 6, 1> basis;
      basis << 1, a, s, a * a, a * s, s * s;
      const double w = patch.gauss[i] * robust[i];
      normal += w * basis * basis.transpose();
      rhs += w * h * basis;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal);
    if (solver.info() != Eigen::Success || !solver.isPositive() || !(std::abs(normal.determinant()) > 1e-12))
      return std::nullopt;
    c = solver.solve(rhs);
    std::vector<double> magnitudes(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d d = (patch.x[i] - p) / patch.edge;
      const double a = d.dot(patch.frame.along), s = d.dot(patch.frame.across), h = d.dot(patch.frame.normal);
      r[i] = h - (c(0) + c(1) * a + c(2) * s + c(3) * a * a + c(4) * a * s + c(5) * s * s);
      magnitudes[i] = std::abs(r[i]);
    }
    residual = median_of(magnitudes) * patch.edge;
    const double sigma = std::max(1e-3, 1.4826 * median_of(magnitudes));
    for (std::size_t i = 0; i < n; ++i) robust[i] = tukey(r[i], sigma);
  }
  if (!std::isfinite(c(0))) return std::nullopt;
  return p + c(0) * patch.edge * patch.frame.normal;
}

// Whether an edge of the line's sign (any sign when 0) marked as a crease joins two vertices
// of the patch within half its radius of p.
bool marked_crease_near(const PreparedMesh& pm, const Neighbourhood& ball, const std::vector<std::uint32_t>& vertices,
                        const Eigen::Vector3d& p, double radius, double sign) {
  for (const std::uint32_t v : vertices) {
    if ((pm.positions()[v] - p).norm() > radius) continue;
    for (auto k = pm.neighbor_offsets()[v]; k < pm.neighbor_offsets()[v + 1]; ++k) {
      if (pm.is_crease_slot(k, sign) && ball.contains(pm.neighbors()[k])) return true;
    }
  }
  return false;
}

// Direction of the line at station i (central difference; one-sided at an open line's ends).
Eigen::Vector3d line_direction(const std::vector<Station>& st, std::size_t i, bool closed) {
  const std::size_t n = st.size();
  const std::size_t prev = closed ? (i + n - 1) % n : (i == 0 ? 0 : i - 1);
  const std::size_t next = closed ? (i + 1) % n : std::min(n - 1, i + 1);
  return st[next].p - st[prev].p;
}

// Station i's neighbourhood, weighted and framed.
Patch make_patch(const PreparedMesh& pm, const std::vector<std::uint32_t>& vertices, const std::vector<Station>& st,
                 std::size_t i, bool closed, double radius) {
  Patch patch;
  patch.edge = st[i].edge;
  const double sigma = radius / 2;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (const std::uint32_t v : vertices) {
    const double d = (pm.positions()[v] - st[i].p).norm();
    patch.x.push_back(pm.positions()[v]);
    patch.gauss.push_back(std::exp(-0.5 * d * d / (sigma * sigma)));
    normal += patch.gauss.back() * pm.vertex_normals()[v];
  }
  if (!(normal.norm() > 1e-12)) normal = pm.vertex_normals()[st[i].seed];
  patch.frame.normal = normal.normalized();
  Eigen::Vector3d along = line_direction(st, i, closed);
  along -= along.dot(patch.frame.normal) * patch.frame.normal;
  if (!(along.norm() > 1e-12)) along = patch.frame.normal.unitOrthogonal();
  patch.frame.along = along.normalized();
  patch.frame.across = patch.frame.along.cross(patch.frame.normal);
  return patch;
}

// The line's curvature at station i in the tangent plane of `frame`, toward frame.across: the
// parabola fitted to the stations within `reach` of arc length (a noisy line's zig-zag averages
// out over them).
double line_bend(const std::vector<Station>& st, std::size_t i, bool closed, const Frame& frame, double reach) {
  const std::size_t n = st.size();
  ParabolaFit fit(reach);
  auto add = [&](const Eigen::Vector3d& q) {
    const Eigen::Vector3d d = q - st[i].p;
    fit.add(d.dot(frame.along), d.dot(frame.across));
  };
  add(st[i].p);
  for (const int step : {-1, 1}) {
    double walked = 0;
    std::size_t at = i;
    for (std::size_t k = 1; 2 * k < n; ++k) {
      if (!closed && (step < 0 ? k > i : i + k >= n)) break;
      const std::size_t next = step < 0 ? (i + n - k) % n : (i + k) % n;
      walked += (st[next].p - st[at].p).norm();
      at = next;
      if (walked > reach) break;
      add(st[at].p);
    }
  }
  return fit.curvature();
}

// The neighbourhood of a crease fit at a station: every vertex within kCreaseStretch radii,
// weighted by a Gaussian kCreaseStretch times longer along the line than across it, in the
// frame of the station's round patch, its sides told apart across the line as it bends there (a
// ring-shaped crease 13 edges in radius curves 3 edges off its tangent 9 edges along it).
Patch stretched_patch(const PreparedMesh& pm, Neighbourhood& ball, const std::vector<Station>& st, std::size_t i,
                      bool closed, const Patch& round, double radius) {
  const Station& station = st[i];
  Patch patch;
  patch.edge = round.edge;
  patch.frame = round.frame;
  patch.bend = line_bend(st, i, closed, round.frame, kCreaseStretch * radius);
  // Along a bending crease the stretch ends where the bend takes the crease kStretchSagitta off
  // its tangent: the sides' a^2 and a u terms follow a bend only so far.
  const double stretch =
      patch.bend != 0
          ? std::clamp(std::sqrt(2 * kStretchSagitta * round.edge / std::abs(patch.bend)) / radius, 1.0, kCreaseStretch)
          : kCreaseStretch;
  const double sigma = radius / 2, sigma_along = stretch * sigma;
  for (const std::uint32_t v : ball.gather(pm, station.seed, station.p, kCreaseStretch * radius)) {
    const Eigen::Vector3d d = pm.positions()[v] - station.p;
    const double along = d.dot(round.frame.along), rest2 = d.squaredNorm() - along * along;
    patch.x.push_back(pm.positions()[v]);
    patch.gauss.push_back(std::exp(-0.5 * (along * along / (sigma_along * sigma_along) + rest2 / (sigma * sigma))));
  }
  return patch;
}

// The crease point moved toward the surface line's point when the two lie within the noise of
// each other: then both are noisy estimates of the same crease point (a noisy crease run's line
// lies on its vertices) whose errors are largely independent, and their mean is the better one
// (bench_accuracy, noisy CAD: the crease points alone 0.92 of the initial line's distance, their
// means 0.84); when they lie much further apart than the noise, the line is off the crease (it
// zig-zags along edges across faces) and the crease point is kept.
Eigen::Vector3d blend_with_line(const Eigen::Vector3d& crease, const Eigen::Vector3d& line, double noise) {
  const double d2 = (crease - line).squaredNorm(), s2 = kBlendNoise * kBlendNoise * noise * noise;
  const double t = 0.5 + 0.5 * d2 / (d2 + s2);
  return line + t * (crease - line);
}

// The fitted point of station i and where it came from (module comment in the header).
std::pair<Eigen::Vector3d, Source> station_point(const PreparedMesh& pm, Neighbourhood& ball, const std::vector<Station>& st,
                                                 std::size_t i, bool closed, double sign, const FittedCurveOptions& o) {
  const Station& station = st[i];
  if (station.exact) return {station.p, Source::exact};
  const double radius = o.radius * station.edge;
  const std::vector<std::uint32_t>& vertices = ball.gather(pm, station.seed, station.p, radius);
  const Patch patch = make_patch(pm, vertices, st, i, closed, radius);
  const double max_shift = o.max_shift * station.edge;
  double surface_residual = HUGE_VAL;
  const auto on_surface = surface_point(patch, station.p, surface_residual);
  const bool marked = marked_crease_near(pm, ball, vertices, station.p, radius / 2, sign);
  // A clean mesh has no noise to average: its crease points come from the round neighbourhood.
  const bool stretch = marked && pm.curvature().noise >= kCleanMeshNoise;
  double crease_residual = HUGE_VAL;
  const auto crease =
      crease_point(stretch ? stretched_patch(pm, ball, st, i, closed, patch, radius) : patch, station.p, o, crease_residual);
  // A crease where the two sides fit better than one smooth surface: clearly so, or at all where
  // the mesh marks crease edges of the line's sign here (noise blurs the comparison on weak creases).
  const bool two_sides = crease_residual < (marked ? 1.0 : kCreaseResidualShare) * surface_residual;
  // ... and where two planes describe the sides down to the noise: a tight bend of the crease
  // within the radius, or a third face near a corner, leaves residuals the fit cannot explain.
  const double noise = std::max(pm.curvature().noise_length, kCleanNoise * station.edge);
  const bool described = crease_residual <= kResidualPerNoise * noise;
  if (crease && (station.p - *crease).norm() <= max_shift && two_sides && described)
    return {blend_with_line(*crease, station.p, noise), Source::crease};
  // A marked crease the planes could not describe is no smooth surface either: keep the line.
  if (!marked && on_surface && (station.p - *on_surface).norm() <= max_shift) return {*on_surface, Source::surface};
  return {station.p, Source::line};
}

// The direction of points first .. first + count (indices modulo their number): their principal
// axis, pointing from the first to the last, so one point off the line barely turns it.
Eigen::Vector3d principal_direction(const std::vector<Eigen::Vector3d>& x, std::size_t first, std::size_t count) {
  const std::size_t n = x.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j <= count; ++j) mean += x[(first + j) % n];
  mean /= double(count + 1);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j <= count; ++j) covariance += (x[(first + j) % n] - mean) * (x[(first + j) % n] - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  Eigen::Vector3d d = eigen.eigenvectors().col(2);
  if (d.dot(x[(first + count) % n] - x[first % n]) < 0) d = -d;
  return d;
}

// The turn at each point between the directions of the points over `edges` edges before and
// after it (0 that close to an open line's ends).
std::vector<double> turns(const std::vector<Eigen::Vector3d>& x, bool closed, double edges) {
  const std::size_t n = x.size(), k = std::size_t(std::lround(edges / kStationSpacing));
  std::vector<double> turn(n, 0.0);
  if (n < 2 * k + 2) return turn;
  for (std::size_t i = 0; i < n; ++i) {
    if (!closed && (i < k || i + k >= n)) continue;
    const Eigen::Vector3d in = principal_direction(x, i + n - k, k), out = principal_direction(x, i, k);
    turn[i] = std::acos(std::clamp(in.dot(out), -1.0, 1.0));
  }
  return turn;
}

// Corners: where the fitted points' directions over two edges before and after turn by more than
// the corner angle (the largest turn among neighbours) and the surface line turns by half as
// much within an edge. Both, because a noisy surface line kinks at its pinned keys and a fitted
// point can be an outlier (bench_accuracy: the tight rounded corners of the slab need the split;
// a noisy line can still show a false corner at a key, pinned to the line's point there).
std::vector<std::size_t> corners_of(const std::vector<Station>& st, const std::vector<Eigen::Vector3d>& q, bool closed,
                                    double corner_angle) {
  const std::size_t n = q.size(), k = std::size_t(std::lround(1.0 / kStationSpacing));
  std::vector<Eigen::Vector3d> line(n);
  for (std::size_t i = 0; i < n; ++i) line[i] = st[i].p;
  const std::vector<double> fitted_turn = turns(q, closed, 2), line_turn = turns(line, closed, 1);
  const double limit = corner_angle * M_PI / 180;
  std::vector<std::size_t> corners;
  for (std::size_t i = 0; i < n; ++i) {
    if (fitted_turn[i] <= limit) continue;
    bool largest = true, line_turns = false;
    for (std::size_t j = 1; j <= 2 * k && largest; ++j)
      largest = fitted_turn[(i + j) % n] < fitted_turn[i] && fitted_turn[(i + n - j) % n] <= fitted_turn[i];
    for (std::size_t j = 0; j <= k; ++j)
      line_turns = line_turns || line_turn[(i + j) % n] > limit / 2 || line_turn[(i + n - j) % n] > limit / 2;
    if (largest && line_turns) corners.push_back(i);
  }
  return corners;
}

// Uniform cubic B-spline basis at local parameter f in [0, 1] (control points j .. j+3).
std::array<double, 4> cubic_basis(double f) {
  const double g = 1 - f;
  return {g * g * g / 6, (3 * f * f * f - 6 * f * f + 4) / 6, (-3 * f * f * f + 3 * f * f + 3 * f + 1) / 6, f * f * f / 6};
}

// A penalised cubic B-spline (P-spline) through points q at parameters u with weights w:
// least squares on the control points plus `smoothing` (per control point's data weight) times
// their squared second differences, which leave straight lines unbiased. Periodic over
// `period` when it is positive. Returns the spline at the same parameters.
std::vector<Eigen::Vector3d> fit_pspline(const std::vector<double>& u, const std::vector<Eigen::Vector3d>& q,
                                         const std::vector<double>& w, double period, double spacing, double smoothing,
                                         std::size_t& control_points) {
  const bool periodic = period > 0;
  const double u0 = u.front(), span = periodic ? period : u.back() - u.front();
  const std::size_t intervals = std::max<std::size_t>(periodic ? 4 : 1, std::size_t(std::lround(span / spacing)));
  const std::size_t m = periodic ? intervals : intervals + 3;
  control_points = m;
  if (!(span > 0) || q.size() < 4) return q;
  const double h = span / double(intervals);
  auto locate = [&](double x, std::size_t& j, double& f) {
    double t = (x - u0) / h;
    if (periodic) t = std::fmod(t, double(intervals)), t += t < 0 ? double(intervals) : 0;
    j = std::min(intervals - 1, std::size_t(std::max(0.0, std::floor(t))));
    f = t - double(j);
  };
  auto column = [&](std::size_t j, int k) { return periodic ? (j + std::size_t(k)) % m : j + std::size_t(k); };
  std::vector<Eigen::Triplet<double>> entries;  // summed where they repeat
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(Eigen::Index(m), 3);
  double total = 0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    std::size_t j;
    double f;
    locate(u[i], j, f);
    const auto b = cubic_basis(f);
    for (int r = 0; r < 4; ++r) {
      rhs.row(Eigen::Index(column(j, r))) += w[i] * b[std::size_t(r)] * q[i].transpose();
      for (int c = 0; c < 4; ++c)
        entries.emplace_back(Eigen::Index(column(j, r)), Eigen::Index(column(j, c)), w[i] * b[std::size_t(r)] * b[std::size_t(c)]);
    }
    total += std::min(w[i], 1.0);
  }
  const double lambda = smoothing * total / double(m);
  const std::size_t differences = periodic ? m : m - 2;
  for (std::size_t j = 0; j < differences; ++j) {
    const std::size_t idx[3] = {j, (j + 1) % m, (j + 2) % m};
    const double coefficient[3] = {1, -2, 1};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) entries.emplace_back(Eigen::Index(idx[r]), Eigen::Index(idx[c]), lambda * coefficient[r] * coefficient[c]);
  }
  // The system is banded (periodic: banded plus corners), up to a few thousand wide.
  const auto size = Eigen::Index(m);
  Eigen::SparseMatrix<double> sparse(size, size);
  sparse.setFromTriplets(entries.begin(), entries.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(sparse);
  if (solver.info() != Eigen::Success) return q;
  const Eigen::MatrixXd control = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !control.allFinite()) return q;
  std::vector<Eigen::Vector3d> out(u.size());
  for (std::size_t i = 0; i < u.size(); ++i) {
    std::size_t j;
    double f;
    locate(u[i], j, f);
    const auto b = cubic_basis(f);
    out[i] = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) out[i] += b[std::size_t(k)] * control.row(Eigen::Index(column(j, k))).transpose();
  }
  return out;
}

// The P-spline made robust: re-fitted with Tukey weights of the points' distances to it, so a
// fitted point far off (a bad intersection near a third face) does not pull the curve. Points
// weighing more than 1 (corners) keep their weight. `floor` bounds the robust scale below.
std::vector<Eigen::Vector3d> robust_pspline(const std::vector<double>& u, const std::vector<Eigen::Vector3d>& q,
                                            const std::vector<double>& w, double period, double spacing,
                                            double smoothing, double floor, std::size_t& control_points) {
  std::vector<Eigen::Vector3d> fitted = fit_pspline(u, q, w, period, spacing, smoothing, control_points);
  std::vector<double> weights = w, distance(q.size());
  for (int round = 0; round < kRobustRounds; ++round) {
    for (std::size_t i = 0; i < q.size(); ++i) distance[i] = (fitted[i] - q[i]).norm();
    const double sigma = std::max(floor, 1.4826 * median_of(distance));
    for (std::size_t i = 0; i < q.size(); ++i) weights[i] = w[i] > 1 ? w[i] : w[i] * tukey(distance[i], sigma);
    fitted = fit_pspline(u, q, weights, period, spacing, smoothing, control_points);
  }
  return fitted;
}

// The spline through the stations' fitted points, in pieces between corners (whose points are
// pinned to the surface line's), sampled at the stations.
std::vector<Eigen::Vector3d> smooth_points(const std::vector<Station>& st, std::vector<Eigen::Vector3d> q,
                                           const std::vector<std::size_t>& corners, bool closed, bool pin_ends,
                                           double length, double spacing, const FittedCurveOptions& o,
                                           FittedCurveResult& result) {
  const std::size_t n = st.size();
  result.corners = corners.size();
  std::vector<double> w(n, 1.0);
  for (const std::size_t c : corners) q[c] = st[c].p, w[c] = kCornerWeight;
  // On a clean mesh an open curve's ends hold to their own fitted points: a P-spline's end
  // control points have only the points of one interval to go by, and the penalty bends the
  // curve's ends off (clean 5,000-24,200-triangle sines: 0.4-0.7 grid spacings off at the keys).
  // On a noisy one an end's fitted point is as noisy as any other, and held it pulls the curve.
  if (!closed && pin_ends) w.front() = kCornerWeight, w.back() = kCornerWeight;
  std::vector<double> u(n);
  for (std::size_t i = 0; i < n; ++i) u[i] = st[i].u;
  const double floor = 1e-2 * spacing / o.control_spacing;  // a hundredth of the mean edge
  if (closed && corners.empty())
    return robust_pspline(u, q, w, length, spacing, o.smoothing, floor, result.control_points);
  // Pieces [from, to] of station indices; a closed line's last piece wraps past its end.
  std::vector<std::pair<std::size_t, std::size_t>> pieces;
  if (closed) {
    for (std::size_t k = 0; k < corners.size(); ++k)
      pieces.push_back({corners[k], k + 1 < corners.size() ? corners[k + 1] : corners[0] + n});
  } else {
    std::size_t from = 0;
    for (const std::size_t c : corners) pieces.push_back({from, c}), from = c;
    pieces.push_back({from, n - 1});
  }
  std::vector<Eigen::Vector3d> out = q;
  for (const auto& [from, to] : pieces) {
    std::vector<double> pu, pw;
    std::vector<Eigen::Vector3d> pq;
    for (std::size_t k = from; k <= to; ++k) {
      pu.push_back(st[k % n].u + (k >= n ? length : 0.0));
      pq.push_back(q[k % n]);
      pw.push_back(w[k % n]);
    }
    std::size_t controls = 0;
    const std::vector<Eigen::Vector3d> fitted = robust_pspline(pu, pq, pw, 0, spacing, o.smoothing, floor, controls);
    result.control_points += controls;
    for (std::size_t k = from; k <= to; ++k) out[k % n] = fitted[k - from];
  }
  return out;
}

double polyline_length_of(const std::vector<Eigen::Vector3d>& points, bool closed) {
  double length = 0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  if (closed && points.size() > 2) length += (points.front() - points.back()).norm();
  return length;
}

}  // namespace

void check_fitted_curve_options(const FittedCurveOptions& o) {
  using F = FittedCurveOptions;
  check_in_range(F::radius_range, o.radius, "fitted.radius");
  check_in_range(F::control_spacing_range, o.control_spacing, "fitted.control_spacing");
  check_in_range(F::smoothing_range, o.smoothing, "fitted.smoothing");
  check_in_range(F::min_dihedral_range, o.min_dihedral, "fitted.min_dihedral");
  check_in_range(F::max_shift_range, o.max_shift, "fitted.max_shift");
  check_in_range(F::corner_angle_range, o.corner_angle, "fitted.corner_angle");
  check_in_range(F::run_averaging_range, o.run_averaging, "fitted.run_averaging");
}

namespace {

// Stations within `radius` edges of a sharp bend of the surface line (a CAD part's tight rounded
// corner): there no side is one smooth sheet over the fit's neighbourhood and the fits cut inside
// the bend, so the line's own point is kept. The bends are read off the line smoothed by the
// spline, so a line zig-zagging along edges across a straight crease has none.
std::vector<char> sharp_bends_within(const std::vector<Station>& st, bool closed, double length, double spacing,
                                     const FittedCurveOptions& o) {
  const std::size_t n = st.size(), reach = std::size_t(std::lround(o.radius / kStationSpacing));
  std::vector<Eigen::Vector3d> line(n);
  std::vector<double> u(n), w(n, 1.0);
  for (std::size_t i = 0; i < n; ++i) line[i] = st[i].p, u[i] = st[i].u;
  std::size_t controls = 0;
  const std::vector<double> turn = turns(fit_pspline(u, line, w, closed ? length : 0, spacing, o.smoothing, controls), closed, 1);
  std::vector<char> near(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (turn[i] <= kSharpBend) continue;
    for (std::size_t j = 0; j <= reach && j < n; ++j) {
      if (closed || i + j < n) near[(i + j) % n] = 1;
      if (closed || i >= j) near[(i + n - j) % n] = 1;
    }
  }
  return near;
}

// The noise the line's crease runs carry and whether to average them (average_noisy_runs).
struct RunNoise {
  double sigma = 0;         ///< per axis, model units
  bool noisy = false;       ///< average the runs
  bool exact_runs = false;  ///< the exact runs too: their scatter, not the mesh, says they are noisy
};

// How far the middle of five consecutive points lies across the line from the quadratic
// (against arc length, least squares) through the other four; nothing when they coincide.
std::optional<double> offset_from_neighbours(const std::array<Eigen::Vector3d, 5>& x) {
  std::array<double, 5> s{0, 0, 0, 0, 0};  // arc length from the middle point
  for (int k = 1; k <= 2; ++k) {
    s[2 + k] = s[1 + k] + (x[2 + k] - x[1 + k]).norm();
    s[2 - k] = s[3 - k] - (x[2 - k] - x[3 - k]).norm();
  }
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero(), rhs = Eigen::Matrix3d::Zero();
  for (const int k : {0, 1, 3, 4}) {
    const Eigen::Vector3d basis(1, s[k], s[k] * s[k]);
    normal += basis * basis.transpose();
    rhs += basis * x[k].transpose();
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> solver(normal);
  if (!solver.isInvertible()) return std::nullopt;
  const Eigen::Matrix3d c = solver.solve(rhs);  // rows: constant, slope and curvature terms
  const Eigen::Vector3d tangent = c.row(1).transpose();
  if (!(tangent.norm() > 0)) return std::nullopt;
  const Eigen::Vector3d offset = x[2] - c.row(0).transpose();
  return (offset - offset.dot(tangent.normalized()) * tangent.normalized()).norm();
}

// The scatter of the line's exact crease runs about a smooth curve, per axis (model units): the
// median offset_from_neighbours of the points with two more of their run on either side.
// Independent noise sigma gives a median of 1.18 sigma (two axes across the line) times
// sqrt(1 + 34/36) (the quadratic's own error at the middle of four evenly spaced points): 1.64
// sigma. 0 when fewer than kMinRunResiduals points have their four.
double exact_run_scatter(const FittedCurveLine& line) {
  const std::size_t n = line.points.size();
  if (line.exact.size() != n || n < 5) return 0;
  std::vector<double> offsets;
  for (std::size_t i = 0; i < n; ++i) {
    if (!line.closed && (i < 2 || i + 2 >= n)) continue;
    std::array<Eigen::Vector3d, 5> x;
    bool run = true;
    for (std::size_t k = 0; k < 5 && run; ++k) {
      const std::size_t j = (i + n + k - 2) % n;
      run = line.exact[j] != 0;
      x[k] = line.points[j].position;
    }
    if (!run) continue;
    if (const auto offset = offset_from_neighbours(x)) offsets.push_back(*offset);
  }
  if (offsets.size() < kMinRunResiduals) return 0;
  return median_of(std::move(offsets)) / 1.64;
}

// The mesh's noise estimate, or where it has none (no vertex it could read the noise at) the
// exact runs' own scatter: a CAD exporter's tessellation with no vertex off its crease outlines
// reads as clean whatever its noise, and its runs, kept as they are on the surface line, are then
// averaged by the curve when they scatter beyond kCleanMeshNoise of the line's edge.
RunNoise run_noise(const PreparedMesh& pm, const FittedCurveLine& line, double unit) {
  const CurvatureField& field = pm.curvature();
  if (field.noise_samples >= kMinNoiseSamples) return {field.noise_length, field.noise >= kCleanMeshNoise, false};
  const double scatter = exact_run_scatter(line);
  return {scatter, scatter >= kCleanMeshNoise * unit, true};
}

// The fitted points of a noisy mesh's crease runs averaged along the line (engine/line_averaging.h),
// in place; returns which were. Not near a sharp bend, where the surface line's own point stands
// (bench_accuracy, noisy CAD: averaging there too put the rounded slab's corners further, 0.046 ->
// 0.053), nor across a corner. The noise is independent from edge to edge, two stations apart,
// and a length whatever the line's edges: on a wing nut's creases, 5 times shorter than their
// vertices' other edges, the mesh's noise in local edge lengths times the line's edge read a
// quarter of it, and the windows stayed short (wing nut 0.69 -> 0.63 of the initial line's
// distance with the noise as a length, all noisy CAD 0.67 -> 0.65).
std::vector<char> average_noisy_runs(const RunNoise& noise, const std::vector<Station>& st, const std::vector<char>& bent,
                                     const std::vector<std::size_t>& corners, bool closed, double length, double unit,
                                     const FittedCurveOptions& o, std::vector<Eigen::Vector3d>& q) {
  const std::size_t n = st.size();
  AveragedLineInput line{std::vector<double>(n), q, std::vector<char>(n, 0), std::vector<char>(n, 0), closed ? length : 0,
                         unit, noise.sigma};
  if (!(o.run_averaging > 0) || !noise.noisy) return line.movable;
  for (const std::size_t c : corners) line.corner[c] = 1;
  for (std::size_t i = 0; i < n; ++i) {
    line.u[i] = st[i].u;
    const bool on_run = st[i].noisy_crease || (noise.exact_runs && st[i].exact);
    line.movable[i] = on_run && !bent[i] && !line.corner[i];
  }
  q = average_along_line(line, {o.run_averaging, 1 / kStationSpacing}).points;
  return line.movable;
}

}  // namespace

FittedCurveResult fit_feature_curve(const PreparedMesh& pm, const FittedCurveLine& line, const FittedCurveOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  check_fitted_curve_options(options);
  FittedCurveResult result;
  result.closed = line.closed && line.points.size() > 2;
  if (line.points.size() < 2) {
    for (const auto& p : line.points) result.points.push_back(p.position);
    result.fallback_share = line.points.empty() ? 0 : 1;
    return result;
  }
  FittedCurveLine open_or_closed = line;
  open_or_closed.closed = result.closed;
  double unit = 1, length = 0;
  const std::vector<Station> stations = stations_along(pm, open_or_closed, unit, length);
  Neighbourhood ball(pm.n_vertices());
  std::vector<Eigen::Vector3d> q(stations.size());
  std::vector<Source> sources(stations.size());
  std::size_t counts[4] = {0, 0, 0, 0};
  const double spacing = options.control_spacing * unit;
  const std::vector<char> bent = sharp_bends_within(stations, result.closed, length, spacing, options);
  for (std::size_t i = 0; i < stations.size(); ++i) {
    const auto [point, source] = bent[i] && !stations[i].exact
                                     ? std::pair{stations[i].p, Source::line}
                                     : station_point(pm, ball, stations, i, result.closed, line.feature_sign, options);
    q[i] = point;
    sources[i] = source;
    ++counts[int(source)];
  }
  const bool clean = pm.curvature().noise < kCleanMeshNoise;
  const std::vector<std::size_t> corners = corners_of(stations, q, result.closed, options.corner_angle);
  const std::vector<char> averaged =
      average_noisy_runs(run_noise(pm, line, unit), stations, bent, corners, result.closed, length, unit, options, q);
  result.points = smooth_points(stations, q, corners, result.closed, clean, length, spacing, options, result);
  // An exact crease run is the feature, and elsewhere where the fits were refused the surface line
  // is the best estimate there is: the curve keeps the line's points rather than the spline's
  // rounding (a tight bend of a CAD crease, which no fit over a few edges follows, is one of
  // them). Averaged points are already smooth, and the spline would round the crease's bends.
  std::size_t averaged_count = 0;
  for (std::size_t i = 0; i < stations.size(); ++i) {
    if (averaged[i]) result.points[i] = q[i], ++averaged_count;
    else if (sources[i] == Source::exact || sources[i] == Source::line) result.points[i] = stations[i].p;
  }
  const double n = double(stations.size());
  result.crease_share = double(counts[int(Source::crease)]) / n;
  result.surface_share = double(counts[int(Source::surface)]) / n;
  result.exact_share = double(counts[int(Source::exact)]) / n;
  result.fallback_share = double(counts[int(Source::line)]) / n;
  result.averaged_share = double(averaged_count) / n;
  result.length = polyline_length_of(result.points, result.closed);
  result.control_spacing = spacing;
  result.elapsed_ms = ms_since(start);
  return result;
}

}  // namespace featureline
