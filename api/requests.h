// Request bodies of the HTTP API mapped to engine requests: feature lines (one or a batch) and
// segmentation. Every field is checked here, with errors naming it (InvalidInputError, which
// server/http_errors answers as 400 invalid_request); the server only routes and transports.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/feature_line.h"
#include "engine/feature_seeds.h"
#include "engine/prepared_mesh.h"
#include "engine/segmentation.h"

namespace featureline {

/// One line: {"keys": [vertex id | {"point": [x, y, z]}, ...], "closed", "options"}. A point key
/// becomes the nearest vertex. `where` names the line in errors ("request", "lines[2]").
FeatureLineRequest parse_line_request(const nlohmann::json& line, const PreparedMesh& mesh, const std::string& where);

/// "lines": an array of 1 to RequestLimits::max_lines line requests.
std::vector<FeatureLineRequest> parse_line_list(const nlohmann::json& lines, const PreparedMesh& mesh);

/// The body of POST /feature-lines: one line, or {"lines": [...]} alone (`batch` set).
std::vector<FeatureLineRequest> parse_feature_line_body(const nlohmann::json& body, const PreparedMesh& mesh, bool& batch);

/// The segmentation options of a segmentation request: every top-level field except
/// `line_fields` (the fields that say which lines to cut along), by segmentation_option_table().
SegmentationOptions parse_segmentation_options(const nlohmann::json& body,
                                               const std::vector<std::string>& line_fields = {"lines"});

/// A segmentation request body, parsed: its options, and its "lines" (1 to
/// RequestLimits::max_lines items) in order, each a line computed before (an answer's
/// "refined", kept as it is: parse_computed_line) or a line request to detect.
struct SegmentationRequest {
  SegmentationOptions options;
  std::vector<FeatureLineResult> lines;      ///< one per item; the requested ones empty until filled
  std::vector<FeatureLineRequest> requests;  ///< the items to detect, in order
  std::vector<std::size_t> requested_at;     ///< each request's place in `lines`

  /// The lines with `detected` (one result per request, in order) in their places.
  std::vector<FeatureLineResult> lines_with(std::vector<FeatureLineResult> detected) &&;
};

/// POST /v1/meshes/{id}/segmentation's body. \throw InvalidInputError naming the field
SegmentationRequest parse_segmentation_request(const nlohmann::json& body, const PreparedMesh& mesh);

/// The options of GET /v1/meshes/{id}/features from its query parameters (each named as a row of
/// feature_seed_option_table(), its value a number). \throw InvalidInputError naming the parameter
FeatureSeedOptions parse_feature_seed_query(const std::vector<std::pair<std::string, std::string>>& parameters);

/// GET /v1/options: every option table as describe_options() rows, with the request limits.
nlohmann::json describe_api_options();

}  // namespace featureline
