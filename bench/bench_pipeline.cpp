// Times every stage of the pipeline on real meshes and prints medians beside the paper's
// Table 1 (Dragon, 33,927 triangles, 1.6 GHz Pentium IV: initial 0.013 s,
// parameterisation 0.067 s, snake 0.261 s).
//
// Then the preparation's own stages (medians over --prepare-runs preparations of each mesh), so
// a change to prepare_mesh shows where its time went.
//
// usage: bench_pipeline [--lines N] [--keys feature|random|both] [--prepare-runs R] [--dump-curvature DIR]
//                       [--no-crest] [--fitted] [--options JSON] [MESH ...]
//   (default meshes: the four of the README)
//   --lines N            lines per mesh and key mode (default 40; 0: preparation only)
//   --keys MODE          feature: 3 keys along a feature (12 and 24 rings from the first);
//                        random: 3 keys anywhere, each 30 rings from the last (a dragged key
//                        spends most of its time off the feature); both (default)
//   --prepare-runs R     preparations per mesh for the breakdown (default 3)
//   --dump-curvature DIR writes DIR/<mesh>.curvature: the field's scalars, then per vertex mean,
//                        k_max, k_min (%.17g), then the crease flags; two dumps compared tell
//                        whether a change to the curvature stage changed its results
//   --no-crest           lines without crest localisation (its cost is in the snake column)
//   --fitted             lines with the fitted curve too (fitted.enabled); its own time (not in
//                        total) is printed under each row
//   --options JSON       line options as the API takes them, e.g. '{"second_strip": false}'
//   --compare-serial     every line twice, alternately first: on the default executor (a line's
//                        pieces side by side) and on one thread (one after another); prints
//                        both medians, p90s and means under each row
//   --per-line           every line's figures on stderr, tab-separated (what makes a slow line
//                        slow): mesh, keys, stage times, iterations, pieces, strip faces, edges,
//                        strength (the pieces' mean feature strength, weighted by their edges)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

#include "api/feature_line_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/thread_pool.h"
#include "bench/feature_keys.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Medians of the preparation stages over `runs` preparations of `raw`.
struct PrepareBreakdown {
  std::vector<double> total, triangles, adjacency, tables, index, normals, curvature, mean, creases, noise, jet, smoothing,
      landmarks;
};

void add_timings(const PreparedMesh& mesh, PrepareBreakdown& b) {
  const auto& t = mesh.timings();
  const auto& c = mesh.curvature().timings;
  b.total.push_back(mesh.prepare_ms());
  b.triangles.push_back(t.triangles_ms);
  b.adjacency.push_back(t.adjacency_ms);
  b.tables.push_back(t.tables_ms);
  b.index.push_back(t.index_ms);
  b.normals.push_back(t.normals_ms);
  b.curvature.push_back(t.curvature_ms);
  b.mean.push_back(c.mean_ms);
  b.creases.push_back(c.creases_ms);
  b.noise.push_back(c.noise_ms);
  b.jet.push_back(c.jet_ms);
  b.smoothing.push_back(c.smoothing_ms);
  b.landmarks.push_back(t.landmarks_ms);
}

void print_breakdown(const std::string& name, const PrepareBreakdown& b) {
  std::printf("%-20s %8.1f | %7.1f %7.1f %7.1f %7.1f %7.1f | %7.1f: %6.1f %7.1f %6.1f %7.1f %7.1f | %9.1f\n",
              name.c_str(), median(b.total), median(b.triangles), median(b.adjacency), median(b.tables), median(b.index),
              median(b.normals), median(b.curvature), median(b.mean), median(b.creases), median(b.noise), median(b.jet),
              median(b.smoothing), median(b.landmarks));
}

void dump_curvature(const PreparedMesh& mesh, const std::string& path) {
  std::ofstream out(path);
  const CurvatureField& f = mesh.curvature();
  char line[128];
  std::snprintf(line, sizeof line, "noise %.17g radius %.17g passes %d crease_angle %.17g crease_edges %zu\n", f.noise,
                f.radius, f.smoothing_passes, f.crease_angle, f.crease_edges);
  out << line;
  for (std::size_t v = 0; v < f.k_max.size(); ++v) {
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", f.mean[v], f.k_max[v], f.k_min[v]);
    out << line;
  }
  for (const auto c : f.crease) out << int(c) << '\n';
}

enum class KeyMode { feature, random };
const char* to_string(KeyMode mode) { return mode == KeyMode::feature ? "feature" : "random"; }

// Medians of a mesh's lines in one key mode.
struct LineRow {
  std::size_t lines = 0, fallbacks = 0;
  double initial = 0, strip = 0, flatten = 0, snake = 0, median_total = 0, p90_total = 0, iterations = 0,
         per_piece = 0;
  double fitted = -1;  ///< median time of the fitted curve (--fitted), -1 without it
  /// --compare-serial: the same lines' totals with the pieces side by side and on one thread
  std::vector<double> side_by_side, serial;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::size_t(q * double(v.size() - 1))];
}

