// Files other tools read (api/export_formats.h): the format table, exact text of hand-built
// lines and segmentations, numbers that read back bit for bit, and segmentations of a capsule
// whose PLY has the faces and labels of the result. ExportFormatsSample writes the files of real
// lines and segmentations for tests/integration/formats_readback_test.py, which reads them with
// independent readers (VTK, Open3D, meshio).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include <unistd.h>

#include "api/export_formats.h"
#include "api/feature_line_json.h"
#include "api/gltf_export.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/mesh_io.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;
namespace fs = std::filesystem;

SurfacePoint at(double x, double y, double z) {
  SurfacePoint p;
  p.position = Eigen::Vector3d(x, y, z);
  p.barycentric = {1, 0, 0};
  return p;
}

FeatureLineResult line_of(std::vector<SurfacePoint> points, bool closed) {
  FeatureLineResult line;
  line.closed = closed;
  line.refined = std::move(points);
  return line;
}

// An open line whose numbers need every digit or an exponent, and a closed triangle.
std::vector<FeatureLineResult> hand_built_lines() {
  return {line_of({at(0, 0.1, -2.5), at(1, 1.0 / 3, 1e-20), at(2, 0, 123456789.125)}, false),
          line_of({at(0, 0, 0), at(1, 0, 0), at(0, 1, 0)}, true)};
}

TEST(ExportFormatTable, NamesExtensionsAndMimeTypes) {
  // Every name has one row, and parsing its name or a file ending in its extension finds it.
  ASSERT_EQ(export_format_table().size(), EnumNames<ExportFormat>::entries.size());
  for (const auto& [format, name] : EnumNames<ExportFormat>::entries) {
    EXPECT_EQ(export_format_info(format).format, format);
    EXPECT_EQ(parse_export_format(name), format);
    EXPECT_EQ(export_format_from_path(std::string("out/file") + export_format_info(format).extension), format) << name;
  }
  EXPECT_EQ(parse_export_format("PLY"), ExportFormat::ply);
  EXPECT_EQ(parse_export_format("Polylines"), ExportFormat::polylines);
  EXPECT_EQ(parse_export_format("stl"), std::nullopt);
  EXPECT_EQ(parse_export_format(""), std::nullopt);

  EXPECT_EQ(export_format_from_path("lines.OBJ"), ExportFormat::obj);
  EXPECT_EQ(export_format_from_path("a.b/lines.ply"), ExportFormat::ply);
  EXPECT_EQ(export_format_from_path("edges.POLYLINES.TXT"), ExportFormat::polylines);
  EXPECT_EQ(export_format_from_path("parts.json"), ExportFormat::json);
  EXPECT_EQ(export_format_from_path("parts.glb"), ExportFormat::glb);
  EXPECT_EQ(export_format_from_path("notes.txt"), std::nullopt);      // only CGAL's double ending
  EXPECT_EQ(export_format_from_path("lines.obj.gz"), std::nullopt);
  EXPECT_EQ(export_format_from_path(".obj"), std::nullopt);           // a name, not an ending
  EXPECT_EQ(export_format_from_path("ply"), std::nullopt);

  EXPECT_STREQ(export_format_info(ExportFormat::obj).mime_type, "model/obj");
  EXPECT_STREQ(export_format_info(ExportFormat::ply).mime_type, "text/plain");
  EXPECT_STREQ(export_format_info(ExportFormat::polylines).mime_type, "text/plain");
  EXPECT_STREQ(export_format_info(ExportFormat::glb).mime_type, "model/gltf-binary");
  EXPECT_STREQ(export_format_info(ExportFormat::gltf).mime_type, "model/gltf+json");
  EXPECT_STREQ(export_format_info(ExportFormat::json).mime_type, "application/json");

  EXPECT_EQ(export_format_names(ExportContent::lines), "json, glb, gltf, obj, ply, polylines, csv");
  EXPECT_EQ(export_format_names(ExportContent::segmentation), "json, glb, obj, ply");
  EXPECT_EQ(export_format_extensions(ExportContent::lines), ".json, .glb, .gltf, .obj, .ply, .polylines.txt, .csv");
  EXPECT_STREQ(export_format_info(ExportFormat::csv).mime_type, "text/csv");
  EXPECT_FALSE(can_export(ExportFormat::csv, ExportContent::segmentation));
  EXPECT_FALSE(can_export(ExportFormat::polylines, ExportContent::segmentation));
  EXPECT_TRUE(can_export(ExportFormat::ply, ExportContent::segmentation));
  EXPECT_FALSE(export_format_info(ExportFormat::glb).interchange);  // the caller writes it
  EXPECT_TRUE(export_format_info(ExportFormat::obj).interchange);
}

