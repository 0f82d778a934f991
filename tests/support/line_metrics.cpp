#include "tests/support/line_metrics.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "tests/support/accuracy_meshes.h"

namespace featureline::testing {

double total_turning(const std::vector<Eigen::Vector3d>& p) {
  double sum = 0;
  for (std::size_t i = 1; i + 1 < p.size(); ++i) {
    const Eigen::Vector3d a = p[i] - p[i - 1], b = p[i + 1] - p[i];
    if (a.norm() == 0 || b.norm() == 0) continue;
    sum += std::atan2(a.cross(b).norm(), a.dot(b));
  }
  return sum;
}

CrestDistance crest_distance(const HeightField& field, const std::vector<Eigen::Vector3d>& points) {
  CrestDistance d;
  for (const auto& p : points) {
    const double e = distance_to_crest(field, p.x(), p.y());
    d.mean += e;
    d.max = std::max(d.max, e);
  }
  if (!points.empty()) d.mean /= double(points.size());
  return d;
}

LineDistance arc_length_distance(const std::vector<Eigen::Vector3d>& points, bool closed,
                                 const std::function<double(const Eigen::Vector3d&)>& distance) {
  LineDistance d;
  if (points.empty()) return d;
  std::vector<double> at(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    at[i] = distance(points[i]);
    d.max = std::max(d.max, at[i]);
  }
  const std::size_t segments = points.size() < 2 ? 0 : (closed ? points.size() : points.size() - 1);
  double length = 0, integral = 0;
  for (std::size_t s = 0; s < segments; ++s) {
    const std::size_t t = (s + 1) % points.size();
    const double l = (points[t] - points[s]).norm();
    if (l == 0) continue;
    const double mid = distance(0.5 * (points[s] + points[t]));
    d.max = std::max(d.max, mid);
    integral += l * (at[s] + 4 * mid + at[t]) / 6;
    length += l;
  }
  if (length > 0) {
    d.mean = integral / length;
  } else {
    for (double x : at) d.mean += x;
    d.mean /= double(at.size());
  }
  return d;
}

std::vector<Eigen::Vector3d> refined_positions(const FeatureLineResult& result) { return positions_of(result.refined); }

std::vector<Eigen::Vector3d> positions_of(const std::vector<SurfacePoint>& points) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : points) out.push_back(p.position);
  return out;
}

double mean_distance_to_polyline(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& polyline,
                                 bool closed) {
  if (points.empty()) return 0;
  double sum = 0;
  for (const auto& p : points) sum += distance_to_polyline(polyline, closed, p);
  return sum / double(points.size());
}

bool is_edge_path(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path) {
  for (std::size_t i = 1; i < path.size(); ++i) {
    const auto a = path[i - 1], b = path[i];
    const auto begin = mesh.neighbors().begin() + mesh.neighbor_offsets()[a];
    const auto end = mesh.neighbors().begin() + mesh.neighbor_offsets()[a + 1];
    if (std::find(begin, end, b) == end) return false;
  }
  return true;
}

// Height of the mesh surface above (x, y), or NaN outside it.
double surface_height(const RawMesh& mesh, double x, double y) {
  for (const auto& t : mesh.triangles) {
    const auto &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    if (x < std::min({a[0], b[0], c[0]}) || x > std::max({a[0], b[0], c[0]}) || y < std::min({a[1], b[1], c[1]}) ||
        y > std::max({a[1], b[1], c[1]}))
      continue;
    const double det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
    const double l1 = ((x - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (y - a[1])) / det;
    const double l2 = ((b[0] - a[0]) * (y - a[1]) - (x - a[0]) * (b[1] - a[1])) / det;
    if (l1 >= -1e-12 && l2 >= -1e-12 && l1 + l2 <= 1 + 1e-12) return a[2] + l1 * (b[2] - a[2]) + l2 * (c[2] - a[2]);
  }
  return std::nan("");
}

// The analytic crest between x0 and x1, `count` points evenly spaced along it, laid on the mesh.
std::vector<Eigen::Vector3d> crest_on_surface(const HeightField& field, double x0, double x1, std::size_t count) {
  const int fine = 4000;
  std::vector<double> xs(fine + 1), arc(fine + 1, 0.0);
  for (int k = 0; k <= fine; ++k) {
    xs[std::size_t(k)] = x0 + (x1 - x0) * k / fine;
    if (k > 0)
      arc[std::size_t(k)] = arc[std::size_t(k - 1)] + std::hypot(xs[std::size_t(k)] - xs[std::size_t(k - 1)],
                                                                 field.crest(xs[std::size_t(k)]) - field.crest(xs[std::size_t(k - 1)]));
  }
  std::vector<Eigen::Vector3d> out;
  std::size_t k = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const double at = arc.back() * double(i) / double(std::max<std::size_t>(count - 1, 1));
    while (k + 1 < std::size_t(fine) && arc[k + 1] < at) ++k;
    const double f = arc[k + 1] > arc[k] ? (at - arc[k]) / (arc[k + 1] - arc[k]) : 0.0;
    const double x = xs[k] + f * (xs[k + 1] - xs[k]), y = field.crest(x);
    out.emplace_back(x, y, surface_height(field.mesh, x, y));
  }
  return out;
}

}  // namespace featureline::testing