// The answer's feature strength: its pieces' mean strength (the line each piece kept), weighted
// by their edges. What a faster variant must not lose.
double line_strength(const FeatureLineResult& r) {
  double sum = 0, edges = 0;
  for (const PieceReport& p : r.piece_reports) {
    const bool refined = p.kept == PieceKept::refined || p.kept == PieceKept::crease_fit;
    sum += double(p.edges) * (refined ? p.refined_strength : p.initial_strength);
    edges += double(p.edges);
  }
  return edges > 0 ? sum / edges : 0;
}

// `lines` lines on `mesh` with keys picked by `mode` (the same seed for every mesh and mode).
LineRow run_lines(const PreparedMesh& mesh, KeyMode mode, int lines, const FeatureLineOptions& options,
                  const std::string& per_line_name, bool compare_serial) {
  std::mt19937_64 rng(20041101);
  std::vector<double> initial, strip, flatten, snake, total, iterations, per_piece, fitted_ms;
  LineRow row;
  for (int i = 0; i < lines; ++i) {
    FeatureLineRequest request;
    request.keys = mode == KeyMode::feature ? pick_feature_keys(mesh, rng) : pick_random_keys(mesh, rng);
    request.options = options;
    if (request.keys.empty()) break;
    SerialExecutor one_thread;
    FeatureLineRequest serial = request;
    serial.executor = &one_thread;
    // Alternately first, so neither finds the other's caches warm more often.
    if (compare_serial && i % 2 == 0) row.serial.push_back(detect_feature_line(mesh, serial).timings.total_ms);
    const auto r = detect_feature_line(mesh, request);
    if (compare_serial) row.side_by_side.push_back(r.timings.total_ms);
    if (compare_serial && i % 2 == 1) row.serial.push_back(detect_feature_line(mesh, serial).timings.total_ms);
    if (r.fitted) fitted_ms.push_back(r.fitted->elapsed_ms);
    initial.push_back(r.timings.initial_ms);
    strip.push_back(r.timings.strip_ms);
    flatten.push_back(r.timings.flatten_ms);
    snake.push_back(r.timings.snake_ms);
    total.push_back(r.timings.total_ms);
    iterations.push_back(r.iterations);
    if (r.pieces > 0) per_piece.push_back(double(r.iterations) / double(r.pieces));
    row.fallbacks += r.initial.fallbacks.size();
    if (!per_line_name.empty())
      std::fprintf(stderr, "%s\t%s\t%u,%u,%u\t%.3f\t%.3f\t%.3f\t%.3f\t%.3f\t%d\t%zu\t%zu\t%zu\t%.4f\n",
                   per_line_name.c_str(), to_string(mode), request.keys[0], request.keys[1], request.keys[2],
                   r.timings.initial_ms, r.timings.strip_ms, r.timings.flatten_ms, r.timings.snake_ms, r.timings.total_ms,
                   r.iterations, r.pieces, r.strip_faces, r.initial.vertices.size() - 1, line_strength(r));
  }
  row.lines = total.size();
  row.initial = median(initial), row.strip = median(strip), row.flatten = median(flatten), row.snake = median(snake);
  row.median_total = median(total), row.p90_total = percentile(total, 0.9);
  row.iterations = median(iterations), row.per_piece = median(per_piece);
  if (options.fitted.enabled) row.fitted = median(fitted_ms);
  return row;
}

void print_row(const std::string& name, KeyMode mode, const PreparedMesh& mesh, double load_ms, const LineRow& r) {
  std::printf("%-20s %-7s %9zu %8.1f %8.1f | %5zu %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f | %6.0f %5.0f %6zu\n",
              name.c_str(), to_string(mode), mesh.statistics().faces, load_ms, mesh.prepare_ms(), r.lines, r.initial,
              r.strip, r.flatten, r.snake, r.median_total, r.p90_total, r.iterations, r.per_piece, r.fallbacks);
  if (r.fitted >= 0) std::printf("%-20s %-7s   fitted curve: median %.3f ms per line (beside total)\n", "", "", r.fitted);
  auto mean = [](const std::vector<double>& v) { return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size()); };
  if (!r.serial.empty())
    std::printf("%-20s %-7s   pieces side by side / one thread: median %.3f / %.3f ms, p90 %.3f / %.3f, mean %.3f / %.3f\n", "", "",
                median(r.side_by_side), median(r.serial), percentile(r.side_by_side, 0.9), percentile(r.serial, 0.9),
                mean(r.side_by_side), mean(r.serial));
}

}  // namespace

