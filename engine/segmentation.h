// The paper's application: mesh decomposition along detected feature lines ("Application",
// Figs. 8 and 12). The user detects one or more feature lines around the parts to separate;
// the mesh is then cut along them and its faces labelled part by part.
//
// Two ways to put the cut on the mesh, as in the paper:
//  - snap: "the vertices nearest to the obtained feature line are finally chosen as the
//    segmentation line" -- the boundary between parts follows mesh edges;
//  - remesh: "re-sample the feature region to generate new vertices along the detected feature
//    line" (Fig. 8) -- new vertices where the line crosses edges, crossed faces split, so the
//    boundary between parts is the smooth line itself.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/feature_line.h"
#include "engine/prepared_mesh.h"
#include "engine/valid_range.h"

namespace featureline {

enum class SegmentationMode {
  snap,    ///< the paper's basic method: cut along mesh edges through the vertices nearest the line
  remesh,  ///< Fig. 8: insert vertices on the line and split the faces it crosses; cut along the line
};

struct SegmentationOptions {
  SegmentationMode mode = SegmentationMode::snap;
  /// Segments with less than this fraction of the mesh's area are reported in `warnings`
  /// (usually a sliver between two lines that nearly meet, or where a line doubles back).
  double min_segment_area_fraction = 0.001;
  /// Merge each segment below min_segment_area_fraction into the neighbouring segment it shares
  /// the most cut boundary with (slivers left where a detected line doubles back to a key or
  /// two lines nearly meet). The merge is reported in `warnings`; false only reports them.
  bool merge_tiny_segments = false;
  /// An end of an open line that is neither on the mesh boundary nor on another line is joined
  /// to the nearest such place when it is within this distance (in edge lengths at the end), so a line
  /// drawn from one loop to another or to a hole's rim closes its regions. 0 disables.
  double attach_distance = 2.0;
  /// remesh only: a point of the line closer than this fraction of an edge (or barycentric unit)
  /// to a vertex or an edge is moved onto it, so the remeshed faces have no needles. 0 keeps
  /// every crossing where it is (to 1e-6).
  double remesh_snap = 0.01;

  /// What segment_mesh accepts; api/options_table.cpp's limits lie inside.
  static constexpr ValidRange min_segment_area_fraction_range = half_open_range(0, 1);
  static constexpr ValidRange attach_distance_range = finite_from(0);
  static constexpr ValidRange remesh_snap_range = half_open_range(0, 0.25);
};

/// \throw InvalidInputError when an option is outside its range (SegmentationOptions::*_range).
void check_segmentation_options(const SegmentationOptions& options);

/// One part of the decomposition.
struct Segment {
  int label = 0;
  std::size_t faces = 0;
  double area = 0;
  /// Length of the cut edges between this segment and other segments (the mesh's own boundary
  /// and cut edges with this segment on both sides, e.g. a line's loose end, do not count).
  double boundary_length = 0;
  std::array<double, 3> bbox_min{0, 0, 0};
  std::array<double, 3> bbox_max{0, 0, 0};
};

struct SegmentationResult {
  /// One label per face of the (possibly remeshed) mesh, 0..segments-1; label 0 is the largest
  /// segment by area, then decreasing area (ties: the segment holding the lower face id first).
  std::vector<int> labels;
  std::vector<Segment> segments;  ///< indexed by label
  std::vector<std::string> warnings;
  /// remesh mode: the new mesh. Original vertex ids stay valid (same positions); new vertices
  /// are appended. Triangle f < the original face count is a part of original face f; the
  /// triangles split off it are appended. Empty in snap mode (the mesh is unchanged).
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> source_faces;  ///< remesh mode: original face of each triangle
  bool remeshed = false;
  std::size_t cut_edges = 0;  ///< edges of the (possibly remeshed) mesh the lines cut
  double total_area = 0;
  double elapsed_ms = 0;
};

/// Decomposes the mesh along the lines' refined points (FeatureLineResult::refined; closed lines
/// are closed, open lines should end on the mesh boundary or on another line). Every face is
/// labelled; faces are connected across edges that no line cuts and that have exactly two faces,
/// so separate components of the mesh are separate segments too. Thread-safe (the mesh is only
/// read).
/// \throw InvalidInputError for no lines, a line with fewer than two points, a face id out of
///        range, bad barycentric coordinates or bad options;
///        GeometryError when the lines close no region ("the lines close no region: ...");
///        CancelledError once `cancel` is requested (checked per line and before labelling).
SegmentationResult segment_mesh(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines,
                                const SegmentationOptions& options = {}, const Cancellation* cancel = nullptr);

}  // namespace featureline
