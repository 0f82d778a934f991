#include "api/export_formats.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <system_error>

#include "api/gltf_export.h"
#include "engine/errors.h"

namespace featureline {
namespace {

bool equal_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

// Shortest text that reads back to the same double (std::to_chars without a precision).
void append_number(std::string& out, double x) {
  char buffer[32];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, x);
  if (error != std::errc()) throw Error("printing a number failed");
  out.append(buffer, end);
}

// "x y z".
void append_coordinates(std::string& out, const Eigen::Vector3d& p) {
  for (int k = 0; k < 3; ++k) {
    if (k > 0) out += ' ';
    append_number(out, p[k]);
  }
}

// " x y z", after a keyword or a count.
void append_point(std::string& out, const Eigen::Vector3d& p) {
  out += ' ';
  append_coordinates(out, p);
}

std::vector<std::vector<Eigen::Vector3d>> points_of(const std::vector<FeatureLineResult>& lines) {
  if (lines.empty()) throw InvalidInputError("nothing to write: no line");
  std::vector<std::vector<Eigen::Vector3d>> points;
  for (std::size_t i = 0; i < lines.size(); ++i) points.push_back(export_line_points(lines[i], i));
  return points;
}

// A line's fitted curve when it has one of two points or more (FeatureLineResult::fitted).
const FittedCurveResult* fitted_of(const FeatureLineResult& line) {
  return line.fitted && line.fitted->points.size() >= 2 ? &*line.fitted : nullptr;
}

bool any_fitted(const std::vector<FeatureLineResult>& lines) {
  return std::any_of(lines.begin(), lines.end(), [](const FeatureLineResult& l) { return fitted_of(l) != nullptr; });
}

void check_labels(const SegmentedSurface& surface, const SegmentationResult& result) {
  if (result.labels.size() != surface.triangles.size())
    throw InvalidInputError("the segmentation has " + std::to_string(result.labels.size()) + " labels for " +
                            std::to_string(surface.triangles.size()) + " faces");
  for (const int label : result.labels)
    if (label < 0 || std::size_t(label) >= result.segments.size())
      throw InvalidInputError("label " + std::to_string(label) + " is not one of the " +
                              std::to_string(result.segments.size()) + " segments");
}

std::string names_where(ExportContent content, bool extensions) {
  std::string out;
  for (const auto& row : export_format_table()) {
    if (!can_export(row.format, content)) continue;
    if (!out.empty()) out += ", ";
    out += extensions ? row.extension : to_string(row.format);
  }
  return out;
}

}  // namespace

const std::vector<ExportFormatInfo>& export_format_table() {
  // format, extension, MIME type, lines, segmentation, interchange
  static const std::vector<ExportFormatInfo> table{
      {ExportFormat::json, ".json", "application/json", true, true, false},
      {ExportFormat::glb, ".glb", "model/gltf-binary", true, true, false},
      {ExportFormat::gltf, ".gltf", "model/gltf+json", true, false, false},
      {ExportFormat::obj, ".obj", "model/obj", true, true, true},
      {ExportFormat::ply, ".ply", "text/plain", true, true, true},
      {ExportFormat::polylines, ".polylines.txt", "text/plain", true, false, true},
      {ExportFormat::csv, ".csv", "text/csv", true, false, true},
  };
  return table;
}

const ExportFormatInfo& export_format_info(ExportFormat format) {
  for (const auto& row : export_format_table())
    if (row.format == format) return row;
  throw Error("export format without a table row");
}

std::optional<ExportFormat> parse_export_format(std::string_view name) {
  for (const auto& [format, entry_name] : EnumNames<ExportFormat>::entries)
    if (equal_ignoring_case(name, entry_name)) return format;
  return std::nullopt;
}

std::optional<ExportFormat> export_format_from_path(std::string_view path) {
  // The longest matching ending wins, so ".polylines.txt" is never taken for another ".txt".
  std::optional<ExportFormat> best;
  std::size_t best_length = 0;
  for (const auto& row : export_format_table()) {
    const std::string_view ending = row.extension;
    if (path.size() > ending.size() && ending.size() > best_length &&
        equal_ignoring_case(path.substr(path.size() - ending.size()), ending)) {
      best = row.format;
      best_length = ending.size();
    }
  }
  return best;
}

bool can_export(ExportFormat format, ExportContent content) {
  const auto& row = export_format_info(format);
  return content == ExportContent::lines ? row.lines : row.segmentation;
}

std::string export_format_names(ExportContent content) { return names_where(content, false); }

std::string export_format_extensions(ExportContent content) { return names_where(content, true); }

