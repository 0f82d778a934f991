// The noisy-crease fit (engine/crease_fit.h) on the rounded slab, whose top outline is a chain
// of crease edges known exactly: on the clean part a straight run comes back as its vertices and
// the whole outline stays within a small fraction of an edge; on a noisy copy the fitted points
// are nearer the clean outline than the noisy vertices are; the options do what they say; and
// the nearest surface point near a vertex is the orthogonal projection where there is one.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/crease_fit.h"
#include "engine/prepared_mesh.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/line_metrics.h"

namespace featureline {
namespace {

using namespace featureline::testing;

CadPart fine_slab() {
  RoundedSlabOptions options;
  options.tessellation = SlabTessellation::fine;
  return make_rounded_slab(options);
}

// The chain from outline vertex `first` over `count` vertices (wrapping round the loop).
std::vector<std::uint32_t> outline_run(const CadPart& part, std::size_t first, std::size_t count) {
  std::vector<std::uint32_t> run;
  for (std::size_t k = 0; k < count; ++k) run.push_back(part.top_outline[(first + k) % part.top_outline.size()]);
  return run;
}

TEST(CreaseFit, AStraightCleanRunComesBackAsItsVertices) {
  const CadPart part = fine_slab();
  const auto mesh = prepare_mesh(part.mesh);
  // The outline starts at the bottom end of the straight side x = +a: its first 12 vertices are
  // on that side, a straight line, which a local quadratic reproduces exactly.
  const auto chain = outline_run(part, 0, 12);
  const CreaseFitResult fit = fit_noisy_crease(*mesh, chain);
  ASSERT_EQ(fit.points.size(), chain.size());
  for (std::size_t i = 0; i < chain.size(); ++i)
    EXPECT_LT((fit.points[i].position - mesh->positions()[chain[i]]).norm(), 1e-9 * part.mean_edge_length) << "point " << i;
  EXPECT_EQ(fit.kept_vertices, 0u);
  EXPECT_LT(fit.mean_shift, 1e-9);
}

TEST(CreaseFit, TheCleanOutlineStaysOnTheOutline) {
  const CadPart part = fine_slab();
  const auto mesh = prepare_mesh(part.mesh);
  const auto truth = positions_of(part.mesh, part.top_outline);
  // A run over a rounded corner (radius about 1.6 edges, tighter than the fit's bandwidth): the
  // quadratic's bias through the bend, half of it taken (step 0.5), stays under a tenth of an
  // edge (0.08 measured at the corner's middle).
  const std::size_t side = part.top_outline.size() / 4;
  const auto chain = outline_run(part, side / 2, side);
  const CreaseFitResult fit = fit_noisy_crease(*mesh, chain);
  ASSERT_EQ(fit.points.size(), chain.size());
  for (std::size_t i = 0; i < chain.size(); ++i)
    EXPECT_LT(distance_to_polyline(truth, true, fit.points[i].position), 0.1 * part.mean_edge_length) << "point " << i;
}

// Calls check(noisy mesh, chain, seed) for the fine slab at 10% noise (seeds 1-3) and the chain
// over half its top outline: two straight sides and two rounded corners.
template <typename Check>
void on_noisy_half_outlines(const CadPart& part, Check check) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const auto noisy = prepare_mesh(with_noise(part.mesh, 0.1, seed));
    check(*noisy, outline_run(part, 3, part.top_outline.size() / 2), seed);
  }
}

TEST(CreaseFit, OnANoisyCopyThePointsAreNearerTheTrueCreaseThanTheVertices) {
  const CadPart part = fine_slab();
  const auto truth = positions_of(part.mesh, part.top_outline);
  on_noisy_half_outlines(part, [&](const PreparedMesh& noisy, const std::vector<std::uint32_t>& chain, std::uint64_t seed) {
    const CreaseFitResult fit = fit_noisy_crease(noisy, chain);
    ASSERT_EQ(fit.points.size(), chain.size());
    std::vector<Eigen::Vector3d> vertices;
    for (auto v : chain) vertices.push_back(noisy.positions()[v]);
    const double before = mean_distance_to_polyline(vertices, truth, true), after = mean_distance_to_polyline(positions_of(fit.points), truth, true);
    EXPECT_LT(after, 0.95 * before) << "seed " << seed << ": vertices " << before << ", fitted " << after;
    // The ends are the chain's end vertices, unchanged (they are pinned keys).
    EXPECT_EQ(fit.points.front().position, noisy.positions()[chain.front()]);
    EXPECT_EQ(fit.points.back().position, noisy.positions()[chain.back()]);
    EXPECT_GT(fit.mean_shift, 0);
  });
}

TEST(CreaseFit, FixedVerticesStayAndFreeEndsMoveTowardTheCrease) {
  // A chain whose middle vertex is fixed (a pin shared with the rest of a line) and whose ends
  // are free (the line's own ends, keys picked near the crease): the fixed vertex keeps its
  // place, and the ends, estimated from their run on one side, lie nearer the clean outline on
  // average than the noisy end vertices.
  const CadPart part = fine_slab();
  const auto truth = positions_of(part.mesh, part.top_outline);
  double vertices_off = 0, ends_off = 0;
  on_noisy_half_outlines(part, [&](const PreparedMesh& noisy, const std::vector<std::uint32_t>& chain, std::uint64_t seed) {
    std::vector<char> fixed(chain.size(), 0);
    const std::size_t middle = chain.size() / 2;
    fixed[middle] = 1;
    const CreaseFitResult fit = fit_noisy_crease(noisy, chain, {}, fixed);
    ASSERT_EQ(fit.points.size(), chain.size());
    EXPECT_EQ(fit.points[middle].position, noisy.positions()[chain[middle]]) << "seed " << seed;
    for (const std::size_t end : {std::size_t(0), chain.size() - 1}) {
      vertices_off += distance_to_polyline(truth, true, noisy.positions()[chain[end]]);
      ends_off += distance_to_polyline(truth, true, fit.points[end].position);
    }
  });
  EXPECT_LT(ends_off, 0.9 * vertices_off);  // 0.84 measured
}

