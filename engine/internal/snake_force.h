// Internal to the engine: the snake's feature force on the flattened strip, F = grad |C|^p
// (paper Eqs. 13 and 15), in one of the two models of SnakeForce (engine/snake.h).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/feature_strip.h"
#include "engine/prepared_mesh.h"
#include "engine/snake.h"

namespace featureline {

// The feature force on the flattened strip, F = grad |C|^p (Eqs. 13 and 15).
struct ForceField {
  SnakeForce kind = SnakeForce::smooth;
  std::vector<Eigen::Vector2d> triangle_gradient;  ///< paper force: constant per triangle
  std::vector<Eigen::Vector2d> vertex_gradient;    ///< smooth force: per vertex, interpolated
  std::vector<Eigen::Matrix2d> jacobian;           ///< smooth force: its Jacobian per triangle
};

/// The force of `o.force` toward features of `feature_sign` (LineContext::feature_sign) over the
/// strip, in units of `unit` (the strip's mean edge length).
ForceField build_force_field(const PreparedMesh& mesh, const FeatureStrip& strip, const FlatStrip& flat,
                             const SnakeOptions& o, double feature_sign, double unit);

/// The force at a point of the strip.
inline Eigen::Vector2d force_at(const ForceField& field, const FeatureStrip& strip, const StripPoint& p) {
  if (field.kind == SnakeForce::paper) return field.triangle_gradient[p.triangle];
  const auto& tri = strip.triangles[p.triangle];
  return p.barycentric[0] * field.vertex_gradient[tri[0]] + p.barycentric[1] * field.vertex_gradient[tri[1]] +
         p.barycentric[2] * field.vertex_gradient[tri[2]];
}

}  // namespace featureline
