// Tracing a feature from one key, against known answers: a capped cylinder's rim traced from one
// click cuts off its cap; the rounded slab's top outline comes
// back as the whole closed crease loop (skinny CAD and fine tessellations, and the fine one at
// 10-20% noise); a cube's edge stops
// at both corners, where three creases meet; a T of two roof crests is passed straight through
// from the bar and stops at the bar from the stem; a Gaussian ridge that fades out stops where it
// fades and at the boundary on its other side; noisy ridges stay on the crest; a sphere and a
// flat plane have nothing to trace. Plus the bounds (max_edges, options, one key).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "api/feature_line_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/segmentation.h"
#include "engine/trace.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/line_metrics.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;
constexpr double kPi = 3.14159265358979323846;

std::vector<Eigen::Vector3d> vertex_positions(const PreparedMesh& mesh, const std::vector<std::uint32_t>& ids) {
  std::vector<Eigen::Vector3d> out;
  for (auto v : ids) out.push_back(mesh.positions()[v]);
  return out;
}

std::uint32_t vertex_at(const PreparedMesh& mesh, const Eigen::Vector3d& p) { return mesh.nearest_vertex(p); }

FeatureLineResult traced_line(const PreparedMesh& mesh, std::uint32_t key, FeatureLineOptions options = {}) {
  FeatureLineRequest request;
  request.keys = {key};
  request.trace = true;
  request.options = options;
  return detect_feature_line(mesh, request);
}

TEST(Trace, SlabOutlineFromOneKeyIsTheWholeClosedCreaseLoop) {
  for (auto tessellation : {SlabTessellation::skinny, SlabTessellation::fine}) {
    RoundedSlabOptions slab;
    slab.tessellation = tessellation;
    const CadPart part = make_rounded_slab(slab);
    const auto mesh = prepare_mesh(part.mesh);
    // A key on the outline, and one a little inside the cap (the click missed the edge).
    const std::uint32_t on_edge = part.top_outline[5];
    const Eigen::Vector3d inside = mesh->positions()[on_edge] + Eigen::Vector3d(-0.3, 0, 0) * part.mean_edge_length;
    for (std::uint32_t key : {on_edge, vertex_at(*mesh, inside)}) {
      const TraceResult trace = trace_feature(*mesh, key);
      EXPECT_TRUE(trace.closed);
      EXPECT_TRUE(trace.on_crease);
      EXPECT_EQ(trace.sign, FeatureSign::ridge);
      EXPECT_TRUE(same_cycle(trace.vertices, part.top_outline)) << trace.vertices.size() << " vertices";
      EXPECT_EQ(trace.ends[0].reason, TraceStop::closed);
      EXPECT_TRUE(trace.junctions.empty());
    }
    const TraceResult bottom = trace_feature(*mesh, part.bottom_outline[11]);
    EXPECT_TRUE(bottom.closed);
    EXPECT_TRUE(same_cycle(bottom.vertices, part.bottom_outline)) << "the bottom loop from a key on it";
    const FeatureLineResult line = traced_line(*mesh, on_edge);
    ASSERT_TRUE(line.trace);
    EXPECT_TRUE(line.closed);
    EXPECT_EQ(line.keys.size(), 2u);
    // A clean crease is kept exactly: every refined point on the outline polygon.
    const auto outline = positions_of(part.mesh, part.top_outline);
    for (const auto& p : refined_positions(line)) EXPECT_LT(distance_to_polyline(outline, true, p), 1e-9);
  }
}

// Noise unmarks some crease edges and marks spurs beside them (a face's second edge): the
// trace bridges the gaps and is not stopped by the spurs. (On the skinny tessellation the same
// noise hides the creases from the curvature stage altogether: nothing to trace there.)
TEST(Trace, NoisySlabOutlineIsStillTheWholeLoop) {
  RoundedSlabOptions slab;
  slab.tessellation = SlabTessellation::fine;
  const CadPart part = make_rounded_slab(slab);
  for (double noise : {0.1, 0.2})
    for (std::uint64_t seed : {1, 2}) {
      const auto mesh = prepare_mesh(with_noise(part.mesh, noise, seed));
      const TraceResult trace = trace_feature(*mesh, part.top_outline[5]);
      EXPECT_TRUE(trace.closed) << "noise " << noise << " seed " << seed;
      EXPECT_TRUE(same_cycle(trace.vertices, part.top_outline)) << "noise " << noise << " seed " << seed << ": "
                                                                 << trace.vertices.size() << " vertices";
    }
}

