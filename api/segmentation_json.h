// JSON and glTF mapping of mesh decomposition (the paper's application).
#pragma once

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

#include "api/options_table.h"
#include "engine/prepared_mesh.h"
#include "engine/segmentation.h"

namespace featureline {

/// {"mode", "labels": [label per face], "segments": [{"label", "faces", "area", "boundary_length",
///  "bbox": {"min", "max"}}], "warnings": [..], "total_area", "cut_edges", "timings_ms": {"segment"},
///  and in remesh mode "remeshed": {"vertices", "faces", "source_faces"} (labels then refer to
///  the remeshed faces; original vertex ids are unchanged, new vertices follow them)}
nlohmann::json segmentation_to_json(const SegmentationResult& result, SegmentationMode mode);

/// A GLB with one primitive per segment (the remeshed surface in remesh mode).
std::string segmentation_to_glb(const PreparedMesh& mesh, const SegmentationResult& result);

}  // namespace featureline
