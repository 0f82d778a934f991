// One-click lines (engine/trace.h): how long a trace takes on real meshes, and how close a
// traced line comes to an analytic crest beside the keyed line through three keys on it.
//
// Speed: on each mesh, traces from the middle of every crease chain and from the strongest
// ridge and valley seeds (engine/feature_seeds.h, 16 of each), each timed over --runs runs
// (median); then the whole traced line (trace, strip, snake) once. The hover preview of the
// page is the trace alone.
//
// Accuracy: Gaussian ridges and valleys (make_ridge_field: width 0.25, sine bend 0.3) on
// jittered Delaunay grids of n x n points, clean and with 10% and 20% noise (RMS, of the grid
// spacing); the keyed line has keys at x = -0.8, 0, 0.8 on the crest (as bench_accuracy), the
// traced line one key at x = 0 and runs border to border. Distances are arc-length means of the
// refined line's xy distance to the crest, in grid spacings, over |x| <= 0.8 for both lines
// (the keyed line's span), and over the whole traced line.
//
// usage: bench_trace [--runs R] [--seeds N] [--sizes N,..] [--no-speed] [--no-accuracy] [MESH ...]
//   (default meshes: fandisk.off, dragon_25k.off, bun_zipper.ply, igea.ply from ../shared)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/feature_seeds.h"
#include "engine/mesh_io.h"
#include "engine/trace.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/line_metrics.h"
#include "tests/support/synthetic_meshes.h"

namespace {

using namespace featureline;
using namespace featureline::testing;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}
double median(const std::vector<double>& v) { return quantile(v, 0.5); }

struct Args {
  int runs = 5, seeds = 3;
  std::vector<int> sizes{51, 111, 201, 351};
  bool speed = true, accuracy = true;
  std::vector<std::string> meshes;
};

Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool more = i + 1 < argc;
    if (arg == "--runs" && more) a.runs = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--seeds" && more) a.seeds = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--sizes" && more) {
      a.sizes.clear();
      for (std::string list = argv[++i]; !list.empty();) {
        const auto comma = list.find(',');
        a.sizes.push_back(std::atoi(list.substr(0, comma).c_str()));
        list = comma == std::string::npos ? "" : list.substr(comma + 1);
      }
    } else if (arg == "--no-speed") a.speed = false;
    else if (arg == "--no-accuracy") a.accuracy = false;
    else if (!arg.empty() && arg[0] != '-') a.meshes.push_back(arg);
    else {
      std::fprintf(stderr, "usage: bench_trace [--runs R] [--seeds N] [--sizes N,..] [--no-speed] [--no-accuracy] [MESH ...]\n");
      std::exit(2);
    }
  }
  if (a.meshes.empty())
    for (const char* name : {"fandisk.off", "dragon_25k.off", "bun_zipper.ply", "igea.ply"})
      a.meshes.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name);
  return a;
}

// Where a user would click: the middle of each crease chain, and the ridge and valley seeds.
std::vector<std::uint32_t> trace_starts(const PreparedMesh& mesh) {
  FeatureSeedOptions options;
  options.max_crease_chains = 16;
  options.max_vertices_per_sign = 16;
  const FeatureSeeds seeds = find_feature_seeds(mesh, options);
  std::vector<std::uint32_t> starts;
  for (const auto& chain : seeds.crease_chains) starts.push_back(chain.vertices[chain.vertices.size() / 2]);
  for (const auto* list : {&seeds.ridge_vertices, &seeds.valley_vertices})
    for (const auto& seed : *list) starts.push_back(seed.vertex);
  return starts;
}

void speed_row(const std::string& path, int runs) {
  const auto mesh = prepare_mesh(read_mesh_file(path));
  std::vector<double> edges, trace_ms, per_edge_us, long_ms, line_ms;
  std::size_t refused = 0, closed = 0;
  for (const auto start : trace_starts(*mesh)) {
    std::vector<double> times;
    TraceResult trace;
    try {
      for (int r = 0; r < runs; ++r) {
        const auto t = Clock::now();
        trace = trace_feature(*mesh, start);
        times.push_back(ms_since(t));
      }
    } catch (const GeometryError&) {
      ++refused;
      continue;
    }
    const double n = double(trace.vertices.size() - (trace.closed ? 0 : 1));
    closed += trace.closed;
    edges.push_back(n);
    trace_ms.push_back(median(times));
    per_edge_us.push_back(1000 * median(times) / n);
    if (n >= 150) long_ms.push_back(median(times));
    FeatureLineRequest request;
    request.keys = {start};
    request.trace = true;
    const auto t = Clock::now();
    detect_feature_line(*mesh, request);
    line_ms.push_back(ms_since(t));
  }
  const std::string name = path.substr(path.find_last_of('/') + 1);
  std::printf("| %s | %zu | %zu | %zu | %zu | %.0f | %.0f | %.2f | %.2f | %.2f | %.1f | %zu: %.2f | %.1f | %.1f |\n", name.c_str(),
              mesh->statistics().faces, edges.size(), refused, closed, median(edges), quantile(edges, 1.0), median(trace_ms),
              quantile(trace_ms, 0.9), quantile(trace_ms, 1.0), median(per_edge_us), long_ms.size(), median(long_ms),
              median(line_ms), quantile(line_ms, 0.9));
}

