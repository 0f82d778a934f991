// Compares the initial-line methods (and the marching search's three curvature terms), the
// snake's two force models and its two steps on fields with an analytic crest: how often each
// initial method needs a fallback, how far each line is from the true crest, how smooth it is,
// how many snake iterations it took.
//
// A line on the surface turns wherever it crosses from one facet to the next, so even the
// analytic crest, laid on the mesh, has a total turning well above 0; crest_turn is that
// reference (the crest sampled with as many points as the refined line, at the mesh's height),
// and plan_turn the refined line's turning seen from above (the crest's: 0 for the straight
// crease, 0.58 for the bent ridge and valley).
//
// usage: bench_methods [--seeds N]
#include <algorithm>
#include <cmath>
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
  bool normal_step = true;
};

struct Tally {
  double segments = 0, fallbacks = 0, initial_distance = 0, refined_distance = 0, initial_turning = 0,
         refined_turning = 0, crest_turning = 0, plan_turning = 0, iterations = 0, ms = 0, runs = 0;
};

std::vector<Eigen::Vector3d> seen_from_above(std::vector<Eigen::Vector3d> points) {
  for (auto& p : points) p.z() = 0;
  return points;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 8;
  for (int i = 1; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--seeds") seeds = std::max(1, std::atoi(argv[i + 1]));
  const std::vector<Variant> variants = {
      {"geodesic + smooth", InitialMethod::geodesic, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"feature-path + smooth", InitialMethod::feature_path, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"feature-path + paper force", InitialMethod::feature_path, MarchingCurvatureTerm::similar_to_end, SnakeForce::paper},
      {"feature-path + paper step", InitialMethod::feature_path, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth, false},
      {"marching(current) + smooth", InitialMethod::marching, MarchingCurvatureTerm::similar_to_current, SnakeForce::smooth},
      {"marching(end) + smooth", InitialMethod::marching, MarchingCurvatureTerm::similar_to_end, SnakeForce::smooth},
      {"marching(high) + smooth", InitialMethod::marching, MarchingCurvatureTerm::high_magnitude, SnakeForce::smooth},
  };
  const char* fields[] = {"ridge", "valley", "crease"};
  std::printf("%d seeds x {ridge, valley, crease} fields, 61x61 jittered Delaunay grids, 3 keys on the crest.\n", seeds);
  std::printf("Distances are mean xy distances to the analytic crest in grid spacings; turning is the total\n"
              "turning angle of the line in radians (crest_turn: the analytic crest laid on the mesh with as many\n"
              "points as the refined line; plan_turn: the refined line seen from above, where the crest has 0 for\n"
              "the crease and 0.58 for ridge and valley); fallback%% is the share of segments where marching\n"
              "failed; iters are snake iterations summed over the line's pieces. 'paper step': the snake's\n"
              "Eq. (15) on both coordinates with tau = 1 (normal_step = false) instead of the normal step.\n\n");
  std::printf("%-28s %-7s %8s %7s %9s %9s %8s %10s %9s %6s %7s\n", "variant", "field", "fallbk%", "init_d", "refined_d",
              "init_turn", "ref_turn", "crest_turn", "plan_turn", "iters", "ms");
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
        if (!variant.normal_step) request.options.snake.normal_step = false, request.options.snake.tau = 1;
        const auto r = detect_feature_line(*mesh, request);
        const auto refined = refined_positions(r);
        t.segments += double(request.keys.size() - 1);
        t.fallbacks += double(r.initial.fallbacks.size());
        t.initial_distance += crest_distance(field, r.initial_points).mean / field.spacing;
        t.refined_distance += crest_distance(field, refined).mean / field.spacing;
        t.initial_turning += total_turning(r.initial_points);
        t.refined_turning += total_turning(refined);
        t.crest_turning += total_turning(crest_on_surface(field, refined.front().x(), refined.back().x(), refined.size()));
        t.plan_turning += total_turning(seen_from_above(refined));
        t.iterations += r.iterations;
        t.ms += r.timings.total_ms;
        t.runs += 1;
      }
      std::printf("%-28s %-7s %8.1f %7.3f %9.3f %9.2f %8.2f %10.2f %9.2f %6.0f %7.2f\n", variant.name.c_str(), fields[f],
                  100 * t.fallbacks / t.segments, t.initial_distance / t.runs, t.refined_distance / t.runs,
                  t.initial_turning / t.runs, t.refined_turning / t.runs, t.crest_turning / t.runs,
                  t.plan_turning / t.runs, t.iterations / t.runs, t.ms / t.runs);
    }
  }
  return 0;
}
