#include "tests/support/line_metrics.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

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

std::vector<Eigen::Vector3d> refined_positions(const FeatureLineResult& result) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : result.refined) out.push_back(p.position);
  return out;
}

bool is_edge_path(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path) {
  for (std::size_t i = 1; i < path.size(); ++i) {
    const auto a = path[i - 1], b = path[i];
    const auto begin = mesh.neighbors.begin() + mesh.neighbor_offsets[a];
    const auto end = mesh.neighbors.begin() + mesh.neighbor_offsets[a + 1];
    if (std::find(begin, end, b) == end) return false;
  }
  return true;
}

}  // namespace featureline::testing
