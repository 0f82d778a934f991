#include "api/requests.h"

#include <algorithm>
#include <cmath>

#include "api/feature_line_json.h"
#include "api/options_table.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"

namespace featureline {

using nlohmann::json;

namespace {

bool is_point_key(const json& k) {
  if (!k.is_object() || k.size() != 1 || !k.contains("point")) return false;
  const json& p = k["point"];
  return p.is_array() && p.size() == 3 && p[0].is_number() && p[1].is_number() && p[2].is_number();
}

std::uint32_t parse_key(const json& k, const PreparedMesh& mesh, const std::string& at) {
  if (k.is_number_unsigned()) {
    const auto id = k.get<std::uint64_t>();
    if (id >= mesh.n_vertices())
      throw InvalidInputError(at + " is vertex " + std::to_string(id) + ", but the mesh has only " +
                              std::to_string(mesh.n_vertices()) + " vertices");
    return std::uint32_t(id);
  }
  if (!is_point_key(k)) throw InvalidInputError(at + " must be a vertex id (integer >= 0) or {\"point\": [x, y, z]}");
  const json& p = k["point"];
  const Eigen::Vector3d point(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  if (!point.allFinite()) throw InvalidInputError(at + ".point must be finite");
  const std::uint32_t v = mesh.nearest_vertex(point);  // the prepared mesh's k-d tree (engine/vertex_index.h)
  // A point further from the mesh than the mesh's own size was not picked on it (and one far
  // enough out reads every vertex as equally near: its squared distances overflow).
  const auto& s = mesh.statistics();
  const double size = (Eigen::Vector3d(s.bbox_max[0], s.bbox_max[1], s.bbox_max[2]) -
                       Eigen::Vector3d(s.bbox_min[0], s.bbox_min[1], s.bbox_min[2])).norm();
  if (!((mesh.positions()[v] - point).norm() <= size))
    throw InvalidInputError(at + ".point lies further from the mesh than the mesh's size (" + format_number(size) +
                            ", its bounding box's diagonal): a point key is replaced by the vertex nearest to it");
  return v;
}

}  // namespace

FeatureLineRequest parse_line_request(const json& j, const PreparedMesh& mesh, const std::string& where) {
  if (!j.is_object()) throw InvalidInputError(where + " must be a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "keys" && it.key() != "closed" && it.key() != "trace" && it.key() != "options")
      throw InvalidInputError("unknown field \"" + where + "." + it.key() + "\"");
  FeatureLineRequest line;
  const auto keys = j.find("keys");
  if (keys == j.end() || !keys->is_array()) throw InvalidInputError(where + ".keys must be an array of vertex ids or points");
  if (keys->size() > RequestLimits::max_keys_per_line)
    throw InvalidInputError(where + ".keys has more than " + std::to_string(RequestLimits::max_keys_per_line) + " keys");
  for (std::size_t i = 0; i < keys->size(); ++i)
    line.keys.push_back(parse_key((*keys)[i], mesh, where + ".keys[" + std::to_string(i) + "]"));
  if (const auto closed = j.find("closed"); closed != j.end()) {
    if (!closed->is_boolean()) throw InvalidInputError(where + ".closed must be true or false");
    line.closed = closed->get<bool>();
  }
  if (const auto trace = j.find("trace"); trace != j.end()) {
    if (!trace->is_boolean()) throw InvalidInputError(where + ".trace must be true or false");
    line.trace = trace->get<bool>();
  }
  if (const auto options = j.find("options"); options != j.end()) apply_options_json(*options, line.options);
  return line;
}

std::vector<FeatureLineRequest> parse_line_list(const json& list, const PreparedMesh& mesh) {
  if (!list.is_array() || list.empty() || list.size() > RequestLimits::max_lines)
    throw InvalidInputError("\"lines\" must be an array of 1 to " + std::to_string(RequestLimits::max_lines) + " line requests");
  std::vector<FeatureLineRequest> lines;
  for (std::size_t i = 0; i < list.size(); ++i) lines.push_back(parse_line_request(list[i], mesh, "lines[" + std::to_string(i) + "]"));
  return lines;
}

std::vector<FeatureLineRequest> parse_feature_line_body(const json& body, const PreparedMesh& mesh, bool& batch) {
  batch = body.is_object() && body.contains("lines");
  if (!batch) return {parse_line_request(body, mesh, "request")};
  if (body.size() != 1) throw InvalidInputError("with \"lines\", no other top-level field is allowed");
  return parse_line_list(body["lines"], mesh);
}

SegmentationOptions parse_segmentation_options(const json& body, const std::vector<std::string>& line_fields) {
  if (!body.is_object()) throw InvalidInputError("the request body must be a JSON object");
  json options = body;
  for (const auto& field : line_fields) options.erase(field);
  SegmentationOptions parsed;
  apply_options(segmentation_option_table(), options, "", parsed);
  return parsed;
}

SegmentationRequest parse_segmentation_request(const json& body, const PreparedMesh& mesh) {
  SegmentationRequest request;
  request.options = parse_segmentation_options(body);
  if (!body.contains("lines")) throw InvalidInputError("\"lines\" is required");
  const json& list = body["lines"];
  if (!list.is_array() || list.empty() || list.size() > RequestLimits::max_lines)
    throw InvalidInputError("\"lines\" must be an array of 1 to " + std::to_string(RequestLimits::max_lines) +
                            " line requests or computed lines");
  request.lines.resize(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = "lines[" + std::to_string(i) + "]";
    if (is_computed_line(list[i])) {
      request.lines[i] = parse_computed_line(list[i], mesh, where);
    } else {
      request.requests.push_back(parse_line_request(list[i], mesh, where));
      request.requested_at.push_back(i);
    }
  }
  return request;
}

std::vector<FeatureLineResult> SegmentationRequest::lines_with(std::vector<FeatureLineResult> detected) && {
  for (std::size_t j = 0; j < detected.size() && j < requested_at.size(); ++j) lines[requested_at[j]] = std::move(detected[j]);
  return std::move(lines);
}

FeatureSeedOptions parse_feature_seed_query(const std::vector<std::pair<std::string, std::string>>& parameters) {
  json object = json::object();
  for (const auto& [name, text] : parameters) {
    if (name.size() > 64) throw InvalidInputError("unknown query parameter (" + std::to_string(name.size()) + " characters)");
    double value = 0;
    std::size_t used = 0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size()) throw InvalidInputError("query parameter \"" + name + "\" must be a number");
    object[name] = value;
  }
  FeatureSeedOptions options;
  apply_options(feature_seed_option_table(), object, "", options);
  return options;
}

json describe_api_options() {
  return {{"feature_line", describe_options(option_specs(feature_line_option_table()))},
          {"segmentation", describe_options(option_specs(segmentation_option_table()))},
          {"curvature", describe_options(option_specs(curvature_option_table()))},
          {"features", describe_options(option_specs(feature_seed_option_table()))},
          {"limits",
           {{"max_lines", RequestLimits::max_lines},
            {"max_keys_per_line", RequestLimits::max_keys_per_line},
            {"max_json_bytes", RequestLimits::max_json_bytes}}}};
}

}  // namespace featureline
