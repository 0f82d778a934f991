// Cancellation (engine/cancellation.h) reaches preparation and segmentation, the server's other
// long jobs: a refused or timed-out upload or segmentation stops its work instead of holding
// an engine worker.
#include <gtest/gtest.h>

#include <chrono>

#include "engine/cancellation.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/segmentation.h"
#include "engine/segmentation/stages.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

TEST(Cancellation, StopsPreparation) {
  const auto field = make_ridge_field(41, 0.2, 3, 0.3, 0.25, 0.3);
  Cancellation cancelled;
  cancelled.cancel();
  EXPECT_THROW(prepare_mesh(field.mesh, {}, &cancelled), CancelledError);
  // Not requested: the same mesh prepares.
  const Cancellation idle;
  EXPECT_NO_THROW(prepare_mesh(field.mesh, {}, &idle));
}

TEST(Cancellation, ADeadlineStopsPreparationPartWay) {
  // 180,000 triangles take far longer than 2 ms to prepare (about 0.2 s here): the deadline
  // passes inside the face loop or the curvature fits, which stop at their next check.
  const auto field = make_ridge_field(301, 0.2, 3, 0.3, 0.25, 0.3);
  const Cancellation deadline(Cancellation::Clock::now() + std::chrono::milliseconds(2));
  EXPECT_THROW(prepare_mesh(field.mesh, {}, &deadline), CancelledError);
}

TEST(Cancellation, StopsSegmentation) {
  const auto field = make_ridge_field(31, 0.0, 2, 0.3, 0.25, 0.0);
  const auto mesh = prepare_mesh(field.mesh);
  // A line from the left border to the right border cuts the square in two.
  FeatureLineRequest request;
  request.keys = {std::uint32_t(15 * 31), std::uint32_t(15 * 31 + 30)};
  const FeatureLineResult line = detect_feature_line(*mesh, request);
  EXPECT_EQ(segment_mesh(*mesh, {line}).segments.size(), 2u);
  Cancellation cancelled;
  cancelled.cancel();
  for (const auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    EXPECT_THROW(segment_mesh(*mesh, {line}, options, &cancelled), CancelledError) << int(mode);
  }
}

// The cutting stages check the cancellation themselves, per line, not only segment_mesh between
// stages: a long batch of lines stops inside the cut instead of finishing it.
TEST(Cancellation, StopsEachCuttingStage) {
  const auto field = make_ridge_field(31, 0.0, 2, 0.3, 0.25, 0.0);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {std::uint32_t(15 * 31), std::uint32_t(15 * 31 + 30)};
  const std::vector<FeatureLineResult> lines(3, detect_feature_line(*mesh, request));
  const SegmentationOptions options;
  Cancellation cancelled;
  cancelled.cancel();
  const Cancellation idle;
  CutReport report;
  report.gaps.assign(lines.size(), 0);
  EXPECT_THROW(cut_along_nearest_vertices(*mesh, lines, options, report, &cancelled), CancelledError);
  EXPECT_THROW(cut_along_lines_by_remeshing(*mesh, lines, options, report, &cancelled), CancelledError);
  // Not requested: both cut the line's edges (the same line three times: its edges once each).
  EXPECT_FALSE(cut_along_nearest_vertices(*mesh, lines, options, report, &idle).empty());
  const RemeshedCut remeshed = cut_along_lines_by_remeshing(*mesh, lines, options, report, &idle);
  EXPECT_FALSE(remeshed.cuts.empty());
  EXPECT_GT(remeshed.triangles.size(), mesh->triangles().size());
}

}  // namespace
}  // namespace featureline
