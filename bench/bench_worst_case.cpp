// The most engine time one feature line can take within the option table's limits
// (api/options_table.cpp): every option that sets how much work a line does at its cap, on
// real meshes, for four shapes of line: 3 keys along a feature, 2 keys across the whole mesh,
// the most keys a line of the longest accepted length can have, and that length in pieces of
// 12 edges.
//
// usage: bench_worst_case [--repeat N] [MESH ...]   (default: igea.ply, 268,686 triangles)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "api/options_table.h"
#include "bench/feature_keys.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

const OptionSpec& spec_of(const std::string& name) {
  for (const auto& field : feature_line_option_table())
    if (field.spec.name == name) return field.spec;
  throw std::runtime_error("no option " + name);
}

// Every option that adds work at the end of its range that adds the most: iterations at the
// cap with a tolerance that never stops early, the densest points, the widest strip,
// resampling every iteration, the shortest pieces, and every triangle in the snake's domain.
FeatureLineOptions options_at_caps(bool strong_force) {
  FeatureLineOptions o;
  o.snake.max_iterations = int(spec_of("snake.max_iterations").maximum);
  o.snake.tolerance = spec_of("snake.tolerance").minimum;
  o.snake.spacing = spec_of("snake.spacing").minimum;
  o.snake.resample_every = int(spec_of("snake.resample_every").minimum);
  o.strip.rings = int(spec_of("strip.rings").maximum);
  o.min_piece_edges = int(spec_of("min_piece_edges").minimum);
  o.strip.max_edge_distortion = spec_of("strip.max_edge_distortion").maximum;
  if (strong_force) {  // an extreme force once made the snake add points without bound
    o.snake.kappa = spec_of("snake.kappa").maximum;
    o.snake.exponent = spec_of("snake.exponent").maximum;
    o.snake.max_step = spec_of("snake.max_step").maximum;
  }
  return o;
}

// The farthest vertex (straight-line) from v among the referenced ones.
std::uint32_t farthest_from(const PreparedMesh& mesh, std::uint32_t v) {
  std::uint32_t best = v;
  double best_d = -1;
  for (std::uint32_t w = 0; w < mesh.n_vertices(); ++w) {
    if (mesh.component()[w] != mesh.component()[v]) continue;
    const double d = (mesh.positions()[w] - mesh.positions()[v]).squaredNorm();
    if (d > best_d) best_d = d, best = w;
  }
  return best;
}

// Keys every `stride` vertices along a self-avoiding walk (Warnsdorff's rule: step to the free
// neighbour with the fewest free neighbours, so the walk does not trap itself early): the most
// keys a line can have without repeating a vertex.
std::vector<std::uint32_t> keys_along_walk(const PreparedMesh& mesh, std::uint32_t start, std::size_t keys, int stride,
                                           std::mt19937_64& rng) {
  const auto free_neighbours = [&](std::uint32_t v, const std::vector<char>& used) {
    int count = 0;
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) count += !used[mesh.neighbors()[k]];
    return count;
  };
  std::vector<char> used(mesh.n_vertices(), 0);
  std::vector<std::uint32_t> out{start};
  std::uint32_t v = start;
  used[v] = 1;
  for (std::size_t step = 1; out.size() < keys && step < keys * std::size_t(stride) * 4; ++step) {
    std::vector<std::uint32_t> free;
    int fewest = 1 << 30;
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
      const auto w = mesh.neighbors()[k];
      if (used[w]) continue;
      const int onward = free_neighbours(w, used);
      if (onward < fewest) free.clear(), fewest = onward;
      if (onward == fewest) free.push_back(w);
    }
    if (free.empty()) break;
    v = free[rng() % free.size()];
    used[v] = 1;
    if (step % std::size_t(stride) == 0) out.push_back(v);
  }
  return out;
}

struct Case {
  std::string name;
  std::vector<std::uint32_t> keys;
};