// One click on a capped cylinder's top rim: the closed rim, which decomposes the cylinder into
// its top cap (one fan of `segments` triangles) and the rest.
TEST(Trace, OneClickOnACylinderRimCutsOffItsCap) {
  const int rings = 6, segments = 48;
  const auto mesh = prepare_mesh(make_cylinder(1, 1, rings, segments, true));
  const FeatureLineResult line = traced_line(*mesh, std::uint32_t(rings * segments + 7));
  ASSERT_TRUE(line.closed);
  EXPECT_EQ(line.initial.vertices.size(), std::size_t(segments));
  const SegmentationResult parts = segment_mesh(*mesh, {line});
  ASSERT_EQ(parts.segments.size(), 2u);
  EXPECT_EQ(parts.segments[1].faces, std::size_t(segments));
  EXPECT_EQ(parts.segments[0].faces, std::size_t(2 * rings * segments + segments));
}

TEST(Trace, CubeEdgeStopsAtTheTwoCornersWhereThreeCreasesMeet) {
  const int n = 6;
  const auto mesh = prepare_mesh(make_subdivided_cube(n));
  const std::uint32_t key = vertex_at(*mesh, {0.5, 0, 0});
  const TraceResult trace = trace_feature(*mesh, key);
  ASSERT_FALSE(trace.closed);
  EXPECT_EQ(trace.vertices.size(), std::size_t(n + 1));
  for (auto v : trace.vertices) {
    EXPECT_NEAR(mesh->positions()[v].y(), 0, 1e-12);
    EXPECT_NEAR(mesh->positions()[v].z(), 0, 1e-12);
  }
  for (const auto& end : trace.ends) {
    EXPECT_EQ(end.reason, TraceStop::junction);
    EXPECT_NEAR(std::abs(mesh->positions()[end.vertex].x() - 0.5), 0.5, 1e-12);
  }
  ASSERT_EQ(trace.junctions.size(), 2u);
  for (const auto& junction : trace.junctions) {
    EXPECT_EQ(junction.branches, 3u);
    EXPECT_FALSE(junction.followed);
  }
  // Not following junctions changes nothing here; a line through the corner needs a turn.
  TraceOptions options;
  options.follow_junctions = false;
  EXPECT_EQ(trace_feature(*mesh, key, options).vertices, trace.vertices);
}

// Two roofs on an unjittered grid, crests along grid lines: the bar y = 0 across the square and
// the stem x = 0 for y > 0, meeting in a T at the origin.
HeightField t_of_roofs(int n) {
  auto z = [](double x, double y) {
    const double bar = 0.3 - 0.6 * std::abs(y);
    const double stem = y > 0 ? 0.3 - 0.6 * std::abs(x) : -1.0;
    return std::max({0.0, bar, stem});
  };
  return make_height_field(z, n, 0.0, 1);
}

TEST(Trace, TJunctionIsPassedStraightFromTheBarAndEndsTheStem) {
  const HeightField field = t_of_roofs(41);
  const auto mesh = prepare_mesh(field.mesh);
  const TraceResult bar = trace_feature(*mesh, vertex_at(*mesh, {-0.5, 0, 0.3}));
  ASSERT_FALSE(bar.closed);
  for (auto v : bar.vertices) EXPECT_NEAR(mesh->positions()[v].y(), 0, 1e-12);
  const double x0 = mesh->positions()[bar.vertices.front()].x(), x1 = mesh->positions()[bar.vertices.back()].x();
  EXPECT_NEAR(std::min(x0, x1), -1, 1e-12);
  EXPECT_NEAR(std::max(x0, x1), 1, 1e-12);
  for (const auto& end : bar.ends) EXPECT_EQ(end.reason, TraceStop::boundary);
  const auto origin = vertex_at(*mesh, {0, 0, 0.3});
  // The facets where the roofs meet add crease edges of the crest's sign beside the origin too.
  const double spacing = 2.0 / 40;
  ASSERT_FALSE(bar.junctions.empty());
  for (const auto& junction : bar.junctions) {
    EXPECT_LE(mesh->positions()[junction.vertex].head<2>().norm(), 1.01 * spacing);
    EXPECT_TRUE(junction.followed);
  }

  const TraceResult stem = trace_feature(*mesh, vertex_at(*mesh, {0, 0.5, 0.3}));
  ASSERT_FALSE(stem.closed);
  for (auto v : stem.vertices) EXPECT_NEAR(mesh->positions()[v].x(), 0, 1e-12);
  const bool origin_first = stem.vertices.front() == origin;
  const TraceEnd& at_bar = stem.ends[origin_first ? 0 : 1];
  EXPECT_EQ(at_bar.vertex, origin);
  EXPECT_EQ(at_bar.reason, TraceStop::junction);
  EXPECT_EQ(stem.ends[origin_first ? 1 : 0].reason, TraceStop::boundary);
  ASSERT_FALSE(stem.junctions.empty());
  EXPECT_EQ(stem.junctions.back().vertex, origin);
  EXPECT_FALSE(stem.junctions.back().followed);
}

