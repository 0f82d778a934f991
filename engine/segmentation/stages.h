// Internal to the engine: the stages of segment_mesh (engine/segmentation.h), one file each:
//  - trace.cpp: following a line between consecutive refined points across the original faces;
//  - remesh.cpp: splitting the faces the traced line crosses (the paper's Fig. 8);
//  - cut.cpp: which edges the lines cut, in snap mode (mesh edges through the nearest vertices)
//    and in remesh mode (the new edges along the line), loose ends joined to what is near;
//  - label.cpp: faces connected across uncut edges, slivers merged, parts measured and ordered.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "engine/cancellation.h"
#include "engine/internal/geometry.h"
#include "engine/segmentation.h"
#include "engine/surface_point.h"

namespace featureline {

/// barycentric_in where face f must hold `l`: an internal invariant of tracing and remeshing
/// (every point is traced in a face that holds it), so a miss is a logic error, not bad input.
inline Barycentric barycentric_of(const std::vector<Triangle>& tris, std::uint32_t f, const SurfaceLocation& l) {
  const auto w = barycentric_in(tris, f, l);
  if (!w) throw std::logic_error("segmentation: a point is not in the face it was traced in");
  return *w;
}

/// Cut edges (edge_key) -> the line that cut each first.
using CutEdges = std::unordered_map<std::uint64_t, int>;

/// The mesh the labels are for (the original in snap mode, the remeshed one in remesh mode),
/// with the tables the labelling reads, and the edges the lines cut.
struct CutMesh {
  const std::vector<Eigen::Vector3d>* positions = nullptr;
  const std::vector<Triangle>* triangles = nullptr;
  const VertexFaces* vertex_faces = nullptr;
  const std::vector<Triangle>* face_neighbors = nullptr;
  CutEdges cuts;
};

/// What cutting found besides the cuts, reported as warnings.
struct CutReport {
  std::vector<std::string> loose_ends;  ///< open ends touching neither the boundary nor another line
  std::size_t fallbacks = 0;            ///< remesh: pieces cut along edges because the walk got lost
  std::vector<std::size_t> gaps;        ///< per line: pieces between parts that share no edge
};

/// Snap mode: the chains of vertices nearest the lines, joined by shortest edge paths; loose ends
/// joined to the boundary or another chain within attach_distance.
/// \throw CancelledError once `cancel` is requested (checked per line).
CutEdges cut_along_nearest_vertices(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                    const SegmentationOptions& options, CutReport& report, const Cancellation* cancel);

/// The remeshed surface and the new edges along the lines (remesh mode).
struct RemeshedCut {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Triangle> triangles;
  std::vector<std::uint32_t> source_faces;
  CutEdges cuts;
};

/// Remesh mode: new vertices where the lines cross edges, crossed faces split, cut along them.
/// \throw CancelledError once `cancel` is requested (checked per line, before it is traced and
/// before its faces are split).
RemeshedCut cut_along_lines_by_remeshing(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                         const SegmentationOptions& options, CutReport& report, const Cancellation* cancel);

/// What labelling found, for the warnings.
struct LabelReport {
  std::vector<char> line_separates;  ///< per line: some edge it cut lies between two segments
  std::size_t merged = 0;            ///< segments merged into a neighbour (merge_tiny_segments)
};

/// Labels of the faces of `cut` (connected across uncut edges with exactly two faces), merged and
/// ordered as SegmentationResult documents; fills labels, segments, total_area and cut_edges.
/// \throw GeometryError when the cuts add no component ("the lines close no region ...").
LabelReport label_segments(const CutMesh& cut, std::size_t line_count, const SegmentationOptions& options,
                           const CutReport& report, SegmentationResult& result);

/// The warnings of SegmentationResult: loose ends, lines that separate nothing, gaps, fallbacks,
/// merged and tiny segments.
void add_segmentation_warnings(const std::vector<FeatureLineResult>& lines, const SegmentationOptions& options,
                               const CutReport& report, const LabelReport& labelling, SegmentationResult& result);

}  // namespace featureline
