// JSON mapping of the engine's options and results. One place decides the field names, so
// the CLI and the server answer exactly the same documents (see api/openapi.yaml).
#pragma once

#include <nlohmann/json.hpp>

#include "engine/feature_line.h"
#include "engine/prepared_mesh.h"

namespace featureline {

/// Applies an "options" object onto `options`. Unknown fields and wrong types are an
/// InvalidInputError naming the field, so typos never pass silently.
void apply_options_json(const nlohmann::json& json, FeatureLineOptions& options);

/// The options as JSON (every field, defaults included).
nlohmann::json options_to_json(const FeatureLineOptions& options);

/// The feature-line answer: keys, closed, initial, refined, stats, and `fitted` when the line has
/// a fitted curve (field names are the contract).
/// stats.pieces_detail has one object per FeatureLineResult::piece_reports entry, in line order;
/// its "reason" is always present and empty unless the piece kept its initial line.
/// stats.iteration_caps counts the pieces whose snake stopped at its iteration cap.
nlohmann::json feature_line_to_json(const FeatureLineResult& result);

/// The same answer as JSON text, written without a DOM (what the server sends).
std::string feature_line_json_text(const FeatureLineResult& result);

/// The prepared mesh's description, as `featureline info` prints it. Its "curvature" object
/// describes the feature value (the larger |principal curvature|) and the curvature stage:
/// method, noise, radius, crease_angle, crease_edges (MeshStatistics).
nlohmann::json mesh_info_to_json(const PreparedMesh& mesh, double load_ms);

/// Parses a key list "10,20,30" (CLI form).
std::vector<std::uint32_t> parse_key_list(const std::string& text);

}  // namespace featureline