void run_case(const PreparedMesh& mesh, const Case& c, const char* variant, const FeatureLineOptions& options, int repeat) {
  FeatureLineRequest request;
  request.keys = c.keys;
  request.options = options;
  std::vector<double> ms;
  FeatureLineResult result;
  std::string error;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    try {
      result = detect_feature_line(mesh, request);
    } catch (const std::exception& e) {
      error = e.what();
    }
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  std::size_t caps = 0;
  for (const auto& p : result.piece_reports) caps += p.iteration_cap ? 1 : 0;
  std::printf("%-30s %-8s %5zu %6zu %6zu %7zu %7d %5zu %9.1f %9.1f %9.1f %9.1f %s\n", c.name.c_str(), variant,
              c.keys.size(), result.initial.vertices.size(), result.pieces, result.refined.size(), result.iterations, caps,
              result.timings.initial_ms, result.timings.snake_ms, ms[ms.size() / 2], ms.back(), error.c_str());
  std::fflush(stdout);
}

double load_average() {
  std::ifstream in("/proc/loadavg");
  double one = -1;
  in >> one;
  return one;
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
    else meshes.push_back(arg);
  }
  if (meshes.empty()) meshes.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/igea.ply");
  std::printf("Worst case per line at the option caps (snake.max_iterations %g, tolerance %g, spacing %g, resample_every %g,\n"
              "strip.rings %g, min_piece_edges %g, strip.max_edge_distortion %g; 'strong' adds kappa %g, exponent %g, max_step %g),\n"
              "at most %zu keys per line. Times: median and max of %d runs; load average at start %.2f.\n\n",
              spec_of("snake.max_iterations").maximum, spec_of("snake.tolerance").minimum, spec_of("snake.spacing").minimum,
              spec_of("snake.resample_every").minimum, spec_of("strip.rings").maximum, spec_of("min_piece_edges").minimum,
              spec_of("strip.max_edge_distortion").maximum, spec_of("snake.kappa").maximum, spec_of("snake.exponent").maximum,
              spec_of("snake.max_step").maximum, RequestLimits::max_keys_per_line, repeat, load_average());
  int status = 0;
  for (const auto& path : meshes) {
    try {
      const auto mesh = prepare_mesh(read_mesh_file(path));
      std::printf("%s: %zu triangles\n", path.c_str(), mesh->triangles().size());
      std::printf("%-30s %-8s %5s %6s %6s %7s %7s %5s %9s %9s %9s %9s\n", "line", "options", "keys", "edges", "pieces",
                  "points", "iters", "caps", "initial", "snake", "median_ms", "max_ms");
      std::mt19937_64 rng(20261201);
      std::vector<Case> cases;
      cases.push_back({"3 keys along a feature", pick_feature_keys(*mesh, rng)});
      const std::uint32_t start = cases[0].keys.empty() ? 0 : cases[0].keys[0];
      cases.push_back({"2 keys across the mesh", {start, farthest_from(*mesh, start)}});
      // As many keys as fit the longest line, 3 edges apart (the most pieces, each refined alone).
      const std::size_t max_edges = std::size_t(spec_of("initial.max_edges").maximum);
      cases.push_back({"most keys, 3 edges apart", keys_along_walk(*mesh, start, std::min(RequestLimits::max_keys_per_line, max_edges / 3), 3, rng)});
      // The longest line in pieces of about 12 edges (the snake's points grow with the length).
      cases.push_back({"longest, keys 12 edges apart", keys_along_walk(*mesh, start, max_edges / 12, 12, rng)});
      for (const auto& c : cases) {
        if (c.keys.size() < 2) continue;
        run_case(*mesh, c, "default", FeatureLineOptions{}, repeat);
        run_case(*mesh, c, "caps", options_at_caps(false), repeat);
        run_case(*mesh, c, "strong", options_at_caps(true), repeat);
      }
      std::printf("\n");
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), e.what());
      status = 1;
    }
  }
  return status;
}