std::vector<Eigen::Vector3d> export_line_points(const FeatureLineResult& line, std::size_t index) {
  if (line.refined.size() < 2) throw InvalidInputError("line " + std::to_string(index) + " has fewer than two points");
  std::vector<Eigen::Vector3d> points;
  points.reserve(line.refined.size());
  for (const auto& p : line.refined) points.push_back(p.position);
  return points;
}

std::string lines_to_obj(const std::vector<FeatureLineResult>& lines) {
  const auto points = points_of(lines);
  std::string out = "# Featureline: " + std::to_string(lines.size()) + " feature lines\n";
  std::size_t first = 1;  // OBJ ids are 1-based and count over the whole file
  for (std::size_t i = 0; i < lines.size(); ++i) {
    out += "o line_" + std::to_string(i) + "\n";
    for (const auto& p : points[i]) {
      out += 'v';
      append_point(out, p);
      out += '\n';
    }
    out += 'l';
    for (std::size_t k = 0; k < points[i].size(); ++k) out += ' ' + std::to_string(first + k);
    if (lines[i].closed) out += ' ' + std::to_string(first);
    out += '\n';
    first += points[i].size();
    if (const FittedCurveResult* fitted = fitted_of(lines[i])) {
      out += "o line_" + std::to_string(i) + "_fitted\n";
      for (const auto& p : fitted->points) {
        out += 'v';
        append_point(out, p);
        out += '\n';
      }
      out += 'l';
      for (std::size_t k = 0; k < fitted->points.size(); ++k) out += ' ' + std::to_string(first + k);
      if (fitted->closed) out += ' ' + std::to_string(first);
      out += '\n';
      first += fitted->points.size();
    }
  }
  return out;
}

std::string lines_to_ply(const std::vector<FeatureLineResult>& lines) {
  const auto points = points_of(lines);
  // Each line's refined points, then its fitted curve's when it has one (edges marked fitted).
  struct Polyline {
    const std::vector<Eigen::Vector3d>* points;
    bool closed;
    std::size_t line;
    bool fitted;
  };
  std::vector<Polyline> polylines;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    polylines.push_back({&points[i], lines[i].closed, i, false});
    if (const FittedCurveResult* fitted = fitted_of(lines[i])) polylines.push_back({&fitted->points, fitted->closed, i, true});
  }
  const bool marked = any_fitted(lines);
  std::size_t vertices = 0, edges = 0;
  for (const auto& p : polylines) {
    vertices += p.points->size();
    edges += p.points->size() - (p.closed ? 0 : 1);
  }
  std::string out = "ply\nformat ascii 1.0\ncomment Featureline: " + std::to_string(lines.size()) +
                    " feature lines\nelement vertex " + std::to_string(vertices) +
                    "\nproperty double x\nproperty double y\nproperty double z\nelement edge " + std::to_string(edges) +
                    "\nproperty int vertex1\nproperty int vertex2\nproperty int line\n" +
                    (marked ? "property uchar fitted\n" : "") + "end_header\n";
  for (const auto& p : polylines)
    for (const auto& x : *p.points) {
      append_coordinates(out, x);
      out += '\n';
    }
  std::size_t first = 0;
  for (const auto& p : polylines) {
    const std::size_t n = p.points->size();
    const std::size_t count = p.closed ? n : n - 1;
    for (std::size_t k = 0; k < count; ++k)
      out += std::to_string(first + k) + ' ' + std::to_string(first + (k + 1) % n) + ' ' + std::to_string(p.line) +
             (marked ? (p.fitted ? " 1" : " 0") : "") + '\n';
    first += n;
  }
  return out;
}

std::string lines_to_polylines(const std::vector<FeatureLineResult>& lines) {
  const auto points = points_of(lines);
  std::string out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    out += std::to_string(points[i].size() + (lines[i].closed ? 1 : 0));
    for (const auto& p : points[i]) append_point(out, p);
    if (lines[i].closed) append_point(out, points[i].front());
    out += '\n';
    if (const FittedCurveResult* fitted = fitted_of(lines[i])) {
      out += std::to_string(fitted->points.size() + (fitted->closed ? 1 : 0));
      for (const auto& p : fitted->points) append_point(out, p);
      if (fitted->closed) append_point(out, fitted->points.front());
      out += '\n';
    }
  }
  return out;
}

