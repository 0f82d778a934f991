#include "engine/crease_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "engine/line_averaging.h"
#include "engine/surface_point.h"

namespace featureline {
namespace {

// The parameter (0 at p, 1 at q) of the point of segment pq nearest to x.
double nearest_parameter(const Eigen::Vector3d& x, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  const double length2 = (q - p).squaredNorm();
  return length2 > 0 ? std::clamp((x - p).dot(q - p) / length2, 0.0, 1.0) : 0.0;
}

// Barycentric coordinates (w.r.t. a, b, c) of the point of triangle abc nearest to x: the
// projection on the plane when it falls inside, else the nearest point of the nearest side.
std::array<double, 3> nearest_on_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ax = x - a;
  const double d00 = ab.dot(ab), d01 = ab.dot(ac), d11 = ac.dot(ac);
  const double denominator = d00 * d11 - d01 * d01;
  if (denominator > 1e-300) {
    const double d20 = ax.dot(ab), d21 = ax.dot(ac);
    const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
    if (v >= 0 && w >= 0 && v + w <= 1) return {1 - v - w, v, w};
  }
  // Outside (or degenerate): the best of the three sides.
  std::array<double, 3> best{1, 0, 0};
  double best_distance = (x - a).squaredNorm();
  const std::array<Eigen::Vector3d, 3> corner{a, b, c};
  for (int side = 0; side < 3; ++side) {
    const Eigen::Vector3d& p = corner[side];
    const Eigen::Vector3d& q = corner[(side + 1) % 3];
    const double t = nearest_parameter(x, p, q);
    const double distance = (x - (p + t * (q - p))).squaredNorm();
    if (distance < best_distance) {
      best_distance = distance;
      best = {0, 0, 0};
      best[side] = 1 - t;
      best[(side + 1) % 3] = t;
    }
  }
  return best;
}

// Cumulative arc length along the chain's vertices.
std::vector<double> arc_lengths(const PreparedMesh& mesh, const std::vector<std::uint32_t>& chain) {
  std::vector<double> s(chain.size(), 0.0);
  for (std::size_t i = 1; i < chain.size(); ++i)
    s[i] = s[i - 1] + (mesh.positions()[chain[i]] - mesh.positions()[chain[i - 1]]).norm();
  return s;
}

// Local quadratic regression of the chain's positions against arc length at s[i]: the constant
// term of the weighted least-squares fit x(t) = c0 + c1 t + c2 t^2 (t = (s - s[i]) / h). A
// quadratic follows a bend of the crease without the inward bias of a plain weighted mean;
// where too few vertices carry weight for a quadratic (near the ends) a line is fitted.
Eigen::Vector3d regress_at(const PreparedMesh& mesh, const std::vector<std::uint32_t>& chain,
                           const std::vector<double>& s, std::size_t i, double h) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d rhs = Eigen::Matrix3d::Zero();  // one column per coordinate
  int support = 0;
  for (std::size_t j = 0; j < chain.size(); ++j) {
    const double t = (s[j] - s[i]) / h;
    if (std::abs(t) > 3) continue;
    const double w = std::exp(-0.5 * t * t);
    const Eigen::Vector3d basis(1, t, t * t);
    normal += w * basis * basis.transpose();
    rhs += w * basis * mesh.positions()[chain[j]].transpose();
    ++support;
  }
  const int terms = support >= 5 ? 3 : 2;
  const Eigen::MatrixXd a = normal.topLeftCorner(terms, terms);
  const Eigen::LDLT<Eigen::MatrixXd> solver(a);
  if (solver.info() != Eigen::Success || !solver.isPositive() || std::abs(a.determinant()) < 1e-12)
    return mesh.positions()[chain[i]];
  const Eigen::MatrixXd coefficients = solver.solve(rhs.topRows(terms));
  return coefficients.row(0).transpose();
}

// Every free vertex's estimate of the crease: the regression at the fixed bandwidth, or over
// windows chosen vertex by vertex (options.confidence > 0).
std::vector<Eigen::Vector3d> crease_estimates(const PreparedMesh& mesh, const std::vector<std::uint32_t>& chain,
                                              const std::vector<double>& s, const std::vector<char>& fixed,
                                              const CreaseFitOptions& options) {
  std::vector<Eigen::Vector3d> estimates(chain.size());
  if (!(options.confidence > 0)) {
    for (std::size_t i = 0; i < chain.size(); ++i)
      if (!fixed[i]) estimates[i] = regress_at(mesh, chain, s, i, options.bandwidth * mesh.local_edge_length(chain[i]));
    return estimates;
  }
  AveragedLineInput line;
  line.u = s;
  double unit = 0;
  for (const auto v : chain) line.points.push_back(mesh.positions()[v]), unit += mesh.local_edge_length(v);
  unit /= double(chain.size());
  for (const char f : fixed) line.movable.push_back(!f);
  line.corner.assign(chain.size(), 0);
  line.unit = unit;
  line.sigma = mesh.curvature().noise_length;
  return average_along_line(line, {options.confidence, 1.0}).points;
}

}  // namespace

