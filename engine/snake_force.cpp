#include "engine/internal/snake_force.h"

#include <algorithm>
#include <cmath>

#include "engine/internal/geometry.h"

namespace featureline {
namespace {

// At a sharp crest (a crease vertex, where |C| drops steeply on both sides of the line) the
// potential has a kink, and any average of the one-sided gradients points towards the flatter
// side, pushing the line off the crease. There the gradient's component across the line is
// set to zero, so the crest itself is the force's zero. Smooth ridges, whose neighbours drop
// only a little, keep their interpolated gradients and with them sub-edge accuracy.
void zero_gradient_across_sharp_crests(const FeatureStrip& strip, const FlatStrip& flat, const std::vector<double>& potential,
                                       double drop, std::vector<Eigen::Vector2d>& gradient) {
  if (!(drop > 0) || drop >= 1) return;
  const std::size_t nv = strip.vertices.size();
  // Tangent of the line at each line vertex, then at every strip vertex from its line vertex.
  std::vector<Eigen::Vector2d> line_tangent(strip.line.size());
  for (std::size_t i = 0; i < strip.line.size(); ++i) {
    const auto a = strip.line[i == 0 ? 0 : i - 1], b = strip.line[std::min(i + 1, strip.line.size() - 1)];
    line_tangent[i] = (flat.uv[b] - flat.uv[a]).normalized();
  }
  std::vector<double> highest_left(nv, -1), highest_right(nv, -1);
  std::vector<Eigen::Vector2d> normal(nv, Eigen::Vector2d::Zero());
  // Each vertex takes the normal of the line vertex the strip reached it from (a vertex's nearest
  // line vertex by rings; a search over the whole line per vertex cost more than the force).
  for (std::size_t v = 0; v < nv; ++v) {
    if (!flat.placed[v]) continue;
    const auto& tangent = line_tangent[strip.line_position[v]];
    normal[v] = Eigen::Vector2d(-tangent.y(), tangent.x());
  }
  // Highest potential among the neighbours on each side of the line (through triangle edges).
  for (std::size_t t = 0; t < strip.triangles.size(); ++t) {
    if (!flat.triangle_valid[t]) continue;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j) {
        if (j == k) continue;
        const auto v = strip.triangles[t][k], w = strip.triangles[t][j];
        // Beyond 60 degrees from the line on either side: |d.n| > |d| / 2, without a square root.
        const Eigen::Vector2d d = flat.uv[w] - flat.uv[v];
        const double across = d.dot(normal[v]);
        if (4 * across * across <= d.squaredNorm()) continue;
        if (across > 0) highest_left[v] = std::max(highest_left[v], potential[w]);
        else highest_right[v] = std::max(highest_right[v], potential[w]);
      }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    if (highest_left[v] < 0 || highest_right[v] < 0 || !(potential[v] > 0)) continue;
    const double limit = (1 - drop) * potential[v];
    if (highest_left[v] <= limit && highest_right[v] <= limit)
      gradient[v] -= gradient[v].dot(normal[v]) * normal[v];
  }
}

// Potential |C|^p per strip vertex: Eq. (13)'s |C| (of the line's sign, capped) raised to the
// exponent of Eq. (15).
std::vector<double> feature_potential(const PreparedMesh& pm, const FeatureStrip& strip, const SnakeOptions& o,
                                      double feature_sign) {
  std::vector<double> potential(strip.vertices.size(), 0.0);
  for (std::size_t v = 0; v < potential.size(); ++v) {
    const double s = std::min(feature_value(pm.curvature(), strip.vertices[v], feature_sign) / pm.curvature_scale(), o.curvature_cap);
    potential[v] = std::pow(s, o.exponent);
  }
  return potential;
}

// The edge of triangle p opposite corner k turned by 90 degrees: over twice the area it is the
// gradient of the barycentric coordinate lambda_k.
Eigen::Vector2d turned_opposite_edge(const Eigen::Vector2d (&p)[3], int k) {
  const Eigen::Vector2d e = p[(k + 2) % 3] - p[(k + 1) % 3];
  return Eigen::Vector2d(-e.y(), e.x());
}

struct TriangleGradients {
  std::vector<Eigen::Vector2d> gradient;  ///< of the potential's barycentric interpolant
  std::vector<double> area;               ///< in scaled coordinates
};

// Gradient of the barycentric interpolant of the potential, constant per triangle.
TriangleGradients triangle_gradients(const FeatureStrip& strip, const FlatStrip& flat, const std::vector<double>& potential,
                                     double unit) {
  const std::size_t nt = strip.triangles.size();
  TriangleGradients out{std::vector<Eigen::Vector2d>(nt, Eigen::Vector2d::Zero()), std::vector<double>(nt, 0.0)};
  for (std::size_t t = 0; t < nt; ++t) {
    if (!flat.triangle_valid[t]) continue;
    const auto& tri = strip.triangles[t];
    const Eigen::Vector2d p[3] = {flat.uv[tri[0]] / unit, flat.uv[tri[1]] / unit, flat.uv[tri[2]] / unit};
    const double twice_area = cross2(p[1] - p[0], p[2] - p[0]);
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) g += potential[tri[k]] * turned_opposite_edge(p, k) / twice_area;
    out.gradient[t] = g;
    out.area[t] = 0.5 * twice_area;
  }
  return out;
}

