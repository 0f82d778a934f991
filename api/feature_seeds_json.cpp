#include "api/feature_seeds_json.h"

namespace featureline {
namespace {

using nlohmann::json;

json point_json(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

json vertex_seeds_json(const PreparedMesh& mesh, const std::vector<FeatureVertexSeed>& seeds) {
  json out = json::array();
  for (const auto& s : seeds)
    out.push_back({{"vertex", s.vertex},
                   {"point", point_json(mesh.positions()[s.vertex])},
                   {"curvature", s.curvature},
                   {"strength", s.strength},
                   {"direction", s.direction ? point_json(*s.direction) : json(nullptr)}});
  return out;
}

}  // namespace

json feature_seeds_to_json(const PreparedMesh& mesh, const FeatureSeeds& seeds) {
  json chains = json::array();
  for (const auto& c : seeds.crease_chains) {
    json points = json::array();
    for (auto v : c.vertices) points.push_back(point_json(mesh.positions()[v]));
    chains.push_back({{"sign", to_string(c.sign)},
                      {"closed", c.closed},
                      {"edges", c.edges()},
                      {"length", c.length},
                      {"dihedral_deg", c.dihedral_degrees},
                      {"vertices", c.vertices},
                      {"points", points}});
  }
  const FeatureSeedStatistics& s = seeds.stats;
  return {{"crease_chains", chains},
          {"ridge_vertices", vertex_seeds_json(mesh, seeds.ridge_vertices)},
          {"valley_vertices", vertex_seeds_json(mesh, seeds.valley_vertices)},
          {"stats",
           {{"crease_chains", s.crease_chains},
            {"short_chains", s.short_chains},
            {"junctions", s.junctions},
            {"corners", s.corners},
            {"ridge_candidates", s.ridge_candidates},
            {"valley_candidates", s.valley_candidates},
            {"noise_floor_strength", s.noise_floor_strength},
            {"timings_ms", {{"features", s.elapsed_ms}}}}}};
}

}  // namespace featureline
