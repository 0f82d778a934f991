#include "api/feature_line_json.h"

#include <cmath>
#include <sstream>

#include "engine/errors.h"

namespace featureline {
namespace {

using nlohmann::json;

json point_json(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

// Reads fields of one JSON object, refusing unknown names and wrong types.
class FieldReader {
 public:
  FieldReader(const json& object, std::string path) : object_(object), path_(std::move(path)) {
    if (!object_.is_object()) throw InvalidInputError("\"" + path_ + "\" must be a JSON object");
  }
  void number(const char* name, double& out, double lo, double hi) {
    if (const json* v = take(name)) {
      if (!v->is_number()) throw InvalidInputError(where(name) + " must be a number");
      const double x = v->get<double>();
      if (!(x >= lo && x <= hi))
        throw InvalidInputError(where(name) + " must be between " + fmt(lo) + " and " + fmt(hi));
      out = x;
    }
  }
  void integer(const char* name, int& out, int lo, int hi) {
    if (const json* v = take(name)) {
      // JSON Schema counts 2.0 as an integer, so do we.
      if (!v->is_number() || !std::isfinite(v->get<double>()) || v->get<double>() != std::floor(v->get<double>()))
        throw InvalidInputError(where(name) + " must be an integer");
      if (std::abs(v->get<double>()) > 1e9) throw InvalidInputError(where(name) + " must be between " + fmt(lo) + " and " + fmt(hi));
      const auto x = static_cast<long long>(v->get<double>());
      if (x < lo || x > hi) throw InvalidInputError(where(name) + " must be between " + fmt(lo) + " and " + fmt(hi));
      out = int(x);
    }
  }
  void boolean(const char* name, bool& out) {
    if (const json* v = take(name)) {
      if (!v->is_boolean()) throw InvalidInputError(where(name) + " must be true or false");
      out = v->get<bool>();
    }
  }
  template <typename Enum, typename Parse>
  void choice(const char* name, Enum& out, Parse parse, const char* allowed) {
    if (const json* v = take(name)) {
      if (!v->is_string()) throw InvalidInputError(where(name) + " must be one of " + allowed);
      const auto parsed = parse(v->get<std::string>());
      if (!parsed) throw InvalidInputError(where(name) + " must be one of " + allowed + ", not \"" + v->get<std::string>() + "\"");
      out = *parsed;
    }
  }
  const json* object(const char* name) {
    const json* v = take(name);
    if (v != nullptr && !v->is_object()) throw InvalidInputError(where(name) + " must be a JSON object");
    return v;
  }
  std::string child(const char* name) const { return path_ + "." + name; }
  void finish() const {
    for (auto it = object_.begin(); it != object_.end(); ++it)
      if (std::find(used_.begin(), used_.end(), it.key()) == used_.end())
        throw InvalidInputError("unknown option \"" + path_ + "." + it.key() + "\"");
  }

 private:
  const json* take(const char* name) {
    auto it = object_.find(name);
    if (it == object_.end()) return nullptr;
    used_.emplace_back(name);
    return &*it;
  }
  std::string where(const char* name) const { return "\"" + path_ + "." + name + "\""; }
  static std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }
  const json& object_;
  std::string path_;
  std::vector<std::string> used_;
};

}  // namespace

void apply_options_json(const json& j, FeatureLineOptions& o) {
  FieldReader r(j, "options");
  r.choice("initial", o.initial.method, parse_initial_method, "marching, feature-path, geodesic");
  if (const json* w = r.object("weights")) {
    FieldReader wr(*w, r.child("weights"));
    wr.number("alpha", o.initial.marching_alpha, 0, 1e3);
    wr.number("beta", o.initial.marching_beta, 0, 1e3);
    wr.number("gamma", o.initial.marching_gamma, 0, 1e3);
    wr.number("delta", o.initial.marching_delta, 0, 1e3);
    wr.finish();
  }
  r.choice("curvature_term", o.initial.marching_curvature_term, parse_marching_curvature_term,
           "similar-to-current, similar-to-end, high-magnitude");
  r.boolean("fallback", o.initial.fallback);
  r.number("feature_weight_floor", o.initial.feature_weight_floor, 1e-4, 1);
  r.boolean("sign_aware", o.initial.sign_aware);
  r.integer("rings", o.strip.rings, 0, 8);
  r.choice("flattening", o.strip.flattening, parse_strip_flattening, "automatic, conformal, similar-triangles");
  r.number("max_edge_distortion", o.strip.max_edge_distortion, 0.01, 100);
  r.boolean("refine", o.refine);
  r.boolean("pin_interior_keys", o.pin_interior_keys);
  r.integer("min_piece_edges", o.min_piece_edges, 2, 1000);
  r.integer("exact_crease_edges", o.exact_crease_edges, 0, 1000);
  r.number("exact_crease_noise", o.exact_crease_noise, 0, 1);
  r.number("keep_initial_below", o.keep_initial_below, 0, 1);
  if (const json* s = r.object("snake")) {
    FieldReader sr(*s, r.child("snake"));
    SnakeOptions& so = o.snake;
    sr.number("alpha", so.alpha, 0, 1e3);
    sr.number("beta", so.beta, 0, 1e3);
    sr.number("tau", so.tau, 1e-4, 1e3);
    sr.number("kappa", so.kappa, 0, 1e3);
    sr.number("exponent", so.exponent, 0.1, 8);
    sr.number("curvature_cap", so.curvature_cap, 0.01, 1e3);
    sr.number("max_step", so.max_step, 1e-3, 10);
    sr.integer("iterations", so.max_iterations, 0, 100000);
    sr.number("tolerance", so.tolerance, 0, 10);
    sr.number("spacing", so.spacing, 0.05, 10);
    sr.integer("resample_every", so.resample_every, 1, 1000);
    sr.choice("force", so.force, parse_snake_force, "paper, smooth");
    sr.boolean("normal_force_only", so.normal_force_only);
    sr.number("sharp_crest_drop", so.sharp_crest_drop, 0, 0.99);
    sr.boolean("normal_step", so.normal_step);
    sr.finish();
  }
  r.finish();
}

json options_to_json(const FeatureLineOptions& o) {
  return {
      {"initial", to_string(o.initial.method)},
      {"weights",
       {{"alpha", o.initial.marching_alpha},
        {"beta", o.initial.marching_beta},
        {"gamma", o.initial.marching_gamma},
        {"delta", o.initial.marching_delta}}},
      {"curvature_term", to_string(o.initial.marching_curvature_term)},
      {"fallback", o.initial.fallback},
      {"feature_weight_floor", o.initial.feature_weight_floor},
      {"sign_aware", o.initial.sign_aware},
      {"rings", o.strip.rings},
      {"flattening", to_string(o.strip.flattening)},
      {"max_edge_distortion", o.strip.max_edge_distortion},
      {"refine", o.refine},
      {"pin_interior_keys", o.pin_interior_keys},
      {"min_piece_edges", o.min_piece_edges},
      {"exact_crease_edges", o.exact_crease_edges},
      {"exact_crease_noise", o.exact_crease_noise},
      {"keep_initial_below", o.keep_initial_below},
      {"snake",
       {{"alpha", o.snake.alpha},
        {"beta", o.snake.beta},
        {"tau", o.snake.tau},
        {"kappa", o.snake.kappa},
        {"exponent", o.snake.exponent},
        {"curvature_cap", o.snake.curvature_cap},
        {"max_step", o.snake.max_step},
        {"iterations", o.snake.max_iterations},
        {"tolerance", o.snake.tolerance},
        {"spacing", o.snake.spacing},
        {"resample_every", o.snake.resample_every},
        {"force", to_string(o.snake.force)},
        {"normal_force_only", o.snake.normal_force_only},
        {"sharp_crest_drop", o.snake.sharp_crest_drop},
        {"normal_step", o.snake.normal_step}}},
  };
}

json feature_line_to_json(const FeatureLineResult& r) {
  json initial_points = json::array();
  for (const auto& p : r.initial_points) initial_points.push_back(point_json(p));
  json refined_points = json::array(), faces = json::array(), barycentric = json::array();
  for (const auto& p : r.refined) {
    refined_points.push_back(point_json(p.position));
    faces.push_back(p.face);
    barycentric.push_back(json::array({p.barycentric[0], p.barycentric[1], p.barycentric[2]}));
  }
  json fallbacks = json::array();
  for (const auto& f : r.initial.fallbacks)
    fallbacks.push_back({{"segment", f.segment}, {"from", to_string(f.from)}, {"to", to_string(f.to)}, {"reason", f.reason}});
  // One object per piece, in line order; "reason" is always present, empty unless the piece
  // kept its initial line (kept == "initial").
  json pieces_detail = json::array();
  std::size_t iteration_caps = 0;
  for (const auto& p : r.piece_reports) {
    pieces_detail.push_back({{"from", p.from},
                             {"to", p.to},
                             {"edges", p.edges},
                             {"kept", p.kept},
                             {"reason", p.reason},
                             {"iterations", p.iterations},
                             {"iteration_cap", p.iteration_cap},
                             {"initial_strength", p.initial_strength},
                             {"refined_strength", p.refined_strength}});
    iteration_caps += p.iteration_cap ? 1 : 0;
  }
  return {
      {"keys", r.keys},
      {"closed", r.closed},
      {"initial",
       {{"method", to_string(r.initial.method)},
        {"vertices", r.initial.vertices},
        {"points", initial_points},
        {"length", r.initial.length}}},
      {"refined",
       {{"points", refined_points}, {"faces", faces}, {"barycentric", barycentric}, {"length", r.refined_length}}},
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
}

json mesh_info_to_json(const PreparedMesh& m, double load_ms) {
  const MeshStatistics& s = m.statistics;
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
        {"smoothing_passes", s.curvature_smoothing_passes},
        {"crease_angle", s.crease_angle},
        {"crease_edges", s.crease_edges}}},
      {"memory_bytes", m.memory_bytes()},
      {"warnings", m.warnings},
      {"timings_ms", {{"load", load_ms}, {"prepare", m.prepare_ms}}},
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
