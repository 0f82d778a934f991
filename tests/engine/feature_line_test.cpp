// The whole pipeline: closed loops, options, thread safety, scratch, cancellation.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <thread>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/scratch_memory.h"
#include "engine/thread_pool.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/line_metrics.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

TEST(FeatureLine, ClosedLoopFollowsCircularCreaseBetweenVertices) {
  // A ring-shaped roof: a sharp convex crease on the circle r = 0.55, on a jittered grid
  // whose edges do not follow it. Keys on four vertices near the circle, closed loop.
  const double R = 0.55, width = 0.3;
  const auto field = make_height_field(
      [&](double x, double y) { return 0.25 * std::max(0.0, 1 - std::abs(std::hypot(x, y) - R) / width); }, 81, 0.2, 17);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  for (double angle : {0.3, 1.9, 3.4, 4.9})
    request.keys.push_back(nearest_vertex(field.mesh, R * std::cos(angle), R * std::sin(angle)));
  request.closed = true;
  const auto result = detect_feature_line(*mesh, request);
  EXPECT_TRUE(result.closed);
  EXPECT_EQ(result.pieces, 4u);
  auto mean_offset = [&](const std::vector<Eigen::Vector3d>& points) {
    double sum = 0;
    for (const auto& p : points) sum += std::abs(std::hypot(p.x(), p.y()) - R);
    return sum / double(points.size());
  };
  const double initial = mean_offset(result.initial_points), refined = mean_offset(refined_positions(result));
  EXPECT_LT(refined, 0.5 * initial);
  EXPECT_LT(refined, 0.15 * field.spacing);
  EXPECT_NEAR(result.refined_length, 2 * M_PI * R, 0.04 * 2 * M_PI * R);  // small wiggles add a little
  EXPECT_GT(result.initial.length, result.refined_length);  // the zig-zag edge path is longer
}

// A coarse CAD cube (each face 2 x 2 quads, 48 triangles) reads as the exact polyhedron it is:
// a closed line through a face's four corners is that face's outline, kept as it is. Read as
// noisy (fits across its creases made 0.41 edge lengths of "noise") the line was re-fitted as a
// noisy crease and cut the corners across the face (length 6.5 instead of 8 on the 2 x 2 x 2
// cube of cube.obj).
TEST(FeatureLine, ACoarseCubesFaceOutlineIsKeptExactly) {
  const auto mesh = prepare_mesh(make_subdivided_cube(2));
  EXPECT_EQ(mesh->curvature().noise, 0);
  auto vertex_at = [&](const Eigen::Vector3d& p) {
    for (std::uint32_t v = 0; v < mesh->n_vertices(); ++v)
      if ((mesh->positions()[v] - p).norm() < 1e-12) return v;
    ADD_FAILURE() << "no vertex at " << p.transpose();
    return std::uint32_t(0);
  };
  FeatureLineRequest request;
  request.keys = {vertex_at({0, 0, 1}), vertex_at({1, 0, 1}), vertex_at({1, 1, 1}), vertex_at({0, 1, 1})};
  request.closed = true;
  const FeatureLineResult result = detect_feature_line(*mesh, request);
  double length = 0;
  for (std::size_t i = 0; i < result.refined.size(); ++i) {
    const Eigen::Vector3d& p = result.refined[i].position;
    EXPECT_NEAR(p.z(), 1, 1e-12);
    EXPECT_TRUE(std::abs(p.x()) < 1e-12 || std::abs(p.x() - 1) < 1e-12 || std::abs(p.y()) < 1e-12 ||
                std::abs(p.y() - 1) < 1e-12)
        << "point " << i << " off the face's outline: " << p.transpose();
    length += (result.refined[(i + 1) % result.refined.size()].position - p).norm();
  }
  EXPECT_NEAR(length, 4, 1e-12);
}