// A Gaussian ridge along y = 0.1234 at full height for x < -0.1, fading to nothing by x = 0.9
// (slowly: its curvature along the crest stays under a sixth of the curvature across).
HeightField fading_ridge(int n, double jitter) {
  auto fade = [](double x) { return x < -0.1 ? 1.0 : x > 0.9 ? 0.0 : 0.5 + 0.5 * std::cos(kPi * (x + 0.1)); };
  auto z = [fade](double x, double y) {
    const double d = (y - kRidgeCrestOffset) / 0.25;
    return 0.3 * fade(x) * std::exp(-d * d);
  };
  HeightField field = make_height_field(z, n, jitter, 7);
  field.crest = [](double) { return kRidgeCrestOffset; };
  return field;
}

TEST(Trace, FadingRidgeStopsWhereItFadesAndAtTheBoundaryBehind) {
  const HeightField field = fading_ridge(61, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  const TraceResult trace = trace_feature(*mesh, nearest_vertex(field.mesh, -0.5, kRidgeCrestOffset));
  ASSERT_FALSE(trace.closed);
  EXPECT_FALSE(trace.on_crease);
  EXPECT_EQ(trace.sign, FeatureSign::ridge);
  const auto& P = mesh->positions();
  const bool left_first = P[trace.vertices.front()].x() < P[trace.vertices.back()].x();
  const TraceEnd& left = trace.ends[left_first ? 0 : 1];
  const TraceEnd& right = trace.ends[left_first ? 1 : 0];
  EXPECT_EQ(left.reason, TraceStop::boundary);
  EXPECT_NEAR(P[left.vertex].x(), -1, 1e-9);
  EXPECT_EQ(right.reason, TraceStop::feature_end);
  // The ridge's height, and its curvature across with it, is 30% of full at
  // x = -0.1 + acos(-0.4) / pi = 0.53: the trace stops there, within three edges.
  const double spacing = 2.0 / 60;
  EXPECT_NEAR(P[right.vertex].x(), -0.1 + std::acos(-0.4) / kPi, 3 * spacing);
  EXPECT_LT(crest_distance(field, vertex_positions(*mesh, trace.vertices)).max, 1.0 * spacing);
}

TEST(Trace, NoisyRidgesAndValleysStayOnTheCrest) {
  for (double noise : {0.1, 0.2}) {
    for (double amplitude : {0.3, -0.3}) {
      const HeightField field = make_ridge_field(81, 0.2, 3, amplitude, 0.25, 0.3);
      const RawMesh noisy = with_noise(field.mesh, noise, 11);
      const auto mesh = prepare_mesh(noisy);
      const double e = mean_edge_length(noisy);
      const FeatureLineResult line = traced_line(*mesh, nearest_vertex(noisy, 0.0, field.crest(0.0)));
      ASSERT_TRUE(line.trace);
      const TraceResult& trace = *line.trace;
      SCOPED_TRACE("noise " + std::to_string(noise) + " amplitude " + std::to_string(amplitude));
      EXPECT_EQ(trace.sign, amplitude > 0 ? FeatureSign::ridge : FeatureSign::valley);
      EXPECT_FALSE(trace.closed);
      // The crest crosses the whole square: the trace runs from border to border.
      for (const auto& end : trace.ends) {
        EXPECT_EQ(end.reason, TraceStop::boundary);
        EXPECT_NEAR(std::abs(mesh->positions()[end.vertex].x()), 1, 0.05);
      }
      const CrestDistance initial = crest_distance(field, vertex_positions(*mesh, trace.vertices));
      const CrestDistance refined = crest_distance(field, refined_positions(line));
      EXPECT_LT(initial.mean, 0.5 * e);
      // Measured 0.05-0.07 e (max 0.16-0.23 e): the traced line's ends are free, not pinned keys.
      EXPECT_LT(refined.mean, 0.15 * e);
      EXPECT_LT(refined.max, 0.4 * e);
    }
  }
}

TEST(Trace, ASmoothFeatureGoesOnWhereCreasesNoiseMadeAlongItMeet) {
  // At 20% noise the 80,000-triangle valley's crest has short runs of crease edges noise made;
  // where three of them met, the trace stopped as at a junction of creases, which on a smooth
  // feature is no choice the user has to make.
  const HeightField field = make_ridge_field(201, 0.2, 7, -0.3, 0.25, 0.3);
  const double fraction = 0.2 * field.spacing / mean_edge_length(field.mesh);
  const auto mesh = prepare_mesh(with_noise(field.mesh, fraction, 1000003ull * 7 + 7));
  const FeatureLineResult line = traced_line(*mesh, nearest_vertex(field.mesh, 0.0, field.crest(0.0)));
  ASSERT_TRUE(line.trace);
  for (const auto& end : line.trace->ends) {
    EXPECT_EQ(end.reason, TraceStop::boundary);
    EXPECT_NEAR(std::abs(mesh->positions()[end.vertex].x()), 1, 0.05);
  }
  const CrestDistance refined = crest_distance(field, refined_positions(line));
  EXPECT_LT(refined.mean, 0.15 * mean_edge_length(field.mesh));
}

TEST(Trace, NothingToTraceOnASphereOrAPlane) {
  const auto sphere = prepare_mesh(make_icosphere(1, 4));
  EXPECT_THROW(trace_feature(*sphere, 17), GeometryError);
  const auto plane = prepare_mesh(with_noise(make_plane_grid(41, 0.2, 1), 0.1, 3));
  EXPECT_THROW(trace_feature(*plane, nearest_vertex(make_plane_grid(41, 0.2, 1), 0, 0)), GeometryError);
}

TEST(Trace, MaxEdgesBoundsTheLine) {
  const CadPart part = make_rounded_slab({});
  const auto mesh = prepare_mesh(part.mesh);
  TraceOptions options;
  options.max_edges = 10;
  const TraceResult trace = trace_feature(*mesh, part.top_outline[5], options);
  EXPECT_FALSE(trace.closed);
  EXPECT_LE(trace.vertices.size(), 11u);
  EXPECT_TRUE(trace.ends[0].reason == TraceStop::max_edges || trace.ends[1].reason == TraceStop::max_edges);
}

TEST(Trace, RequestsAreChecked) {
  const CadPart part = make_rounded_slab({});
  const auto mesh = prepare_mesh(part.mesh);
  TraceOptions options;
  options.step = 0.5;
  EXPECT_THROW(trace_feature(*mesh, 0, options), InvalidInputError);
  EXPECT_THROW(trace_feature(*mesh, std::uint32_t(mesh->n_vertices()), {}), InvalidInputError);
  FeatureLineRequest two_keys;
  two_keys.keys = {part.top_outline[0], part.top_outline[3]};
  two_keys.trace = true;
  EXPECT_THROW(detect_feature_line(*mesh, two_keys), InvalidInputError);
  FeatureLineRequest closed;
  closed.keys = {part.top_outline[0]};
  closed.trace = true;
  closed.closed = true;
  EXPECT_THROW(detect_feature_line(*mesh, closed), InvalidInputError);
  // The initial line's bound, which bounds the trace too, is named as the request set it.
  FeatureLineRequest one_edge;
  one_edge.keys = {part.top_outline[0]};
  one_edge.trace = true;
  one_edge.options.initial.max_edges = 1;
  try {
    detect_feature_line(*mesh, one_edge);
    ADD_FAILURE() << "a trace bounded to one edge was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_STREQ(e.what(), "initial.max_edges must be at least 2 for a traced line (1 given)");
  }
}

TEST(Trace, SameAnswerEveryRun) {
  const HeightField field = make_ridge_field(61, 0.2, 5, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(with_noise(field.mesh, 0.1, 2));
  const auto key = nearest_vertex(field.mesh, 0.1, field.crest(0.1));
  const TraceResult a = trace_feature(*mesh, key), b = trace_feature(*mesh, key);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.seed, b.seed);
}

}  // namespace
}  // namespace featureline