TEST(ExportLines, ObjHasOneObjectAndOnePolylinePerLine) {
  EXPECT_EQ(lines_to_obj(hand_built_lines()),
            "# Featureline: 2 feature lines\n"
            "o line_0\n"
            "v 0 0.1 -2.5\n"
            "v 1 0.3333333333333333 1e-20\n"
            "v 2 0 123456789.125\n"
            "l 1 2 3\n"
            "o line_1\n"
            "v 0 0 0\n"
            "v 1 0 0\n"
            "v 0 1 0\n"
            "l 4 5 6 4\n");
}

TEST(ExportLines, PlyHasAnEdgePerSegmentAndTheClosingEdge) {
  EXPECT_EQ(lines_to_ply(hand_built_lines()),
            "ply\n"
            "format ascii 1.0\n"
            "comment Featureline: 2 feature lines\n"
            "element vertex 6\n"
            "property double x\n"
            "property double y\n"
            "property double z\n"
            "element edge 5\n"
            "property int vertex1\n"
            "property int vertex2\n"
            "property int line\n"
            "end_header\n"
            "0 0.1 -2.5\n"
            "1 0.3333333333333333 1e-20\n"
            "2 0 123456789.125\n"
            "0 0 0\n"
            "1 0 0\n"
            "0 1 0\n"
            "0 1 0\n"
            "1 2 0\n"
            "3 4 1\n"
            "4 5 1\n"
            "5 3 1\n");
}

TEST(ExportLines, CgalPolylinesRepeatTheFirstPointOfAClosedLine) {
  EXPECT_EQ(lines_to_polylines(hand_built_lines()),
            "3 0 0.1 -2.5 1 0.3333333333333333 1e-20 2 0 123456789.125\n"
            "4 0 0 0 1 0 0 0 1 0 0 0 0\n");
}

TEST(ExportLines, CsvHasARowPerPointWithItsFaceAndBarycentrics) {
  auto lines = hand_built_lines();
  lines[1].refined[2].face = 7;
  lines[1].refined[2].barycentric = {0.25, 0.5, 0.25};
  EXPECT_EQ(lines_to_csv(lines),
            "line,closed,point,x,y,z,face,b0,b1,b2\n"
            "0,false,0,0,0.1,-2.5,0,1,0,0\n"
            "0,false,1,1,0.3333333333333333,1e-20,0,1,0,0\n"
            "0,false,2,2,0,123456789.125,0,1,0,0\n"
            "1,true,0,0,0,0,0,1,0,0\n"
            "1,true,1,1,0,0,0,1,0,0\n"
            "1,true,2,0,1,0,7,0.25,0.5,0.25\n");
}

TEST(ExportLines, DispatchByFormatMatchesTheWriters) {
  const auto lines = hand_built_lines();
  EXPECT_EQ(export_lines(lines, ExportFormat::obj), lines_to_obj(lines));
  EXPECT_EQ(export_lines(lines, ExportFormat::ply), lines_to_ply(lines));
  EXPECT_EQ(export_lines(lines, *export_format_from_path("x.polylines.txt")), lines_to_polylines(lines));
  EXPECT_EQ(export_lines(lines, *export_format_from_path("lines.csv")), lines_to_csv(lines));
  for (const auto format : {ExportFormat::json, ExportFormat::glb, ExportFormat::gltf})
    EXPECT_THROW(export_lines(lines, format), InvalidInputError) << to_string(format);
}

TEST(ExportLines, NumbersReadBackBitForBit) {
  // Shortest round-trip printing: strtod gives back the very doubles, over many magnitudes.
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> mantissa(-1, 1);
  std::uniform_int_distribution<int> exponent(-300, 300);
  std::vector<SurfacePoint> points;
  for (int i = 0; i < 400; ++i) {
    auto value = [&] { return std::ldexp(mantissa(random), exponent(random)); };
    points.push_back(at(value(), value() * 1e-3, mantissa(random)));
  }
  points.push_back(at(-0.0, 5e-324, 1.7976931348623157e308));  // signed zero, subnormal, largest
  const std::string text = lines_to_polylines({line_of(points, false)});
  std::istringstream in(text);
  std::size_t count = 0;
  in >> count;
  ASSERT_EQ(count, points.size());
  for (const auto& p : points)
    for (int k = 0; k < 3; ++k) {
      std::string token;
      in >> token;
      const double back = std::strtod(token.c_str(), nullptr);
      EXPECT_EQ(std::memcmp(&back, &p.position[k], sizeof back), 0) << token << " vs " << p.position[k];
    }
}

