#include "api/segmentation_json.h"

#include "api/export_formats.h"
#include "api/gltf_export.h"
#include "engine/errors.h"
#include "engine/surface_point.h"

namespace featureline {

using nlohmann::json;

json segmentation_to_json(const SegmentationResult& r, SegmentationMode mode) {
  json segments = json::array();
  for (const auto& s : r.segments)
    segments.push_back({{"label", s.label},
                        {"faces", s.faces},
                        {"area", s.area},
                        {"boundary_length", s.boundary_length},
                        {"color", segment_colour(s.label)},
                        {"bbox", {{"min", s.bbox_min}, {"max", s.bbox_max}}}});
  json out = {{"mode", to_string(mode)},
              {"labels", r.labels},
              {"segments", segments},
              {"warnings", r.warnings},
              {"total_area", r.total_area},
              {"cut_edges", r.cut_edges},
              {"timings_ms", {{"segment", r.elapsed_ms}}}};
  if (r.remeshed) {
    json vertices = json::array();
    for (const auto& p : r.positions) vertices.push_back({p.x(), p.y(), p.z()});
    out["remeshed"] = {{"vertices", vertices}, {"faces", r.triangles}, {"source_faces", r.source_faces}};
  }
  return out;
}

bool is_computed_line(const json& item) { return item.is_object() && item.contains("refined"); }

namespace {

/// The [w0, w1, w2] of a computed line's point, checked for shape (values are checked with the face).
Barycentric barycentric_json(const json& w, const std::string& where) {
  if (!w.is_array() || w.size() != 3 || !w[0].is_number() || !w[1].is_number() || !w[2].is_number())
    throw InvalidInputError(where + ": barycentric coordinates must be an array of three numbers");
  return {w[0].get<double>(), w[1].get<double>(), w[2].get<double>()};
}

}  // namespace

FeatureLineResult parse_computed_line(const json& item, const PreparedMesh& mesh, const std::string& where) {
  for (auto it = item.begin(); it != item.end(); ++it)
    if (it.key() != "refined" && it.key() != "closed" && it.key() != "keys")
      throw InvalidInputError("unknown field \"" + where + "." + it.key() +
                              "\" in a computed line (it has \"refined\", \"closed\" and \"keys\")");
  // The answer's keys may come along (the line is the refined one; its keys say where it came from).
  if (const auto keys = item.find("keys"); keys != item.end() && !keys->is_array())
    throw InvalidInputError(where + ".keys must be an array (the keys the line was detected from)");
  FeatureLineResult line;
  if (const auto closed = item.find("closed"); closed != item.end()) {
    if (!closed->is_boolean()) throw InvalidInputError(where + ".closed must be true or false");
    line.closed = closed->get<bool>();
  }
  const json& refined = item["refined"];
  const std::string at = where + ".refined";
  if (!refined.is_object()) throw InvalidInputError(at + " must be an object with \"faces\" and \"barycentric\"");
  for (auto it = refined.begin(); it != refined.end(); ++it)
    if (it.key() != "faces" && it.key() != "barycentric" && it.key() != "points" && it.key() != "length" &&
        it.key() != "key_points" && it.key() != "key_moves")
      throw InvalidInputError("unknown field \"" + at + "." + it.key() + "\"");
  const auto faces = refined.find("faces"), barycentric = refined.find("barycentric");
  if (faces == refined.end() || !faces->is_array()) throw InvalidInputError(at + ".faces must be an array of face ids");
  if (barycentric == refined.end() || !barycentric->is_array())
    throw InvalidInputError(at + ".barycentric must be an array of [w0, w1, w2] triples");
  if (faces->size() != barycentric->size())
    throw InvalidInputError(at + " has " + std::to_string(faces->size()) + " faces but " +
                            std::to_string(barycentric->size()) + " barycentric triples");
  if (faces->size() < 2) throw InvalidInputError(at + " needs at least two points");
  for (std::size_t i = 0; i < faces->size(); ++i) {
    const std::string point = at + ", point " + std::to_string(i);
    const json& f = (*faces)[i];
    if (!f.is_number_integer() || (!f.is_number_unsigned() && f.get<std::int64_t>() < 0))
      throw InvalidInputError(point + ": the face must be an integer >= 0");
    const auto face = f.get<std::uint64_t>();
    if (face >= mesh.triangles().size())  // checked here too: face ids beyond uint32 must not wrap
      throw InvalidInputError(point + ": face " + std::to_string(face) + " is out of range (the mesh has " +
                              std::to_string(mesh.triangles().size()) + " faces)");
    SurfacePoint s;
    s.face = std::uint32_t(face);
    s.barycentric = barycentric_json((*barycentric)[i], point);
    check_surface_point(mesh, s.face, s.barycentric, point);
    s.position = mesh.point_at(s.face, s.barycentric);
    line.refined.push_back(s);
  }
  return line;
}

std::string segmentation_to_glb(const PreparedMesh& mesh, const SegmentationResult& r) {
  const SegmentedSurface surface = segmented_surface(mesh, r);
  return labelled_mesh_to_glb(surface.positions, surface.triangles, r.labels, int(r.segments.size()));
}

}  // namespace featureline