// The smooth force's per-vertex gradients: area-weighted means of the adjacent triangles'.
std::vector<Eigen::Vector2d> vertex_gradients(const FeatureStrip& strip, const FlatStrip& flat, const TriangleGradients& triangles) {
  const std::size_t nv = strip.vertices.size();
  std::vector<Eigen::Vector2d> gradient(nv, Eigen::Vector2d::Zero());
  std::vector<double> weight(nv, 0.0);
  for (std::size_t t = 0; t < strip.triangles.size(); ++t) {
    if (!flat.triangle_valid[t]) continue;
    for (auto v : strip.triangles[t]) {
      gradient[v] += triangles.area[t] * triangles.gradient[t];
      weight[v] += triangles.area[t];
    }
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (weight[v] > 0) gradient[v] /= weight[v];
  return gradient;
}

// The smooth force F = sum_k lambda_k g_k is linear in each triangle; its Jacobian
// sum_k g_k grad(lambda_k)^T gives the force's restoring stiffness for the normal step.
std::vector<Eigen::Matrix2d> force_jacobians(const FeatureStrip& strip, const FlatStrip& flat,
                                             const std::vector<Eigen::Vector2d>& vertex_gradient, double unit) {
  std::vector<Eigen::Matrix2d> jacobian(strip.triangles.size(), Eigen::Matrix2d::Zero());
  for (std::size_t t = 0; t < strip.triangles.size(); ++t) {
    if (!flat.triangle_valid[t]) continue;
    const auto& tri = strip.triangles[t];
    const Eigen::Vector2d p[3] = {flat.uv[tri[0]] / unit, flat.uv[tri[1]] / unit, flat.uv[tri[2]] / unit};
    const double twice_area = cross2(p[1] - p[0], p[2] - p[0]);
    for (int k = 0; k < 3; ++k) jacobian[t] += vertex_gradient[tri[k]] * (turned_opposite_edge(p, k) / twice_area).transpose();
  }
  return jacobian;
}

}  // namespace

ForceField build_force_field(const PreparedMesh& pm, const FeatureStrip& strip, const FlatStrip& flat, const SnakeOptions& o,
                             double feature_sign, double unit) {
  const std::vector<double> potential = feature_potential(pm, strip, o, feature_sign);
  TriangleGradients triangles = triangle_gradients(strip, flat, potential, unit);
  ForceField field;
  field.kind = o.force;
  if (o.force == SnakeForce::smooth) {
    field.vertex_gradient = vertex_gradients(strip, flat, triangles);
    zero_gradient_across_sharp_crests(strip, flat, potential, o.sharp_crest_drop, field.vertex_gradient);
    field.jacobian = force_jacobians(strip, flat, field.vertex_gradient, unit);
  }
  field.triangle_gradient = std::move(triangles.gradient);
  return field;
}

}  // namespace featureline
