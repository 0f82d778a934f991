// Files other tools read: feature lines as OBJ polylines, PLY edges, CGAL's `.polylines.txt` and
// CSV rows (spreadsheets, pandas: the surface points with their faces and barycentrics);
// a segmentation as a PLY with a colour and a label per face and as an OBJ with a group per part.
// One table names every output format, the JSON and glTF answers written elsewhere
// (api/feature_line_json.h, api/gltf_export.h) included, with its `?format=` name, file ending
// and MIME type, so the CLI and the server choose formats the same way.
//
// Every number is printed in the shortest form that reads back to the same double
// (std::to_chars), so a reader parsing with strtod gets the engine's coordinates bit for bit.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/enum_names.h"
#include "engine/feature_line.h"
#include "engine/prepared_mesh.h"
#include "engine/segmentation.h"

namespace featureline {

enum class ExportFormat {
  json,       ///< Featureline's own answer (api/feature_line_json.h, api/segmentation_json.h)
  glb,        ///< binary glTF (api/gltf_export.h, segmentation_to_glb)
  gltf,       ///< glTF JSON with an embedded buffer (feature_line_to_gltf_json); lines only
  obj,        ///< Wavefront OBJ: `l` polylines, or `g` groups of faces
  ply,        ///< ASCII PLY: an `edge` element, or faces with colour and label
  polylines,  ///< CGAL's polylines text (Mesh_3 feature input); lines only
  csv,        ///< one row per refined point: line, point, x, y, z, face, barycentric; lines only
};

/// The `?format=` names (lower case; parse_export_format accepts any case).
template <>
struct EnumNames<ExportFormat> {
  static constexpr std::array<std::pair<ExportFormat, const char*>, 7> entries{
      {{ExportFormat::json, "json"},
       {ExportFormat::glb, "glb"},
       {ExportFormat::gltf, "gltf"},
       {ExportFormat::obj, "obj"},
       {ExportFormat::ply, "ply"},
       {ExportFormat::polylines, "polylines"},
       {ExportFormat::csv, "csv"}}};
};

/// What a file holds.
enum class ExportContent { lines, segmentation };

/// One row of the format table.
struct ExportFormatInfo {
  ExportFormat format = ExportFormat::json;
  const char* extension = "";  ///< file name ending, dot included (".polylines.txt")
  /// Content-Type of an answer: the IANA-registered type where there is one (application/json,
  /// model/gltf-binary, model/gltf+json, model/obj); PLY and CGAL's polylines have none, and
  /// both are ASCII here, so text/plain.
  const char* mime_type = "";
  bool lines = false;         ///< can hold feature lines
  bool segmentation = false;  ///< can hold a segmentation
  /// Written by this file's export_lines / export_segmentation; false for json, glb and gltf,
  /// which the caller writes with the mapping of its answer (api/feature_line_json.h,
  /// api/gltf_export.h, api/segmentation_json.h).
  bool interchange = false;
};

/// Every format, in EnumNames order.
const std::vector<ExportFormatInfo>& export_format_table();

const ExportFormatInfo& export_format_info(ExportFormat format);

/// A `?format=` name in any case ("obj", "PLY", "polylines"); std::nullopt for anything else.
std::optional<ExportFormat> parse_export_format(std::string_view name);

/// The format a file name ends in, in any case (".obj", ".ply", ".polylines.txt", ".json",
/// ".glb", ".gltf"); std::nullopt for anything else (a bare ".txt" included).
std::optional<ExportFormat> export_format_from_path(std::string_view path);

/// Can `format` hold `content`?
bool can_export(ExportFormat format, ExportContent content);

/// "json, glb, gltf, obj, ply, polylines": the names of the formats that hold `content`, for
/// errors and help.
std::string export_format_names(ExportContent content);

/// The file endings of the formats that hold `content` (".json, .glb, ..."), for errors and help.
std::string export_format_extensions(ExportContent content);

/// The points a line is written with: its refined line on the surface
/// (FeatureLineResult::refined), as feature_line_to_json prints them. detect_feature_line fills
/// it with the initial line's vertices when the line was not refined, so this is also the
/// initial line then. A closed line's first point is not repeated.
/// \throw InvalidInputError "line <index> has fewer than two points" when it has fewer than two.
std::vector<Eigen::Vector3d> export_line_points(const FeatureLineResult& line, std::size_t index);

/// Wavefront OBJ: per line `o line_<n>`, its points as `v x y z`, then one `l i j ...` record
/// (1-based ids over the whole file; a closed line repeats its first id at the end); a line with
/// a fitted curve (FeatureLineResult::fitted) is followed by `o line_<n>_fitted` and the curve.
/// \throw InvalidInputError for no lines or a line with fewer than two points.
std::string lines_to_obj(const std::vector<FeatureLineResult>& lines);

/// ASCII PLY: `element vertex` (double x, y, z; every line's points, line after line) and
/// `element edge` (int vertex1, vertex2, and int line, the line's index): consecutive points,
/// and for a closed line the edge from its last point back to its first. When a line has a fitted
/// curve, its points follow the line's and every edge gets `uchar fitted` (1 on fitted curves).
/// \throw InvalidInputError for no lines or a line with fewer than two points.
std::string lines_to_ply(const std::vector<FeatureLineResult>& lines);

/// CGAL's polylines text (read by CGAL::IO::read_polylines, Mesh_3's feature input): one text
/// line per polyline, "N x1 y1 z1 ... xN yN zN"; a closed polyline repeats its first point at
/// the end, as CGAL writes closed polylines. A line's fitted curve, when it has one, is the text
/// line after it.
/// \throw InvalidInputError for no lines or a line with fewer than two points.
std::string lines_to_polylines(const std::vector<FeatureLineResult>& lines);

/// CSV with a header row, then one row per refined point of each line: `line` (0-based, the
/// request's order), `closed` (true/false: a loop does not repeat its first point), `point`
/// (0-based along the line), x, y, z, `face` and b0, b1, b2 (barycentric coordinates in that
/// face's corner order). When a line has a fitted curve, a last column `curve` says `refined` or
/// `fitted`, and the fitted curve's rows follow its line's with face and barycentric empty (the
/// curve may leave the surface). \throw InvalidInputError for a line with fewer than two points
std::string lines_to_csv(const std::vector<FeatureLineResult>& lines);

/// The labelled surface of a segmentation: in remesh mode the result's own positions and
/// triangles, in snap mode the prepared mesh's (SegmentationResult::labels index its triangles).
/// It refers into `mesh` or `result`, which must outlive it.
struct SegmentedSurface {
  const std::vector<Eigen::Vector3d>& positions;
  const std::vector<std::array<std::uint32_t, 3>>& triangles;
};
SegmentedSurface segmented_surface(const PreparedMesh& mesh, const SegmentationResult& result);

/// ASCII PLY of the segmented surface: every vertex (double x, y, z; vertex ids are the
/// surface's), every face in order with `uchar red green blue` (segment_colour of its label,
/// sRGB 0-255) and `int label`.
/// \throw InvalidInputError when the labels do not match the faces one to one.
std::string segmentation_to_ply(const PreparedMesh& mesh, const SegmentationResult& result);

/// Wavefront OBJ of the segmented surface: every vertex, then per part with faces a
/// `g part_<label>` group holding its faces (1-based ids), parts in label order, faces in
/// face order.
/// \throw InvalidInputError when the labels do not match the faces one to one.
std::string segmentation_to_obj(const PreparedMesh& mesh, const SegmentationResult& result);

/// The file of `lines` in an interchange format (obj, ply, polylines).
/// \throw InvalidInputError for a format that is not an interchange format for lines (json,
///        glb, gltf are the caller's), and as the writers above.
std::string export_lines(const std::vector<FeatureLineResult>& lines, ExportFormat format);

/// The file of a segmentation in an interchange format (obj, ply).
/// \throw InvalidInputError for a format that is not an interchange format for segmentations,
///        and as the writers above.
std::string export_segmentation(const PreparedMesh& mesh, const SegmentationResult& result, ExportFormat format);

}  // namespace featureline