int main(int argc, char** argv) {
  int lines = 40, prepare_runs = 3;
  // --no-crest: the snake's line, to measure what crest localisation costs; --fitted: the fitted
  // curve too, timed on its own; --options: any other line options (JSON, as the API takes
  // them), to compare a change with what it replaced.
  FeatureLineOptions options;
  std::string dump_dir;
  bool per_line = false, compare_serial = false;
  std::vector<std::string> meshes;
  std::vector<KeyMode> modes{KeyMode::feature, KeyMode::random};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--lines" && i + 1 < argc) lines = std::max(0, std::atoi(argv[++i]));
    else if (arg == "--prepare-runs" && i + 1 < argc) prepare_runs = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--dump-curvature" && i + 1 < argc) dump_dir = argv[++i];
    else if (arg == "--no-crest") options.crest.enabled = false;
    else if (arg == "--fitted") options.fitted.enabled = true;
    else if (arg == "--per-line") per_line = true;
    else if (arg == "--compare-serial") compare_serial = true;
    else if (arg == "--options" && i + 1 < argc) apply_options_json(nlohmann::json::parse(argv[++i]), options);
    else if (arg == "--keys" && i + 1 < argc) {
      const std::string which = argv[++i];
      if (which == "feature") modes = {KeyMode::feature};
      else if (which == "random") modes = {KeyMode::random};
      else if (which != "both") return std::fprintf(stderr, "--keys: feature, random or both\n"), 2;
    }
    else meshes.push_back(arg);
  }
  if (meshes.empty())
    for (const char* name : {"dragon_25k.off", "armadillo_29k.obj", "bunny_closed.off", "igea.ply"})
      meshes.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name);

  std::printf("Paper, Table 1 (Dragon, 33,927 triangles, 1.6 GHz Pentium IV, 3 lines): initial 13 ms, "
              "parameterisation 67 ms, snake 261 ms\n\n");
  std::printf("iters: snake iterations per line, summed over its pieces; it/pc: per piece.\n\n");
  std::printf("%-20s %-7s %9s %8s %8s | %5s %8s %8s %8s %8s %8s %8s | %6s %5s %6s\n", "mesh", "keys", "triangles", "load_ms",
              "prep_ms", "lines", "initial", "strip", "flatten", "snake", "total", "p90_tot", "iters", "it/pc", "fallbk");
  struct Extreme {
    std::size_t faces;
    double total;
  };
  std::pair<Extreme, Extreme> extremes[2] = {{{SIZE_MAX, 0}, {0, 0}}, {{SIZE_MAX, 0}, {0, 0}}};
  int status = 0;
  std::vector<std::pair<std::string, PrepareBreakdown>> breakdowns;
  for (const auto& path : meshes) {
    try {
      auto t0 = Clock::now();
      RawMesh raw = read_mesh_file(path);
      const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const std::string name = path.substr(path.find_last_of('/') + 1);
      PrepareBreakdown breakdown;
      for (int run = 1; run < prepare_runs; ++run) add_timings(*prepare_mesh(raw), breakdown);
      const auto mesh = prepare_mesh(std::move(raw));
      add_timings(*mesh, breakdown);
      breakdowns.emplace_back(name, breakdown);
      if (!dump_dir.empty()) dump_curvature(*mesh, dump_dir + "/" + name + ".curvature");
      for (const KeyMode mode : modes) {
        const LineRow row = run_lines(*mesh, mode, lines, options, per_line ? name : std::string(), compare_serial);
        print_row(name, mode, *mesh, load_ms, row);
        auto& [smallest, largest] = extremes[int(mode)];
        if (mesh->statistics().faces < smallest.faces) smallest = {mesh->statistics().faces, row.median_total};
        if (mesh->statistics().faces > largest.faces) largest = {mesh->statistics().faces, row.median_total};
      }
    } catch (const std::exception& e) {
      std::printf("%s: %s\n", path.c_str(), e.what());
      status = 1;
    }
  }
  for (const KeyMode mode : modes) {
    const auto& [smallest, largest] = extremes[int(mode)];
    if (largest.faces > smallest.faces && smallest.total > 0 && lines > 0)
      std::printf("\n%s keys: median total per line, largest / smallest mesh (%zu / %zu triangles): %.2fx\n",
                  to_string(mode), largest.faces, smallest.faces, largest.total / smallest.total);
  }
  std::printf("\nPreparation, ms (medians of %d preparations per mesh; curvature = mean + creases + noise + jet + "
              "smoothing):\n\n",
              prepare_runs);
  std::printf("%-20s %8s | %7s %7s %7s %7s %7s | %7s: %6s %7s %6s %7s %7s | %9s\n", "mesh", "prepare", "triangl",
              "adjacen", "tables", "index", "normals", "curvatu", "mean", "creases", "noise", "jet", "smooth", "landmarks");
  for (const auto& [name, breakdown] : breakdowns) print_breakdown(name, breakdown);
  return status;
}