TEST(ExportLines, RefusesLinesWithoutPoints) {
  EXPECT_THROW(lines_to_obj({}), InvalidInputError);
  auto lines = hand_built_lines();
  lines[1].refined.resize(1);
  try {
    lines_to_ply(lines);
    FAIL() << "a one-point line was written";
  } catch (const InvalidInputError& e) {
    EXPECT_STREQ(e.what(), "line 1 has fewer than two points");
  }
}

TEST(ExportLines, UnrefinedLineIsWrittenWithItsInitialVertices) {
  // refine = false: the engine's refined line is the initial one, on its vertices.
  const auto field = make_ridge_field(31, 0.2, 1, 0.3, 0.25, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  request.options.refine = false;
  const auto result = detect_feature_line(*mesh, request);
  const auto points = export_line_points(result, 0);
  ASSERT_EQ(points.size(), result.initial_points.size());
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i], result.initial_points[i]);
}

// A unit square of two triangles, labelled the other way round from area order.
struct TinySegmentation {
  std::shared_ptr<const PreparedMesh> mesh;
  SegmentationResult result;
  TinySegmentation() {
    RawMesh raw;
    raw.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    raw.triangles = {{0, 1, 2}, {0, 2, 3}};
    mesh = prepare_mesh(raw);
    result.labels = {1, 0};
    result.segments.resize(2);
    result.segments[0].label = 0;
    result.segments[1].label = 1;
  }
};

TEST(ExportSegmentation, PlyColoursAndLabelsEachFace) {
  const TinySegmentation tiny;
  // segment_colour(0) and (1) in 8-bit sRGB: (0.8404, 0.3196, 0.3196) and (0.1748, 0.3412, 0.7452).
  EXPECT_EQ(segmentation_to_ply(*tiny.mesh, tiny.result),
            "ply\n"
            "format ascii 1.0\n"
            "comment Featureline segmentation: 2 parts\n"
            "element vertex 4\n"
            "property double x\n"
            "property double y\n"
            "property double z\n"
            "element face 2\n"
            "property list uchar int vertex_indices\n"
            "property uchar red\n"
            "property uchar green\n"
            "property uchar blue\n"
            "property int label\n"
            "end_header\n"
            "0 0 0\n"
            "1 0 0\n"
            "1 1 0\n"
            "0 1 0\n"
            "3 0 1 2 45 87 190 1\n"
            "3 0 2 3 214 81 81 0\n");
}

TEST(ExportSegmentation, ObjGroupsFacesByPart) {
  const TinySegmentation tiny;
  EXPECT_EQ(segmentation_to_obj(*tiny.mesh, tiny.result),
            "# Featureline segmentation: 2 parts\n"
            "v 0 0 0\n"
            "v 1 0 0\n"
            "v 1 1 0\n"
            "v 0 1 0\n"
            "g part_0\n"
            "f 1 3 4\n"
            "g part_1\n"
            "f 1 2 3\n");
  EXPECT_EQ(export_segmentation(*tiny.mesh, tiny.result, ExportFormat::obj), segmentation_to_obj(*tiny.mesh, tiny.result));
  EXPECT_THROW(export_segmentation(*tiny.mesh, tiny.result, ExportFormat::polylines), InvalidInputError);
  EXPECT_THROW(export_segmentation(*tiny.mesh, tiny.result, ExportFormat::glb), InvalidInputError);
}

