// The snake's feature force F = grad |C|^p on the flattened strip (engine/internal/snake_force.h):
// on a smooth ridge both models point towards the crest from either side; the smooth model's
// Jacobian is its exact derivative inside a triangle (the force is linear there); at a sharp
// crease the smooth force has no component across the line, and without that rule it has.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/initial_line.h"
#include "engine/internal/snake_force.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

struct RidgeStrip {
  HeightField field;
  std::shared_ptr<const PreparedMesh> mesh;
  FeatureStrip strip;
  FlatStrip flat;
};

// A straight ridge (Gaussian profile, width 0.25) on a 51 x 51 jittered grid and the strip of
// the initial line between two keys on its crest.
RidgeStrip straight_ridge() {
  RidgeStrip r{make_ridge_field(51, 0.2, 3, 0.3, 0.25, 0.0), nullptr, {}, {}};
  r.mesh = prepare_mesh(r.field.mesh);
  const auto keys = keys_on_crest(r.field, {-0.6, 0.6});
  const auto line = find_initial_line(*r.mesh, keys, false);
  r.strip = extract_feature_strip(*r.mesh, line.vertices);
  r.flat = flatten_strip(*r.mesh, r.strip, {}, LineContext{});
  return r;
}

SnakeOptions ridge_options(SnakeForce force) {
  SnakeOptions o;
  o.force = force;
  return o;
}

constexpr double kRidges = 1;  // the lines' feature sign (LineContext::feature_sign)

// The plane direction from strip vertex v towards the crest: the field's crest is y = 0.1234,
// and the strip's layout maps the surface's +y side of the line to one side of the flattened
// line; which one, the line's own vertices tell (their uv against a vertex off the crest).
Eigen::Vector2d towards_crest(const RidgeStrip& r, std::uint32_t local) {
  // The nearest line vertex in the plane, and the line's direction there.
  std::size_t best = 0;
  for (std::size_t i = 1; i < r.strip.line.size(); ++i)
    if ((r.flat.uv[r.strip.line[i]] - r.flat.uv[local]).norm() < (r.flat.uv[r.strip.line[best]] - r.flat.uv[local]).norm()) best = i;
  const auto a = r.strip.line[best == 0 ? 0 : best - 1], b = r.strip.line[std::min(best + 1, r.strip.line.size() - 1)];
  const Eigen::Vector2d tangent = (r.flat.uv[b] - r.flat.uv[a]).normalized();
  const Eigen::Vector2d normal(-tangent.y(), tangent.x());
  const double side = (r.flat.uv[local] - r.flat.uv[r.strip.line[best]]).dot(normal);
  return side > 0 ? Eigen::Vector2d(-normal) : normal;
}

// Offset of strip vertex `local` from the crest, in grid spacings.
double crest_offset(const RidgeStrip& r, std::uint32_t local) {
  const auto& p = r.mesh->positions()[r.strip.vertices[local]];
  return std::abs(p.y() - kRidgeCrestOffset) / r.field.spacing;
}

TEST(SnakeForce, BothModelsPointTowardsASmoothRidgesCrestFromEitherSide) {
  const RidgeStrip r = straight_ridge();
  for (SnakeForce kind : {SnakeForce::smooth, SnakeForce::paper}) {
    const ForceField field = build_force_field(*r.mesh, r.strip, r.flat, ridge_options(kind), kRidges, r.strip.mean_edge_length);
    int checked = 0, towards = 0;
    for (std::uint32_t t = 0; t < r.strip.triangles.size(); ++t) {
      if (!r.flat.triangle_valid[t]) continue;
      // Triangles wholly between 1 and 3 grid spacings off the crest, where |C| falls steadily
      // (the profile's curvature changes sign at 4.4 spacings).
      bool inside = true;
      for (auto v : r.strip.triangles[t]) inside = inside && crest_offset(r, v) > 1 && crest_offset(r, v) < 3;
      if (!inside) continue;
      StripPoint centre;
      centre.triangle = t;
      centre.barycentric = Eigen::Vector3d::Constant(1.0 / 3);
      const Eigen::Vector2d f = force_at(field, r.strip, centre);
      ++checked;
      towards += f.dot(towards_crest(r, r.strip.triangles[t][0])) > 0;
    }
    EXPECT_GT(checked, 40) << to_string(kind);
    EXPECT_EQ(towards, checked) << to_string(kind) << ": triangles whose force points away from the crest";
  }
}