TEST(FeatureLine, FreeKeysLoopIsRefinedInTwoHalves) {
  const auto raw = make_cylinder(1.0, 2.0, 12, 48, true);
  const auto mesh = prepare_mesh(raw);
  FeatureLineRequest request;
  request.keys = {12 * 48 + 0, 12 * 48 + 20};
  request.closed = true;
  request.options.pin_interior_keys = false;
  const auto result = detect_feature_line(*mesh, request);
  EXPECT_EQ(result.pieces, 2u);
  EXPECT_EQ(result.initial.vertices.size(), 48u);
}

TEST(FeatureLine, ThreadScratchIsCountedWhileItsThreadLivesAndReleasedAfter) {
  const auto field = make_ridge_field(61, 0.2, 1, 0.3, 0.25, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  const std::size_t before = engine_scratch_bytes();
  std::size_t during = 0;
  std::thread worker([&] {
    detect_feature_line(*mesh, request);
    during = engine_scratch_bytes();
  });
  worker.join();
  // At least the path search's labels (4 + 16 bytes a vertex) and the strip's stamped vertex
  // and face maps (8 bytes an element), sized to the mesh.
  const std::size_t at_least = mesh->n_vertices() * (20 + 8) + mesh->triangles().size() * 8;
  EXPECT_GE(during, before + at_least);
  EXPECT_EQ(engine_scratch_bytes(), before);  // the thread's scratch went with it
}

TEST(FeatureLine, NoRefineReturnsTheInitialLineOnVertices) {
  const auto field = make_ridge_field(31, 0.2, 1, 0.3, 0.25, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  request.options.refine = false;
  const auto result = detect_feature_line(*mesh, request);
  ASSERT_EQ(result.refined.size(), result.initial.vertices.size());
  for (std::size_t i = 0; i < result.refined.size(); ++i)
    EXPECT_EQ(result.refined[i].position, mesh->positions()[result.initial.vertices[i]]);
  EXPECT_FALSE(result.refined_by_snake);
  EXPECT_NEAR(result.refined_length, result.initial.length, 1e-12);
}

TEST(FeatureLine, LinesAreFiniteAndScaleWithTheMeshAtTheEdgesOfTheCoordinateRange) {
  // 1e14 and 1e-25 times a unit ridge: inside the range read_mesh accepts (|x| <= 1e15, extent
  // >= 1e-30), every number of the line is finite and the line is the same up to scale.
  const auto field = make_ridge_field(31, 0.2, 1, 0.3, 0.25, 0.2);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0, field.crest(0)),
                  nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  const auto unit = detect_feature_line(*prepare_mesh(field.mesh), request);
  for (const double s : {1e14, 1e-25}) {
    SCOPED_TRACE(s);
    const auto line = detect_feature_line(*prepare_mesh(scaled(field.mesh, s)), request);
    ASSERT_TRUE(std::isfinite(line.refined_length));
    EXPECT_NEAR(line.refined_length / s, unit.refined_length, 1e-6 * unit.refined_length);
    EXPECT_NEAR(line.initial.length / s, unit.initial.length, 1e-9 * unit.initial.length);
    for (const auto& piece : line.piece_reports) {
      EXPECT_TRUE(std::isfinite(piece.initial_strength));
      EXPECT_TRUE(std::isfinite(piece.refined_strength));
    }
    for (const auto& p : line.refined) EXPECT_TRUE(p.position.allFinite());
  }
}

// Everything a line's answer says, to compare two runs exactly.
void expect_same_line(const FeatureLineResult& a, const FeatureLineResult& b, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(a.refined.size(), b.refined.size());
  for (std::size_t i = 0; i < a.refined.size(); ++i) {
    ASSERT_EQ(a.refined[i].face, b.refined[i].face) << "point " << i;
    ASSERT_EQ(a.refined[i].position, b.refined[i].position) << "point " << i;
  }
  EXPECT_EQ(a.pieces, b.pieces);
  EXPECT_EQ(a.splits, b.splits);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.strip_faces, b.strip_faces);
  EXPECT_EQ(a.warnings, b.warnings);
  ASSERT_EQ(a.piece_reports.size(), b.piece_reports.size());
  for (std::size_t i = 0; i < a.piece_reports.size(); ++i) {
    EXPECT_EQ(a.piece_reports[i].kept, b.piece_reports[i].kept);
    EXPECT_EQ(a.piece_reports[i].refined_strength, b.piece_reports[i].refined_strength);
  }
  EXPECT_EQ(a.key_points, b.key_points);
}

