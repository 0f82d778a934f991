#include "api/segmentation_json.h"

#include "api/gltf_export.h"

namespace featureline {

using nlohmann::json;

json segmentation_to_json(const SegmentationResult& r, SegmentationMode mode) {
  json segments = json::array();
  for (const auto& s : r.segments)
    segments.push_back({{"label", s.label},
                        {"faces", s.faces},
                        {"area", s.area},
                        {"boundary_length", s.boundary_length},
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

std::string segmentation_to_glb(const PreparedMesh& mesh, const SegmentationResult& r) {
  const int count = int(r.segments.size());
  if (r.remeshed) return labelled_mesh_to_glb(r.positions, r.triangles, r.labels, count);
  return labelled_mesh_to_glb(mesh.positions, mesh.triangles, r.labels, count);
}

}  // namespace featureline
