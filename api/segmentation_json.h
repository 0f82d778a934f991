// JSON and glTF mapping of mesh decomposition (the paper's application).
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "api/options_table.h"
#include "engine/prepared_mesh.h"
#include "engine/segmentation.h"

namespace featureline {

/// {"mode", "labels": [label per face], "segments": [{"label", "faces", "area", "boundary_length",
///  "bbox": {"min", "max"}}], "warnings": [..], "total_area", "cut_edges", "timings_ms": {"segment"},
///  and in remesh mode "remeshed": {"vertices", "faces", "source_faces"} (labels then refer to
///  the remeshed faces; original vertex ids are unchanged, new vertices follow them)}
nlohmann::json segmentation_to_json(const SegmentationResult& result, SegmentationMode mode);

/// Is this item of a segmentation request's "lines" a line computed before ({"refined": ...})
/// rather than a line request ({"keys": ...})?
bool is_computed_line(const nlohmann::json& item);

/// A line computed before, as a feature-line answer carries it:
///   {"refined": {"faces": [f, ...], "barycentric": [[w0, w1, w2], ...]}, "closed": false, "keys": [...]}
/// The answer's "refined" may be sent whole: its "points" and "length" are accepted and ignored
/// (positions are recomputed from the faces, as the engine computed them); "keys" (optional, an
/// array) says where the line came from and is not used. `where` names the
/// item in errors ("lines[2]").
/// \throw InvalidInputError naming the field: at least two points, as many barycentric triples
///        as faces, face ids in range, barycentric coordinates finite, non-negative, summing to 1
///        (e.g. "lines[2].refined, point 3: face 99999 is out of range (the mesh has 3200 faces)").
FeatureLineResult parse_computed_line(const nlohmann::json& item, const PreparedMesh& mesh, const std::string& where);

/// A GLB with one primitive per segment (the remeshed surface in remesh mode).
std::string segmentation_to_glb(const PreparedMesh& mesh, const SegmentationResult& result);

}  // namespace featureline