TEST(FeatureLine, PiecesSideBySideGiveTheSerialLine) {
  // Pieces are refined side by side and their crest localisation then meets the pins in line
  // order: every answer must be the one the pieces give one after another. Keys anywhere on the
  // dragon (long pieces, strips that fold and are split), open and closed, 3-5
  // keys; five keys along a noisy ridge.
  const auto dragon = prepare_mesh(read_mesh_file(require_shared_mesh("dragon_25k.off")));
  const auto ridge_field = make_ridge_field(81, 0.2, 3, 0.3, 0.25, 0.3);
  const auto ridge = prepare_mesh(with_noise(ridge_field.mesh, 0.1, 5));
  std::vector<std::pair<const PreparedMesh*, FeatureLineRequest>> lines;
  for (std::uint32_t i = 0; i < 12; ++i) {
    FeatureLineRequest request;
    for (std::uint32_t k = 0; k < 3 + i % 3; ++k) request.keys.push_back((i * 7919u + k * 104729u + 13u) % dragon->n_vertices());
    request.closed = i % 4 == 3;
    lines.emplace_back(dragon.get(), request);
  }
  FeatureLineRequest along;
  for (double x : {-0.8, -0.4, 0.0, 0.4, 0.8}) along.keys.push_back(nearest_vertex(ridge_field.mesh, x, ridge_field.crest(x)));
  lines.emplace_back(ridge.get(), along);

  SerialExecutor serial;
  ThreadPool pool(3);
  int splits = 0, second_pieces = 0;
  for (std::size_t l = 0; l < lines.size(); ++l) {
    FeatureLineRequest request = lines[l].second;
    request.executor = &serial;
    const FeatureLineResult expected = detect_feature_line(*lines[l].first, request);
    splits += expected.splits;
    second_pieces += expected.pieces > 1;
    request.executor = &pool;
    expect_same_line(expected, detect_feature_line(*lines[l].first, request), "line " + std::to_string(l) + " on a pool");
    // As the server runs it: from a job on the pool, whose idle threads help.
    auto job = pool.try_submit([&] { return detect_feature_line(*lines[l].first, request); });
    ASSERT_TRUE(job.has_value());
    expect_same_line(expected, job->get(), "line " + std::to_string(l) + " from a job on the pool");
  }
  EXPECT_GT(second_pieces, 8);  // the lines do have pieces to run side by side
  EXPECT_GT(splits, 0);          // and a fold split into halves inside one task
}

TEST(FeatureLine, ConcurrentRequestsOnOneMeshAgree) {
  const auto field = make_ridge_field(61, 0.2, 7, 0.3, 0.25, 0.3);
  const std::shared_ptr<const PreparedMesh> mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.8, field.crest(-0.8)), nearest_vertex(field.mesh, 0.8, field.crest(0.8))};
  const auto reference = refined_positions(detect_feature_line(*mesh, request));
  std::vector<std::thread> threads;
  std::vector<int> same(8, 0);
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 5; ++i) same[t] += refined_positions(detect_feature_line(*mesh, request)) == reference;
    });
  for (auto& t : threads) t.join();
  for (int t = 0; t < 8; ++t) EXPECT_EQ(same[t], 5);
}

}  // namespace
}  // namespace featureline