TEST(CreaseFit, WindowsChosenPerVertexBeatTheFixedBandwidth) {
  // On the straight sides the windows grow long, at the rounded corners they stay short; the
  // fixed 2.5-edge bandwidth is too short for the one and too long for the other.
  const CadPart part = fine_slab();
  const auto truth = positions_of(part.mesh, part.top_outline);
  CreaseFitOptions fixed;
  fixed.confidence = 0;
  on_noisy_half_outlines(part, [&](const PreparedMesh& noisy, const std::vector<std::uint32_t>& chain, std::uint64_t seed) {
    const double chosen = mean_distance_to_polyline(positions_of(fit_noisy_crease(noisy, chain).points), truth, true);
    const double fixed_width = mean_distance_to_polyline(positions_of(fit_noisy_crease(noisy, chain, fixed).points), truth, true);
    // Measured 0.0045-0.0053 model units (0.08-0.09 mean edges) against 0.0050-0.0056.
    EXPECT_LT(chosen, fixed_width) << "seed " << seed;
  });
}

TEST(CreaseFit, ZeroBandwidthReturnsTheVerticesAndATinyShiftKeepsThem) {
  const CadPart part = fine_slab();
  const auto noisy = prepare_mesh(with_noise(part.mesh, 0.1, 7));
  const auto chain = outline_run(part, 3, 20);
  CreaseFitOptions off;
  off.bandwidth = 0;
  const CreaseFitResult unchanged = fit_noisy_crease(*noisy, chain, off);
  ASSERT_EQ(unchanged.points.size(), chain.size());
  for (std::size_t i = 0; i < chain.size(); ++i) EXPECT_EQ(unchanged.points[i].position, noisy->positions()[chain[i]]);
  CreaseFitOptions held;
  held.max_shift = 1e-9;  // every interior vertex's fit moves it further: all are kept
  const CreaseFitResult kept = fit_noisy_crease(*noisy, chain, held);
  EXPECT_EQ(kept.kept_vertices, chain.size() - 2);
  for (std::size_t i = 0; i < chain.size(); ++i) EXPECT_EQ(kept.points[i].position, noisy->positions()[chain[i]]);
}

TEST(CreaseFit, NearestSurfacePointNearAVertexIsItsProjectionOntoTheTop) {
  const CadPart part = fine_slab();
  const auto mesh = prepare_mesh(part.mesh);
  // A top-cap vertex away from the outline: the flat cap at z = h lies all around it.
  std::uint32_t v = 0;
  double best = HUGE_VAL;
  for (std::uint32_t w = 0; w < mesh->n_vertices(); ++w) {
    const auto& p = mesh->positions()[w];
    const double d = p.head<2>().norm();
    if (std::abs(p.z() - 0.4) < 1e-12 && d < best) best = d, v = w;
  }
  const Eigen::Vector3d above = mesh->positions()[v] + Eigen::Vector3d(0.3, -0.2, 1.0) * 0.1 * part.mean_edge_length;
  const SurfacePoint s = nearest_surface_point_near(*mesh, v, above);
  EXPECT_NEAR(s.position.z(), 0.4, 1e-12);
  EXPECT_NEAR(s.position.x(), above.x(), 1e-9);
  EXPECT_NEAR(s.position.y(), above.y(), 1e-9);
  EXPECT_NEAR(s.barycentric[0] + s.barycentric[1] + s.barycentric[2], 1.0, 1e-12);
  Eigen::Vector3d from_barycentric = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) from_barycentric += s.barycentric[k] * mesh->positions()[mesh->triangles()[s.face][std::size_t(k)]];
  EXPECT_LT((from_barycentric - s.position).norm(), 1e-12);
}

TEST(CreaseFit, PointsPulledTowardACurveMoveThatShareAndStayOnTheSurface) {
  // The straight side x = +a of the clean slab's top outline, and a curve a third of an edge
  // inside the top face beside it: pulled half way, the marked points land a sixth of an edge
  // inside, on the top (z = h); the unmarked ones do not move.
  const CadPart part = fine_slab();
  const auto mesh = prepare_mesh(part.mesh);
  const auto chain = outline_run(part, 0, 12);
  const double e = part.mean_edge_length;
  std::vector<SurfacePoint> points;
  std::vector<Eigen::Vector3d> curve;
  for (auto v : chain) {
    points.push_back(surface_point_at_vertex(*mesh, v));
    curve.push_back(mesh->positions()[v] - Eigen::Vector3d(e / 3, 0, 0));
  }
  std::vector<char> pullable(chain.size(), 1);
  pullable.front() = pullable.back() = pullable[5] = 0;
  std::vector<SurfacePoint> pulled = points;
  pull_toward_curve(*mesh, curve, false, pullable, 0.5, pulled);
  for (std::size_t i = 0; i < chain.size(); ++i) {
    const Eigen::Vector3d& vertex = mesh->positions()[chain[i]];
    if (!pullable[i]) {
      EXPECT_EQ(pulled[i].position, points[i].position) << "point " << i;
      continue;
    }
    EXPECT_NEAR(pulled[i].position.x(), vertex.x() - e / 6, 1e-9) << "point " << i;
    EXPECT_NEAR(pulled[i].position.y(), vertex.y(), 1e-9) << "point " << i;
    EXPECT_NEAR(pulled[i].position.z(), 0.4, 1e-12) << "point " << i;
  }
}

}  // namespace
}  // namespace featureline