struct AccuracyCell {
  std::vector<double> keyed_mean, traced_mean, traced_whole;
  double keyed_max = 0, traced_max = 0;
  std::size_t border_to_border = 0, lines = 0;
};

// The refined points of a line whose x lies within [-0.8, 0.8], as one polyline.
std::vector<Eigen::Vector3d> within_keyed_span(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : points)
    if (std::abs(p.x()) <= 0.8) out.push_back(p);
  return out;
}

void accuracy_cell(bool ridge, int n, double noise, int seeds, AccuracyCell& cell) {
  for (int seed = 1; seed <= seeds; ++seed) {
    const HeightField field = make_ridge_field(n, 0.2, std::uint64_t(seed), ridge ? 0.3 : -0.3, 0.25, 0.3);
    const double fraction = noise / 100 * field.spacing / mean_edge_length(field.mesh);
    const auto mesh = prepare_mesh(with_noise(field.mesh, fraction, 1000003ull * std::uint64_t(seed) + 7));
    auto distance = [&](const Eigen::Vector3d& p) { return distance_to_crest(field, p.x(), p.y()) / field.spacing; };
    FeatureLineRequest keyed;
    for (double x : {-0.8, 0.0, 0.8}) keyed.keys.push_back(nearest_vertex(field.mesh, x, field.crest(x)));
    const LineDistance k = arc_length_distance(refined_positions(detect_feature_line(*mesh, keyed)), false, distance);
    FeatureLineRequest traced;
    traced.keys = {nearest_vertex(field.mesh, 0.0, field.crest(0.0))};
    traced.trace = true;
    const FeatureLineResult t = detect_feature_line(*mesh, traced);
    const auto points = refined_positions(t);
    const LineDistance span = arc_length_distance(within_keyed_span(points), false, distance);
    const LineDistance whole = arc_length_distance(points, false, distance);
    cell.keyed_mean.push_back(k.mean);
    cell.keyed_max = std::max(cell.keyed_max, k.max);
    cell.traced_mean.push_back(span.mean);
    cell.traced_max = std::max(cell.traced_max, span.max);
    cell.traced_whole.push_back(whole.mean);
    cell.border_to_border += t.trace->ends[0].reason == TraceStop::boundary && t.trace->ends[1].reason == TraceStop::boundary;
    ++cell.lines;
  }
}

void accuracy_table(const Args& a) {
  std::printf("\n## Traced (one key) vs keyed (three keys) lines on analytic crests, grid spacings, median over %d seeds (max: over seeds)\n\n",
              a.seeds);
  std::printf("| field | triangles | noise | keyed mean | keyed max | traced mean | traced max | traced, whole line | border to border |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (int n : a.sizes)
    for (bool ridge : {true, false})
      for (double noise : {0.0, 10.0, 20.0}) {
        AccuracyCell cell;
        accuracy_cell(ridge, n, noise, a.seeds, cell);
        std::printf("| %s n=%d | %d | %.0f%% | %.3f | %.3f | %.3f | %.3f | %.3f | %zu of %zu |\n", ridge ? "ridge" : "valley", n,
                    2 * (n - 1) * (n - 1), noise, median(cell.keyed_mean), cell.keyed_max, median(cell.traced_mean), cell.traced_max,
                    median(cell.traced_whole), cell.border_to_border, cell.lines);
        std::fflush(stdout);
      }
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse_args(argc, argv);
  if (a.speed) {
    std::printf("## Trace time from where a user would click (crease chain middles, 16 ridge and 16 valley seeds), median of %d runs each\n\n",
                a.runs);
    std::printf("| mesh | triangles | traces | nothing to trace | closed | edges (median) | edges (max) | trace ms (median) | trace ms (p90) | "
                "trace ms (max) | us per edge | traces >= 150 edges: ms | whole line ms (median) | whole line ms (p90) |\n");
    std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const auto& path : a.meshes) {
      try {
        speed_row(path, a.runs);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_trace: %s: %s\n", path.c_str(), e.what());
        return 1;
      }
      std::fflush(stdout);
    }
  }
  if (a.accuracy) accuracy_table(a);
  return 0;
}
