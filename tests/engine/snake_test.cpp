// Stages 3 and 4: snake refinement on the flattened strip and mapping back to the surface.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "engine/feature_line.h"
#include "tests/support/line_metrics.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

std::vector<std::uint32_t> keys_on_crest(const HeightField& field, std::initializer_list<double> xs) {
  std::vector<std::uint32_t> keys;
  for (double x : xs) keys.push_back(nearest_vertex(field.mesh, x, field.crest(x)));
  return keys;
}

struct Measured {
  CrestDistance initial, refined;
  double initial_turning, refined_turning;
};

Measured run(const PreparedMesh& mesh, const HeightField& field, const std::vector<std::uint32_t>& keys,
             InitialMethod method, SnakeForce force = SnakeForce::smooth) {
  FeatureLineRequest request;
  request.keys = keys;
  request.options.initial.method = method;
  request.options.snake.force = force;
  const auto result = detect_feature_line(mesh, request);
  const auto refined = refined_positions(result);
  return {crest_distance(field, result.initial_points), crest_distance(field, refined),
          total_turning(result.initial_points), total_turning(refined)};
}

class RidgeRefinement : public ::testing::TestWithParam<double> {};

TEST_P(RidgeRefinement, RefinedLineIsCloserAndSmootherThanInitialAndGeodesic) {
  // Ridge (amplitude > 0) or valley (< 0) whose crest does not follow mesh edges.
  const double amplitude = GetParam();
  const auto field = make_ridge_field(61, 0.2, 7, amplitude, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto keys = keys_on_crest(field, {-0.8, 0.0, 0.8});
  const auto feature = run(*mesh, field, keys, InitialMethod::feature_path);
  const auto geodesic = run(*mesh, field, keys, InitialMethod::geodesic);
  EXPECT_LT(feature.refined.mean, 0.25 * feature.initial.mean);
  EXPECT_LT(feature.refined.mean, 0.25 * geodesic.initial.mean);
  EXPECT_LT(feature.refined.mean, 0.1 * field.spacing);  // a tenth of an edge on average
  EXPECT_LT(feature.refined_turning, 0.4 * feature.initial_turning);
  EXPECT_LT(feature.refined_turning, 0.4 * geodesic.initial_turning);
  // The paper's piecewise-constant force also improves on the initial line, less so.
  const auto paper = run(*mesh, field, keys, InitialMethod::feature_path, SnakeForce::paper);
  EXPECT_LT(paper.refined.mean, 0.5 * paper.initial.mean);
  EXPECT_LT(feature.refined.mean, paper.refined.mean);
}

INSTANTIATE_TEST_SUITE_P(RidgeAndValley, RidgeRefinement, ::testing::Values(0.3, -0.3));

TEST(Snake, StraightLineWithoutForceStaysPut) {
  // On a plane there is no curvature, so no force: a straight line far from the origin must
  // not move. A truncated fourth difference at the ends would drag it towards the origin.
  const auto raw = translated(make_plane_grid(41, 0.0, 1), 100, 50, 0);
  const auto mesh = prepare_mesh(raw);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(raw, 99.2, 50.0), nearest_vertex(raw, 100.8, 50.0)};
  const auto result = detect_feature_line(*mesh, request);
  ASSERT_GT(result.refined.size(), 5u);
  for (const auto& p : result.refined) EXPECT_NEAR(p.position.y(), 50.0, 1e-9);
  EXPECT_NEAR(result.refined_length, 1.6, 1e-9);
}

TEST(Snake, PinnedEndsPointsOnSurfaceAndInsideStrip) {
  const auto field = make_ridge_field(41, 0.2, 3, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto keys = keys_on_crest(field, {-0.7, 0.7});
  const auto line = find_initial_line(*mesh, keys, false);
  const auto strip = extract_feature_strip(*mesh, line.vertices);
  const auto flat = flatten_strip(*mesh, strip);
  const auto snake = refine_with_snake(*mesh, strip, flat);
  const auto points = map_to_surface(*mesh, strip, snake.points);
  EXPECT_EQ(points.front().position, mesh->positions[keys[0]]);
  EXPECT_EQ(points.back().position, mesh->positions[keys[1]]);
  const std::set<std::uint32_t> strip_faces(strip.faces.begin(), strip.faces.end());
  for (const auto& p : points) {
    EXPECT_TRUE(strip_faces.count(p.face)) << "point left the strip";
    EXPECT_NEAR(p.barycentric[0] + p.barycentric[1] + p.barycentric[2], 1.0, 1e-12);
    for (double b : p.barycentric) EXPECT_GE(b, 0.0);
    // the point is the barycentric combination of its face's corners
    Eigen::Vector3d q = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) q += p.barycentric[k] * mesh->positions[mesh->triangles[p.face][k]];
    EXPECT_LT((q - p.position).norm(), 1e-12);
  }
  EXPECT_GT(snake.iterations, 0);
}

TEST(Snake, ConvergesBeforeTheCapOnACleanRidge) {
  const auto field = make_ridge_field(61, 0.2, 7, 0.3, 0.25, 0.0);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = keys_on_crest(field, {-0.6, 0.6});
  request.options.snake.max_iterations = 2000;
  const auto result = detect_feature_line(*mesh, request);
  EXPECT_LT(result.iterations, 2000);
}

}  // namespace
}  // namespace featureline