TEST(SnakeForce, TheSmoothForcesJacobianIsItsDerivativeInsideATriangle) {
  const RidgeStrip r = straight_ridge();
  const double unit = r.strip.mean_edge_length;
  const ForceField field = build_force_field(*r.mesh, r.strip, r.flat, ridge_options(SnakeForce::smooth), kRidges, unit);
  ASSERT_EQ(field.jacobian.size(), r.strip.triangles.size());
  int checked = 0;
  for (std::uint32_t t = 0; t < r.strip.triangles.size(); t += 7) {
    if (!r.flat.triangle_valid[t]) continue;
    const auto& tri = r.strip.triangles[t];
    // Two points inside the triangle; F is linear there, so F(q) - F(p) = J (q - p) exactly (in units).
    const Eigen::Vector3d wp(0.5, 0.3, 0.2), wq(0.2, 0.3, 0.5);
    StripPoint p, q;
    p.triangle = q.triangle = t;
    p.barycentric = wp, q.barycentric = wq;
    Eigen::Vector2d up = Eigen::Vector2d::Zero(), uq = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) up += wp[k] * r.flat.uv[tri[k]] / unit, uq += wq[k] * r.flat.uv[tri[k]] / unit;
    const Eigen::Vector2d difference = force_at(field, r.strip, q) - force_at(field, r.strip, p);
    const Eigen::Vector2d predicted = field.jacobian[t] * (uq - up);
    EXPECT_LT((difference - predicted).norm(), 1e-9 * (1 + difference.norm())) << "triangle " << t;
    ++checked;
  }
  EXPECT_GT(checked, 20);
}

TEST(SnakeForce, AtASharpCreaseTheSmoothForceHasNoComponentAcrossTheLine) {
  RoundedSlabOptions options;
  options.tessellation = SlabTessellation::fine;
  const CadPart part = make_rounded_slab(options);
  const auto mesh = prepare_mesh(part.mesh);
  // A straight run of the top outline, a 90-degree convex crease, as the line.
  const std::vector<std::uint32_t> line(part.top_outline.begin(), part.top_outline.begin() + 12);
  const FeatureStrip strip = extract_feature_strip(*mesh, line);
  const FlatStrip flat = flatten_strip(*mesh, strip, {}, LineContext{});
  const auto across = [&](const ForceField& field, std::size_t i) {
    const auto a = strip.line[i - 1], b = strip.line[i + 1];
    const Eigen::Vector2d tangent = (flat.uv[b] - flat.uv[a]).normalized();
    return std::abs(field.vertex_gradient[strip.line[i]].dot(Eigen::Vector2d(-tangent.y(), tangent.x())));
  };
  SnakeOptions o;
  const ForceField sharp = build_force_field(*mesh, strip, flat, o, kRidges, strip.mean_edge_length);
  o.sharp_crest_drop = 0;  // the rule off: the mean of the one-sided gradients
  const ForceField averaged = build_force_field(*mesh, strip, flat, o, kRidges, strip.mean_edge_length);
  double largest_without = 0;
  for (std::size_t i = 2; i + 2 < strip.line.size(); ++i) {
    EXPECT_LT(across(sharp, i), 1e-9 * (1 + sharp.vertex_gradient[strip.line[i]].norm())) << "line vertex " << i;
    largest_without = std::max(largest_without, across(averaged, i));
  }
  EXPECT_GT(largest_without, 1e-3);
}

}  // namespace
}  // namespace featureline