std::string lines_to_csv(const std::vector<FeatureLineResult>& lines) {
  // With fitted curves a last column says which curve a row is on; fitted points lie on no face.
  const bool marked = any_fitted(lines);
  std::string out = marked ? "line,closed,point,x,y,z,face,b0,b1,b2,curve\n" : "line,closed,point,x,y,z,face,b0,b1,b2\n";
  for (std::size_t i = 0; i < lines.size(); ++i) {
    export_line_points(lines[i], i);  // the same check as the other formats: two points at least
    for (std::size_t k = 0; k < lines[i].refined.size(); ++k) {
      const SurfacePoint& p = lines[i].refined[k];
      out += std::to_string(i) + (lines[i].closed ? ",true," : ",false,") + std::to_string(k);
      for (double x : {p.position.x(), p.position.y(), p.position.z()}) out += ',', append_number(out, x);
      out += ',' + std::to_string(p.face);
      for (double b : p.barycentric) out += ',', append_number(out, b);
      out += marked ? ",refined\n" : "\n";
    }
    const FittedCurveResult* fitted = fitted_of(lines[i]);
    if (!fitted) continue;
    for (std::size_t k = 0; k < fitted->points.size(); ++k) {
      out += std::to_string(i) + (fitted->closed ? ",true," : ",false,") + std::to_string(k);
      for (double x : {fitted->points[k].x(), fitted->points[k].y(), fitted->points[k].z()}) out += ',', append_number(out, x);
      out += ",,,,,fitted\n";
    }
  }
  return out;
}

SegmentedSurface segmented_surface(const PreparedMesh& mesh, const SegmentationResult& result) {
  if (result.remeshed) return {result.positions, result.triangles};
  return {mesh.positions(), mesh.triangles()};
}

std::string segmentation_to_ply(const PreparedMesh& mesh, const SegmentationResult& result) {
  const SegmentedSurface surface = segmented_surface(mesh, result);
  check_labels(surface, result);
  std::string out = "ply\nformat ascii 1.0\ncomment Featureline segmentation: " + std::to_string(result.segments.size()) +
                    " parts\nelement vertex " + std::to_string(surface.positions.size()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                    std::to_string(surface.triangles.size()) +
                    "\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
                    "property uchar blue\nproperty int label\nend_header\n";
  for (const auto& p : surface.positions) {
    append_coordinates(out, p);
    out += '\n';
  }
  // The palette of the JSON answer and the GLB (segment_colour), in 8-bit sRGB.
  std::vector<std::string> colours;
  for (std::size_t label = 0; label < result.segments.size(); ++label) {
    std::string rgb;
    for (const double c : segment_colour(int(label))) rgb += ' ' + std::to_string(std::lround(std::clamp(c, 0.0, 1.0) * 255));
    colours.push_back(rgb);
  }
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    const auto& t = surface.triangles[f];
    out += "3 " + std::to_string(t[0]) + ' ' + std::to_string(t[1]) + ' ' + std::to_string(t[2]) +
           colours[std::size_t(result.labels[f])] + ' ' + std::to_string(result.labels[f]) + '\n';
  }
  return out;
}

std::string segmentation_to_obj(const PreparedMesh& mesh, const SegmentationResult& result) {
  const SegmentedSurface surface = segmented_surface(mesh, result);
  check_labels(surface, result);
  std::string out = "# Featureline segmentation: " + std::to_string(result.segments.size()) + " parts\n";
  for (const auto& p : surface.positions) {
    out += 'v';
    append_point(out, p);
    out += '\n';
  }
  std::vector<std::vector<std::uint32_t>> faces_of(result.segments.size());
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) faces_of[std::size_t(result.labels[f])].push_back(std::uint32_t(f));
  for (std::size_t label = 0; label < faces_of.size(); ++label) {
    if (faces_of[label].empty()) continue;
    out += "g part_" + std::to_string(label) + '\n';
    for (const auto f : faces_of[label]) {
      const auto& t = surface.triangles[f];
      out += "f " + std::to_string(t[0] + 1) + ' ' + std::to_string(t[1] + 1) + ' ' + std::to_string(t[2] + 1) + '\n';
    }
  }
  return out;
}

std::string export_lines(const std::vector<FeatureLineResult>& lines, ExportFormat format) {
  switch (format) {
    case ExportFormat::obj: return lines_to_obj(lines);
    case ExportFormat::ply: return lines_to_ply(lines);
    case ExportFormat::polylines: return lines_to_polylines(lines);
    case ExportFormat::csv: return lines_to_csv(lines);
    default:
      throw InvalidInputError("lines are written here as obj, ply, polylines or csv, not " + to_string(format));
  }
}

std::string export_segmentation(const PreparedMesh& mesh, const SegmentationResult& result, ExportFormat format) {
  switch (format) {
    case ExportFormat::obj: return segmentation_to_obj(mesh, result);
    case ExportFormat::ply: return segmentation_to_ply(mesh, result);
    default: throw InvalidInputError("a segmentation is written here as obj or ply, not " + to_string(format));
  }
}

}  // namespace featureline
