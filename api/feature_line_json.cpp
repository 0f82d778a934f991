#include "api/feature_line_json.h"

#include "api/json_writer.h"
#include "api/options_table.h"

#include "engine/errors.h"

namespace featureline {
namespace {

using nlohmann::json;

void write_trace(JsonWriter& w, const TraceResult& t) {
  w.begin_object().member("key", t.clicked).member("seed", t.seed).member("sign", to_string(t.sign));
  w.member("on_crease", t.on_crease).key("ends").begin_array();
  for (const auto& end : t.ends)
    w.begin_object().member("vertex", end.vertex).member("reason", to_string(end.reason)).end_object();
  w.end_array().key("junctions").begin_array();
  for (const auto& j : t.junctions)
    w.begin_object().member("vertex", j.vertex).member("branches", j.branches).member("followed", j.followed).end_object();
  w.end_array().member("seed_strength", t.seed_strength).member("steps", t.steps).member("ms", t.elapsed_ms).end_object();
}

void write_fitted(JsonWriter& w, const FittedCurveResult& f) {
  w.begin_object()
      .member("points", f.points)
      .member("closed", f.closed)
      .member("length", f.length)
      .member("control_points", f.control_points)
      .member("control_spacing", f.control_spacing)
      .member("control_points_per_unit_length", f.control_spacing > 0 ? 1 / f.control_spacing : 0.0)
      .member("corners", f.corners)
      .member("crease_share", f.crease_share)
      .member("surface_share", f.surface_share)
      .member("exact_share", f.exact_share)
      .member("fallback_share", f.fallback_share)
      .member("averaged_share", f.averaged_share)
      .member("ms", f.elapsed_ms)
      .end_object();
}

void write_initial(JsonWriter& w, const FeatureLineResult& r) {
  w.begin_object()
      .member("method", r.trace ? "trace" : to_string(r.initial.method))
      .member("vertices", r.initial.vertices)
      .member("points", r.initial_points)
      .member("length", r.initial.length)
      .end_object();
}

void write_refined(JsonWriter& w, const FeatureLineResult& r) {
  w.begin_object().key("points").begin_array();
  for (const auto& p : r.refined) w.value(p.position);
  w.end_array().key("faces").begin_array();
  for (const auto& p : r.refined) w.value(p.face);
  w.end_array().key("barycentric").begin_array();
  for (const auto& p : r.refined)
    w.begin_array().value(p.barycentric[0]).value(p.barycentric[1]).value(p.barycentric[2]).end_array();
  w.end_array()
      .member("length", r.refined_length)
      .member("key_points", r.key_points)
      .member("key_moves", r.key_moves)
      .end_object();
}

// One object per piece, in line order; "reason" is always present, empty unless the piece kept
// its initial line (kept: initial).
void write_piece(JsonWriter& w, const PieceReport& p) {
  w.begin_object()
      .member("from", p.from)
      .member("to", p.to)
      .member("edges", p.edges)
      .member("kept", to_string(p.kept))
      .member("reason", p.reason)
      .member("iterations", p.iterations)
      .member("iteration_cap", p.iteration_cap)
      .member("second_strip", p.second_strip)
      .member("featureless", p.featureless)
      .member("initial_strength", p.initial_strength)
      .member("refined_strength", p.refined_strength)
      .end_object();
}

void write_stats(JsonWriter& w, const FeatureLineResult& r) {
  std::size_t iteration_caps = 0;
  for (const auto& p : r.piece_reports) iteration_caps += p.iteration_cap ? 1 : 0;
  w.begin_object()
      .member("iterations", r.iterations)
      .member("strip_faces", r.strip_faces)
      .member("pieces", r.pieces)
      .member("splits", r.splits)
      .member("iteration_caps", iteration_caps)
      .key("pieces_detail")
      .begin_array();
  for (const auto& p : r.piece_reports) write_piece(w, p);
  w.end_array().member("refined", r.refined_by_snake).key("fallbacks").begin_array();
  for (const auto& f : r.initial.fallbacks)
    w.begin_object()
        .member("segment", f.segment)
        .member("from", to_string(f.from))
        .member("to", to_string(f.to))
        .member("reason", f.reason)
        .end_object();
  w.end_array()
      .member("warnings", r.warnings)
      .key("timings_ms")
      .begin_object()
      .member("initial", r.timings.initial_ms)
      .member("strip", r.timings.strip_ms)
      .member("flatten", r.timings.flatten_ms)
      .member("snake", r.timings.snake_ms)
      .member("total", r.timings.total_ms)
      .end_object()
      .end_object();
}

}  // namespace

void apply_options_json(const json& j, FeatureLineOptions& o) { apply_options(feature_line_option_table(), j, "options", o); }

json options_to_json(const FeatureLineOptions& o) { return options_json(feature_line_option_table(), o); }

void write_feature_line(JsonWriter& w, const FeatureLineResult& r) {
  w.begin_object().member("keys", r.keys).member("closed", r.closed).key("initial");
  write_initial(w, r);
  w.key("refined");
  write_refined(w, r);
  w.key("stats");
  write_stats(w, r);
  if (r.trace) write_trace(w.key("trace"), *r.trace);
  if (r.fitted) write_fitted(w.key("fitted"), *r.fitted);
  w.end_object();
}

std::string feature_line_json_text(const FeatureLineResult& r) {
  JsonWriter w;
  write_feature_line(w, r);
  return w.take();
}

json feature_line_to_json(const FeatureLineResult& r) { return json::parse(feature_line_json_text(r)); }

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
        {"noise_length", s.noise_length},
        {"noise_samples", s.noise_samples},
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