TEST(ExportSegmentation, RemeshedResultIsWrittenWithItsOwnSurface) {
  TinySegmentation tiny;
  // The square's second triangle split at its centroid: five vertices, four triangles.
  tiny.result.remeshed = true;
  tiny.result.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {1.0 / 3, 2.0 / 3, 0}};
  tiny.result.triangles = {{0, 1, 2}, {0, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  tiny.result.labels = {0, 0, 1, 1};
  const std::string obj = segmentation_to_obj(*tiny.mesh, tiny.result);
  EXPECT_NE(obj.find("v 0.3333333333333333 0.6666666666666666 0\n"), std::string::npos) << obj;
  EXPECT_NE(obj.find("g part_0\nf 1 2 3\nf 1 3 5\ng part_1\nf 3 4 5\nf 4 1 5\n"), std::string::npos) << obj;
  const std::string ply = segmentation_to_ply(*tiny.mesh, tiny.result);
  EXPECT_NE(ply.find("element vertex 5\n"), std::string::npos);
  EXPECT_NE(ply.find("element face 4\n"), std::string::npos);
}

TEST(ExportSegmentation, RefusesLabelsThatDoNotMatchTheFaces) {
  TinySegmentation tiny;
  tiny.result.labels = {0};
  EXPECT_THROW(segmentation_to_ply(*tiny.mesh, tiny.result), InvalidInputError);
  tiny.result.labels = {0, 2};  // only two segments
  EXPECT_THROW(segmentation_to_obj(*tiny.mesh, tiny.result), InvalidInputError);
}

// The header counts and the face records of an ASCII PLY written by segmentation_to_ply.
struct PlyFaces {
  std::size_t vertices = 0;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<int> labels;
  std::vector<std::array<int, 3>> colours;
};
PlyFaces read_ply_faces(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::size_t faces = 0;
  PlyFaces ply;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word, element;
    words >> word >> element;
    if (word == "element" && element == "vertex") words >> ply.vertices;
    if (word == "element" && element == "face") words >> faces;
  }
  for (std::size_t v = 0; v < ply.vertices; ++v) std::getline(in, line);
  for (std::size_t f = 0; f < faces; ++f) {
    int corners = 0;
    std::array<std::uint32_t, 3> t{};
    std::array<int, 3> rgb{};
    int label = -1;
    in >> corners >> t[0] >> t[1] >> t[2] >> rgb[0] >> rgb[1] >> rgb[2] >> label;
    EXPECT_EQ(corners, 3);
    ply.triangles.push_back(t);
    ply.colours.push_back(rgb);
    ply.labels.push_back(label);
  }
  std::string rest;
  EXPECT_FALSE(in >> rest) << "after the faces: " << rest;
  return ply;
}

// The capsule cut at its equator, in both modes: the PLY holds the result's faces and labels,
// one colour per label, distinct between labels; the engine's own reader reads the same surface.
TEST(ExportSegmentation, CapsuleHalvesInBothModes) {
  const int segments = 48, rings_per_cap = 12, rings_cylinder = 8;
  const auto mesh = prepare_mesh(make_capsule(1, 2, segments, rings_per_cap, rings_cylinder));
  const auto equator = capsule_equator(segments, rings_per_cap, rings_cylinder);
  FeatureLineRequest request;
  request.keys = {equator[0], equator[12], equator[24], equator[36]};
  request.closed = true;
  const auto line = detect_feature_line(*mesh, request);
  for (const auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SCOPED_TRACE(to_string(mode));
    SegmentationOptions options;
    options.mode = mode;
    const auto result = segment_mesh(*mesh, {line}, options);
    ASSERT_EQ(result.segments.size(), 2u);
    const SegmentedSurface surface = segmented_surface(*mesh, result);
    const PlyFaces ply = read_ply_faces(segmentation_to_ply(*mesh, result));
    EXPECT_EQ(ply.vertices, surface.positions.size());
    EXPECT_EQ(ply.triangles, surface.triangles);
    EXPECT_EQ(ply.labels, result.labels);
    std::map<int, std::size_t> faces_per_label;
    std::map<int, std::set<std::array<int, 3>>> colours_per_label;
    for (std::size_t f = 0; f < ply.labels.size(); ++f) {
      ++faces_per_label[ply.labels[f]];
      colours_per_label[ply.labels[f]].insert(ply.colours[f]);
    }
    ASSERT_EQ(faces_per_label.size(), 2u);
    for (const auto& s : result.segments) EXPECT_EQ(faces_per_label[s.label], s.faces);
    ASSERT_EQ(colours_per_label[0].size(), 1u);
    ASSERT_EQ(colours_per_label[1].size(), 1u);
    EXPECT_NE(*colours_per_label[0].begin(), *colours_per_label[1].begin());

    for (const auto format : {MeshFormat::ply, MeshFormat::obj}) {
      const std::string text = format == MeshFormat::ply ? segmentation_to_ply(*mesh, result) : segmentation_to_obj(*mesh, result);
      const RawMesh back = read_mesh(text, format);
      ASSERT_EQ(back.positions.size(), surface.positions.size());
      for (std::size_t v = 0; v < back.positions.size(); ++v)
        for (int k = 0; k < 3; ++k) ASSERT_EQ(back.positions[v][k], surface.positions[v][k]) << "vertex " << v;
      if (format == MeshFormat::ply) {
        EXPECT_EQ(back.triangles, surface.triangles);
      } else {  // grouped by part: the same triangles, part after part
        std::vector<std::array<std::uint32_t, 3>> grouped;
        for (int label = 0; label < 2; ++label)
          for (std::size_t f = 0; f < surface.triangles.size(); ++f)
            if (result.labels[f] == label) grouped.push_back(surface.triangles[f]);
        EXPECT_EQ(back.triangles, grouped);
      }
    }
  }
}

