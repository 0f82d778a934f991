// segment_mesh: checks its input, cuts along the lines (engine/segmentation/cut.cpp, with
// trace.cpp and remesh.cpp in remesh mode), then labels the parts (label.cpp).
#include "engine/segmentation.h"

#include <chrono>
#include <cmath>
#include <string>

#include "engine/errors.h"
#include "engine/internal/stopwatch.h"
#include "engine/segmentation/stages.h"

namespace featureline {

void check_segmentation_options(const SegmentationOptions& options) {
  using O = SegmentationOptions;
  if (!O::min_segment_area_fraction_range.contains(options.min_segment_area_fraction))
    throw InvalidInputError("min_segment_area_fraction must be in " + describe(O::min_segment_area_fraction_range));
  if (!O::attach_distance_range.contains(options.attach_distance))
    throw InvalidInputError("attach_distance must be a finite number >= " + format_number(O::attach_distance_range.min));
  if (!O::remesh_snap_range.contains(options.remesh_snap))
    throw InvalidInputError("remesh_snap must be in " + describe(O::remesh_snap_range));
}

namespace {

void check_segmentation_input(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                              const SegmentationOptions& options) {
  if (lines.empty()) throw InvalidInputError("segmentation needs at least one feature line");
  check_segmentation_options(options);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].refined.size() < 2)
      throw InvalidInputError("line " + std::to_string(i) + " has fewer than two refined points");
    for (std::size_t j = 0; j < lines[i].refined.size(); ++j)
      check_surface_point(mesh, lines[i].refined[j].face, lines[i].refined[j].barycentric,
                          "line " + std::to_string(i) + ", refined point " + std::to_string(j));
  }
}

}  // namespace

SegmentationResult segment_mesh(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                const SegmentationOptions& options, const Cancellation* cancel) {
  const auto start = std::chrono::steady_clock::now();
  check_segmentation_input(mesh, lines, options);
  throw_if_cancelled(cancel);
  SegmentationResult result;
  CutReport report;
  report.gaps.assign(lines.size(), 0);
  // The labels are for the original mesh (snap: its tables were built once in prepare_mesh) or
  // for the remeshed one, whose tables are new.
  CutMesh cut{&mesh.positions(), &mesh.triangles(), &mesh.vertex_faces(), &mesh.face_neighbors(), {}};
  VertexFaces remeshed_vertex_faces;
  std::vector<Triangle> remeshed_neighbors;
  if (options.mode == SegmentationMode::snap) {
    cut.cuts = cut_along_nearest_vertices(mesh, lines, options, report, cancel);
  } else {
    RemeshedCut remeshed = cut_along_lines_by_remeshing(mesh, lines, options, report, cancel);
    result.positions = std::move(remeshed.positions);
    result.triangles = std::move(remeshed.triangles);
    result.source_faces = std::move(remeshed.source_faces);
    result.remeshed = true;
    remeshed_vertex_faces = build_vertex_faces(result.triangles, result.positions.size());
    remeshed_neighbors = build_face_neighbors(result.triangles, result.positions.size());
    cut = CutMesh{&result.positions, &result.triangles, &remeshed_vertex_faces, &remeshed_neighbors,
                  std::move(remeshed.cuts)};
  }
  throw_if_cancelled(cancel);  // cutting is done; labelling floods every face
  const LabelReport labelling = label_segments(cut, lines.size(), options, report, result);
  add_segmentation_warnings(lines, options, report, labelling, result);
  result.elapsed_ms = ms_since(start);
  return result;
}

}  // namespace featureline
