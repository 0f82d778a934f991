// Times every stage of the pipeline on real meshes and prints medians beside the paper's
// Table 1 (Dragon, 33,927 triangles, 1.6 GHz Pentium IV: initial 0.013 s,
// parameterisation 0.067 s, snake 0.261 s).
//
// usage: bench_pipeline [--lines N] [MESH ...]   (default: the four meshes of the README)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "bench/feature_keys.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  int lines = 40;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--lines" && i + 1 < argc) lines = std::max(1, std::atoi(argv[++i]));
    else meshes.push_back(arg);
  }
  if (meshes.empty())
    for (const char* name : {"dragon_25k.off", "armadillo_29k.obj", "bunny_closed.off", "igea.ply"})
      meshes.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name);

  std::printf("Paper, Table 1 (Dragon, 33,927 triangles, 1.6 GHz Pentium IV, 3 lines): initial 13 ms, "
              "parameterisation 67 ms, snake 261 ms\n\n");
  std::printf("iters: snake iterations per line, summed over its pieces; it/pc: per piece.\n\n");
  std::printf("%-20s %9s %8s %8s | %5s %8s %8s %8s %8s %8s %8s | %6s %5s %6s\n", "mesh", "triangles", "load_ms",
              "prep_ms", "lines", "initial", "strip", "flatten", "snake", "total", "p90_tot", "iters", "it/pc", "fallbk");
  double smallest_total = 0, largest_total = 0;
  std::size_t smallest_faces = SIZE_MAX, largest_faces = 0;
  int status = 0;
  for (const auto& path : meshes) {
    try {
      auto t0 = Clock::now();
      RawMesh raw = read_mesh_file(path);
      const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const auto mesh = prepare_mesh(std::move(raw));
      std::mt19937_64 rng(20041101);
      std::vector<double> initial, strip, flatten, snake, total, iterations, per_piece;
      std::size_t fallbacks = 0;
      for (int i = 0; i < lines; ++i) {
        FeatureLineRequest request;
        request.keys = pick_feature_keys(*mesh, rng);
        if (request.keys.empty()) break;
        const auto r = detect_feature_line(*mesh, request);
        initial.push_back(r.timings.initial_ms);
        strip.push_back(r.timings.strip_ms);
        flatten.push_back(r.timings.flatten_ms);
        snake.push_back(r.timings.snake_ms);
        total.push_back(r.timings.total_ms);
        iterations.push_back(r.iterations);
        if (r.pieces > 0) per_piece.push_back(double(r.iterations) / double(r.pieces));
        fallbacks += r.initial.fallbacks.size();
      }
      std::vector<double> sorted_total = total;
      std::sort(sorted_total.begin(), sorted_total.end());
      const double p90 = sorted_total.empty() ? 0 : sorted_total[std::size_t(0.9 * double(sorted_total.size() - 1))];
      const std::string name = path.substr(path.find_last_of('/') + 1);
      std::printf("%-20s %9zu %8.1f %8.1f | %5zu %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f | %6.0f %5.0f %6zu\n", name.c_str(),
                  mesh->statistics.faces, load_ms, mesh->prepare_ms, total.size(), median(initial), median(strip),
                  median(flatten), median(snake), median(total), p90, median(iterations), median(per_piece), fallbacks);
      if (mesh->statistics.faces < smallest_faces) smallest_faces = mesh->statistics.faces, smallest_total = median(total);
      if (mesh->statistics.faces > largest_faces) largest_faces = mesh->statistics.faces, largest_total = median(total);
    } catch (const std::exception& e) {
      std::printf("%s: %s\n", path.c_str(), e.what());
      status = 1;
    }
  }
  if (largest_faces > smallest_faces && smallest_total > 0)
    std::printf("\nmedian total per line, largest / smallest mesh (%zu / %zu triangles): %.2fx (target: within 1.5x)\n",
                largest_faces, smallest_faces, largest_total / smallest_total);
  return status;
}