// Real lines and segmentations written where FEATURELINE_EXPORT_SAMPLES says (else a temporary
// folder), with expected.json beside them holding the JSON answers they came from:
// {"lines": [feature_line_to_json...], "segmentations": {"snap"|"remesh": segmentation_to_json
// plus "surface": {"vertices", "faces"}}, "files": {...}}. tests/integration/formats_readback_test.py
// reads the files with independent readers and compares them with expected.json.
TEST(ExportFormatsSample, WritesLinesAndSegmentationsForReadback) {
  const char* env = std::getenv("FEATURELINE_EXPORT_SAMPLES");
  const fs::path dir = env && *env ? fs::path(env)
                                   : fs::temp_directory_path() / ("featureline_export_sample_" + std::to_string(::getpid()));
  fs::create_directories(dir);

  // A ring-shaped roof (a sharp crease on the circle r = 0.55, on a jittered grid whose edges
  // do not follow it): the closed loop around it and an open arc of it, both refined.
  const double R = 0.55, width = 0.3;
  const auto field = make_height_field(
      [&](double x, double y) { return 0.25 * std::max(0.0, 1 - std::abs(std::hypot(x, y) - R) / width); }, 61, 0.2, 17);
  const auto mesh = prepare_mesh(field.mesh);
  auto key = [&](double angle) { return nearest_vertex(field.mesh, R * std::cos(angle), R * std::sin(angle)); };
  FeatureLineRequest loop, arc;
  loop.keys = {key(0.3), key(1.9), key(3.4), key(4.9)};
  loop.closed = true;
  arc.keys = {key(3.6), key(4.4), key(5.4)};
  const std::vector<FeatureLineResult> lines{detect_feature_line(*mesh, loop), detect_feature_line(*mesh, arc)};
  ASSERT_TRUE(lines[0].refined_by_snake);

  nlohmann::json expected = {{"lines", nlohmann::json::array()}, {"segmentations", nlohmann::json::object()},
                             {"files", nlohmann::json::object()}};
  for (const auto& line : lines) expected["lines"].push_back(feature_line_to_json(line));
  auto write = [&](const std::string& stem, ExportFormat format, const std::string& text) {
    const std::string name = stem + export_format_info(format).extension;
    std::ofstream(dir / name, std::ios::binary) << text;
    expected["files"][stem + "." + to_string(format)] = name;
  };
  for (const auto format : {ExportFormat::obj, ExportFormat::ply, ExportFormat::polylines, ExportFormat::csv})
    write("lines", format, export_lines(lines, format));

  for (const auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    const auto result = segment_mesh(*mesh, {lines[0]}, options);
    ASSERT_EQ(result.segments.size(), 2u) << to_string(mode);
    nlohmann::json j = segmentation_to_json(result, mode);
    const SegmentedSurface surface = segmented_surface(*mesh, result);
    nlohmann::json vertices = nlohmann::json::array();
    for (const auto& p : surface.positions) vertices.push_back({p.x(), p.y(), p.z()});
    j["surface"] = {{"vertices", vertices}, {"faces", surface.triangles}};
    expected["segmentations"][to_string(mode)] = j;
    for (const auto format : {ExportFormat::obj, ExportFormat::ply})
      write("segmentation_" + to_string(mode), format, export_segmentation(*mesh, result, format));
  }
  std::ofstream(dir / "expected.json") << expected.dump() << '\n';
  for (const auto& [key_name, name] : expected["files"].items()) EXPECT_GT(fs::file_size(dir / name.get<std::string>()), 0u) << key_name;
  if (!(env && *env)) fs::remove_all(dir);
}

}  // namespace
}  // namespace featureline
