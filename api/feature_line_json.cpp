#include "api/feature_line_json.h"

#include "api/options_table.h"

#include "engine/errors.h"

namespace featureline {
namespace {

using nlohmann::json;

json point_json(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

json trace_json(const TraceResult& t) {
  json ends = json::array(), junctions = json::array();
  for (const auto& end : t.ends) ends.push_back({{"vertex", end.vertex}, {"reason", to_string(end.reason)}});
  for (const auto& j : t.junctions) junctions.push_back({{"vertex", j.vertex}, {"branches", j.branches}, {"followed", j.followed}});
  return {{"key", t.clicked},           {"seed", t.seed},   {"sign", to_string(t.sign)},
          {"on_crease", t.on_crease},   {"ends", ends},     {"junctions", junctions},
          {"seed_strength", t.seed_strength}, {"steps", t.steps}, {"ms", t.elapsed_ms}};
}

json fitted_json(const FittedCurveResult& f) {
  json points = json::array();
  for (const auto& p : f.points) points.push_back(point_json(p));
  return {{"points", points},
          {"closed", f.closed},
          {"length", f.length},
          {"control_points", f.control_points},
          {"control_spacing", f.control_spacing},
          {"control_points_per_unit_length", f.control_spacing > 0 ? 1 / f.control_spacing : 0.0},
          {"corners", f.corners},
          {"crease_share", f.crease_share},
          {"surface_share", f.surface_share},
          {"exact_share", f.exact_share},
          {"fallback_share", f.fallback_share},
          {"ms", f.elapsed_ms}};
}

}  // namespace

void apply_options_json(const json& j, FeatureLineOptions& o) { apply_options(feature_line_option_table(), j, "options", o); }

json options_to_json(const FeatureLineOptions& o) { return options_json(feature_line_option_table(), o); }

json feature_line_to_json(const FeatureLineResult& r) {
  json initial_points = json::array();
  for (const auto& p : r.initial_points) initial_points.push_back(point_json(p));
  json refined_points = json::array(), faces = json::array(), barycentric = json::array();
  for (const auto& p : r.refined) {
    refined_points.push_back(point_json(p.position));
    faces.push_back(p.face);
    barycentric.push_back(json::array({p.barycentric[0], p.barycentric[1], p.barycentric[2]}));
  }
  json key_points = json::array();
  for (const auto& p : r.key_points) key_points.push_back(point_json(p));
  json fallbacks = json::array();
  for (const auto& f : r.initial.fallbacks)
    fallbacks.push_back({{"segment", f.segment}, {"from", to_string(f.from)}, {"to", to_string(f.to)}, {"reason", f.reason}});
  // One object per piece, in line order; "reason" is always present, empty unless the piece
  // kept its initial line (kept: initial).
  json pieces_detail = json::array();
  std::size_t iteration_caps = 0;
  for (const auto& p : r.piece_reports) {
    pieces_detail.push_back({{"from", p.from},
                             {"to", p.to},
                             {"edges", p.edges},
                             {"kept", to_string(p.kept)},
                             {"reason", p.reason},
                             {"iterations", p.iterations},
                             {"iteration_cap", p.iteration_cap},
                             {"second_strip", p.second_strip},
                             {"featureless", p.featureless},
                             {"initial_strength", p.initial_strength},
                             {"refined_strength", p.refined_strength}});
    iteration_caps += p.iteration_cap ? 1 : 0;
  }
  json answer = {
      {"keys", r.keys},
      {"closed", r.closed},
      {"initial",
       {{"method", r.trace ? "trace" : to_string(r.initial.method)},
        {"vertices", r.initial.vertices},
        {"points", initial_points},
        {"length", r.initial.length}}},
      {"refined",
       {{"points", refined_points},
        {"faces", faces},
        {"barycentric", barycentric},
        {"length", r.refined_length},
        {"key_points", key_points},
        {"key_moves", r.key_moves}}},
      {"stats",
       {{"iterations", r.iterations},
        {"strip_faces", r.strip_faces},
        {"pieces", r.pieces},
        {"splits", r.splits},
        {"iteration_caps", iteration_caps},
        {"pieces_detail", pieces_detail},
        {"refined", r.refined_by_snake},
        {"fallbacks", fallbacks},
        {"warnings", r.warnings},
        {"timings_ms",
         {{"initial", r.timings.initial_ms},
          {"strip", r.timings.strip_ms},
          {"flatten", r.timings.flatten_ms},
          {"snake", r.timings.snake_ms},
          {"total", r.timings.total_ms}}}}},
  };
  if (r.trace) answer["trace"] = trace_json(*r.trace);
  if (r.fitted) answer["fitted"] = fitted_json(*r.fitted);
  return answer;
}

json mesh_info_to_json(const PreparedMesh& m, double load_ms) {
  const MeshStatistics& s = m.statistics();
  return {
      {"vertices", s.vertices},
      {"faces", s.faces},
      {"file_vertices", s.file_vertices},
      {"file_faces", s.file_faces},
      {"components", s.components},
      {"boundary_loops", s.boundary_loops},
      {"boundary_edges", s.boundary_edges},
      {"non_manifold_vertices", s.non_manifold_vertices},
      {"non_manifold_edges", s.non_manifold_edges},
      {"unreferenced_vertices", s.unreferenced_vertices},
      {"dropped_faces", s.dropped_faces},
      {"duplicated_vertices", s.duplicated_vertices},
      {"repeated_faces", s.repeated_faces},
      {"closed_components", s.closed_components},
      {"inward_components", s.inward_components},
      {"flipped_faces", s.flipped_faces},
      {"bbox", {{"min", s.bbox_min}, {"max", s.bbox_max}}},
      {"mean_edge", s.mean_edge_length},
      {"curvature",
       {{"min", s.curvature_min},
        {"max", s.curvature_max},
        {"percentiles",  // of the feature value (the larger |principal curvature|)
         {{"p50", s.abs_curvature_p50}, {"p90", s.abs_curvature_p90}, {"p99", s.abs_curvature_p99}}},
        {"method", s.curvature_method},
        {"noise", s.noise},
        {"radius", s.curvature_radius},
        {"jet_degree", s.jet_degree.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.jet_degree)},
        {"smoothing_passes", s.curvature_smoothing_passes},
        {"crease_angle", s.crease_angle},
        {"crease_edges", s.crease_edges}}},
      {"memory_bytes", m.memory_bytes()},
      {"warnings", m.warnings()},
      {"timings_ms", {{"load", load_ms}, {"prepare", m.prepare_ms()}}},
  };
}

std::vector<std::uint32_t> parse_key_list(const std::string& text) {
  std::vector<std::uint32_t> keys;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    if (item.empty() || item.find_first_not_of("0123456789") != std::string::npos || item.size() > 10)
      throw InvalidInputError("keys must be comma-separated vertex ids, got \"" + text + "\"");
    const unsigned long long value = std::stoull(item);
    if (value > 0xFFFFFFFFull) throw InvalidInputError("vertex id " + item + " is too large");
    keys.push_back(std::uint32_t(value));
    pos = comma + 1;
  }
  return keys;
}

}  // namespace featureline
