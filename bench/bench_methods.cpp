// Compares the initial-line methods (and the marching search's three curvature terms) and
// the snake's two force models on fields with an analytic crest: how often each initial
// method needs a fallback, how far each line is from the true crest, how smooth it is.
//
// usage: bench_methods [--seeds N]
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/feature_line.h"
#include "tests/support/line_metrics.h"
#include "tests/support/synthetic_meshes.h"

namespace {

using namespace featureline;
using namespace featureline::testing;

struct Variant {
  std::string name;
  InitialMethod method;
  MarchingCurvatureTerm term;
  SnakeForce force;
};

struct Tally {
  double segments = 0, fallbacks = 0, initial_distance = 0, refined_distance = 0, initial_turning = 0,
         refined_turning = 0, ms = 0, runs = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int seeds = 8;
  for (int i = 1; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--seeds") seeds = std::max(1, std::atoi(argv[i + 1]));
  const std::vector<Variant> variants = {
      {"geodesic + smooth", InitialMethod::geodesic, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"feature-path + smooth", InitialMethod::feature_path, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"feature-path + paper force", InitialMethod::feature_path, MarchingCurvatureTerm::similar_to_end, SnakeForce::paper},
      {"marching(current) + smooth", InitialMethod::marching, MarchingCurvatureTerm::similar_to_current, SnakeForce::smooth},
      {"marching(end) + smooth", InitialMethod::marching, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"marching(high) + smooth", InitialMethod::marching, MarchingCurvatureTerm::high_magnitude, SnakeForce::smooth},
  };
  const char* fields[] = {"ridge", "valley", "crease"};
  std::printf("%d seeds x {ridge, valley, crease} fields, 61x61 jittered Delaunay grids, 3 keys on the crest.\n", seeds);
  std::printf("Distances are mean xy distances to the analytic crest in grid spacings; turning is the total\n"
              "turning angle of the line in radians; fallback%% is the share of segments where marching failed.\n\n");
  std::printf("%-28s %-7s %9s %9s %9s %9s %9s %8s\n", "variant", "field", "fallbk%", "init_d", "refined_d", "init_turn",
              "ref_turn", "ms");
  for (const auto& variant : variants) {
    for (int f = 0; f < 3; ++f) {
      Tally t;
      for (int seed = 1; seed <= seeds; ++seed) {
        const HeightField field = f == 2 ? make_crease_field(61, 0.2, std::uint64_t(seed), 0.25, 0.3)
                                         : make_ridge_field(61, 0.2, std::uint64_t(seed), f == 0 ? 0.3 : -0.3, 0.25, 0.3);
        const auto mesh = prepare_mesh(field.mesh);
        FeatureLineRequest request;
        for (double x : {-0.8, 0.0, 0.8}) request.keys.push_back(nearest_vertex(field.mesh, x, field.crest(x)));
        request.options.initial.method = variant.method;
        request.options.initial.marching_curvature_term = variant.term;
        request.options.snake.force = variant.force;
        const auto r = detect_feature_line(*mesh, request);
        t.segments += double(request.keys.size() - 1);
        t.fallbacks += double(r.initial.fallbacks.size());
        t.initial_distance += crest_distance(field, r.initial_points).mean / field.spacing;
        t.refined_distance += crest_distance(field, refined_positions(r)).mean / field.spacing;
        t.initial_turning += total_turning(r.initial_points);
        t.refined_turning += total_turning(refined_positions(r));
        t.ms += r.timings.total_ms;
        t.runs += 1;
      }
      std::printf("%-28s %-7s %9.1f %9.3f %9.3f %9.2f %9.2f %8.2f\n", variant.name.c_str(), fields[f],
                  100 * t.fallbacks / t.segments, t.initial_distance / t.runs, t.refined_distance / t.runs,
                  t.initial_turning / t.runs, t.refined_turning / t.runs, t.ms / t.runs);
    }
  }
  return 0;
}