SurfacePoint nearest_surface_point_near(const PreparedMesh& mesh, std::uint32_t v, const Eigen::Vector3d& x) {
  SurfacePoint best = surface_point_at_vertex(mesh, v);
  double best_distance = (best.position - x).squaredNorm();
  auto try_faces_of = [&](std::uint32_t u) {
    for (const std::uint32_t f : mesh.faces_around(u)) {
      const auto& t = mesh.triangles()[f];
      const auto w = nearest_on_triangle(x, mesh.positions()[t[0]], mesh.positions()[t[1]], mesh.positions()[t[2]]);
      const Eigen::Vector3d p = mesh.point_at(f, w);
      const double distance = (p - x).squaredNorm();
      if (distance < best_distance) {
        best_distance = distance;
        best = {p, f, w};
      }
    }
  };
  try_faces_of(v);
  for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) try_faces_of(mesh.neighbors()[k]);
  return best;
}

namespace {

// The nearest point to x of segment `segment` of the polyline (it runs to the next point, the
// first again after the last).
Eigen::Vector3d nearest_on_segment(const std::vector<Eigen::Vector3d>& curve, std::size_t segment, const Eigen::Vector3d& x) {
  const Eigen::Vector3d& a = curve[segment];
  const Eigen::Vector3d& b = curve[(segment + 1) % curve.size()];
  return a + nearest_parameter(x, a, b) * (b - a);
}

// The point of the curve nearest x, searched from segment `from` (where the point before x on
// the line found its own) out to both sides while it keeps getting nearer, a few segments past:
// the line and the curve run side by side, so this is linear in their lengths.
Eigen::Vector3d nearest_on_curve(const std::vector<Eigen::Vector3d>& curve, bool closed, std::size_t& from,
                                 const Eigen::Vector3d& x) {
  constexpr std::size_t kPast = 4;
  const std::size_t segments = closed ? curve.size() : curve.size() - 1;
  Eigen::Vector3d best = nearest_on_segment(curve, from, x);
  double best_distance = (best - x).squaredNorm();
  std::size_t best_segment = from;
  for (const int direction : {1, -1}) {
    std::size_t misses = 0;
    for (std::size_t step = 1; step < segments && misses <= kPast; ++step) {
      const std::ptrdiff_t raw = std::ptrdiff_t(from) + direction * std::ptrdiff_t(step);
      if (!closed && (raw < 0 || raw >= std::ptrdiff_t(segments))) break;
      const std::size_t segment = std::size_t((raw % std::ptrdiff_t(segments) + std::ptrdiff_t(segments)) % std::ptrdiff_t(segments));
      const Eigen::Vector3d p = nearest_on_segment(curve, segment, x);
      const double distance = (p - x).squaredNorm();
      if (distance < best_distance) best_distance = distance, best = p, best_segment = segment, misses = 0;
      else ++misses;
    }
  }
  from = best_segment;
  return best;
}

}  // namespace

void pull_toward_curve(const PreparedMesh& mesh, const std::vector<Eigen::Vector3d>& curve, bool closed,
                       const std::vector<char>& pullable, double pull, std::vector<SurfacePoint>& points) {
  if (!(pull > 0) || curve.size() < 2) return;
  std::size_t segment = 0;
  bool started = false;
  for (std::size_t i = 0; i < points.size() && i < pullable.size(); ++i) {
    if (!pullable[i]) continue;
    const SurfacePoint& p = points[i];
    if (!started) {  // the first point's segment from all of them; the rest walk from there
      double best = HUGE_VAL;
      for (std::size_t s = 0; s + (closed ? 0 : 1) < curve.size(); ++s)
        if (const double d = (nearest_on_segment(curve, s, p.position) - p.position).squaredNorm(); d < best) best = d, segment = s;
      started = true;
    }
    const Eigen::Vector3d target = p.position + pull * (nearest_on_curve(curve, closed, segment, p.position) - p.position);
    points[i] = nearest_surface_point_near(mesh, nearest_corner(mesh, p), target);
  }
}

CreaseFitResult fit_noisy_crease(const PreparedMesh& mesh, const std::vector<std::uint32_t>& chain,
                                 const CreaseFitOptions& options, std::vector<char> fixed) {
  CreaseFitResult result;
  for (const auto v : chain) result.points.push_back(surface_point_at_vertex(mesh, v));
  if (options.bandwidth <= 0 || chain.size() < 3) return result;
  if (fixed.empty()) {
    fixed.assign(chain.size(), 0);
    fixed.front() = fixed.back() = 1;
  }
  fixed.resize(chain.size(), 1);
  const std::vector<double> s = arc_lengths(mesh, chain);
  const std::vector<Eigen::Vector3d> estimates = crease_estimates(mesh, chain, s, fixed, options);
  double shift_sum = 0;
  std::size_t free = 0;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    if (fixed[i]) continue;
    ++free;
    const double edge = mesh.local_edge_length(chain[i]);
    const Eigen::Vector3d& vertex = mesh.positions()[chain[i]];
    const Eigen::Vector3d estimate = vertex + options.step * (estimates[i] - vertex);
    const SurfacePoint on_surface = nearest_surface_point_near(mesh, chain[i], estimate);
    const double shift = (on_surface.position - mesh.positions()[chain[i]]).norm() / edge;
    if (shift > options.max_shift) {
      ++result.kept_vertices;
      continue;
    }
    result.points[i] = on_surface;
    shift_sum += shift;
  }
  const std::size_t moved = free - result.kept_vertices;
  result.mean_shift = moved > 0 ? shift_sum / double(moved) : 0;
  return result;
}

}  // namespace featureline