namespace featureline {
namespace {

TEST(FeatureLine, ExtremeKappaRegressionIsBoundedInPoints) {
  // ../shared/data/regressions/snake_runaway_ridge20: kappa = 1000 once grew the snake to
  // 209,204 points over 51 s. The point count is now capped at 4x the initial sampling.
  const std::string path = std::string(FEATURELINE_SHARED_DIR) + "/data/regressions/snake_runaway_ridge20.obj";
  if (!std::ifstream(path).good()) FAIL() << "missing regression input " << path;
  const auto mesh = prepare_mesh(read_mesh_file(path));
  FeatureLineRequest request;
  request.keys = {239, 182, 330, 355, 57, 225, 310};
  request.options.snake.kappa = 1000;
  const auto result = detect_feature_line(*mesh, request);
  FeatureLineRequest plain = request;
  plain.options.snake.kappa = SnakeOptions{}.kappa;
  const auto normal = detect_feature_line(*mesh, plain);
  EXPECT_LE(result.refined.size(), 4 * normal.refined.size() + 16 * result.pieces);
  EXPECT_EQ(result.pieces, 6u);
}

// Keys on a noisy plane: no strip holds a feature, so each piece's snake only smooths the
// initial line, within featureless_iterations, and searching in full finds nothing stronger.
TEST(FeatureLine, AFeaturelessStripOnlySmoothsTheLine) {
  const auto field = make_height_field([](double, double) { return 0.0; }, 61, 0.2, 3);
  const auto mesh = prepare_mesh(with_noise(field.mesh, 0.1, 5));
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, -0.6), nearest_vertex(field.mesh, 0.0, 0.1),
                  nearest_vertex(field.mesh, 0.7, 0.5)};
  const auto quick = detect_feature_line(*mesh, request);
  ASSERT_EQ(quick.piece_reports.size(), 2u);
  for (const auto& piece : quick.piece_reports) {
    EXPECT_TRUE(piece.featureless);
    EXPECT_LE(piece.iterations, SnakeOptions{}.featureless_iterations);
    EXPECT_FALSE(piece.iteration_cap);
  }
  request.options.snake.featureless_below = 0;
  const auto full = detect_feature_line(*mesh, request);
  for (const auto& piece : full.piece_reports) EXPECT_FALSE(piece.featureless);
  EXPECT_GT(full.iterations, 2 * quick.iterations);
  const double quick_strength = mean_feature_strength(*mesh, quick.refined, 0, SnakeOptions{}.curvature_cap);
  const double full_strength = mean_feature_strength(*mesh, full.refined, 0, SnakeOptions{}.curvature_cap);
  EXPECT_LT(full_strength - quick_strength, 0.1);
  // Smoothed: the line is shorter than the initial zigzag of edges.
  EXPECT_LT(quick.refined_length, quick.initial.length);
}

TEST(FeatureLine, AStripAlongARidgeIsSearched) {
  const auto field = make_ridge_field(61, 0.2, 2, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(with_noise(field.mesh, 0.1, 5));
  FeatureLineRequest request;
  request.keys = keys_on_crest(field, {-0.8, 0.0, 0.8});
  const auto result = detect_feature_line(*mesh, request);
  ASSERT_FALSE(result.piece_reports.empty());
  for (const auto& piece : result.piece_reports) EXPECT_FALSE(piece.featureless);
}

TEST(FeatureLine, CancellationStopsTheWork) {
  const auto field = make_ridge_field(61, 0.2, 2, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = keys_on_crest(field, {-0.8, 0.0, 0.8});
  // Cancelled before it starts: nothing is computed.
  Cancellation cancelled;
  cancelled.cancel();
  request.cancel = &cancelled;
  EXPECT_THROW(detect_feature_line(*mesh, request), CancelledError);
  // A deadline passing inside the snake: these options ask for 100,000 iterations that never
  // converge (many seconds of engine time for one small line); the work stops
  // instead of finishing.
  request.options.snake.max_iterations = 100000;
  request.options.snake.tolerance = 0;
  request.options.snake.spacing = 0.05;
  const Cancellation deadline(Cancellation::Clock::now() + std::chrono::milliseconds(50));
  request.cancel = &deadline;
  EXPECT_THROW(detect_feature_line(*mesh, request), CancelledError);
  // Without a cancellation the same request runs (capped at fewer iterations here).
  request.cancel = nullptr;
  request.options.snake.max_iterations = 50;
  EXPECT_NO_THROW(detect_feature_line(*mesh, request));
}

}  // namespace
}  // namespace featureline
