// Mesh decomposition on real models (the paper's Fig. 12: parts cut off along detected feature
// lines): times detection and segmentation in both modes and prints every segment's area.
//
// Loops are picked by hand, by coordinates: each cut is a plane through a limb or an ear and a
// point near the wanted loop. The plane meets the mesh in closed curves; the one nearest that
// point gives four key vertices a quarter of its length apart, and the feature line detected
// through those keys (closed) is the cut. So the keys are where a user would click, and the
// line is what the pipeline makes of them.
//
// usage: bench_segmentation [--repeat N]   (medians over N runs, default 5)
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/segmentation.h"
#include "engine/vertex_index.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Cut {
  const char* name;
  Eigen::Vector3d normal;  ///< plane normal . x = normal . through
  Eigen::Vector3d through;
  Eigen::Vector3d near;  ///< the loop whose centre is nearest this point
};

struct Model {
  const char* file;
  std::vector<Cut> cuts;
};

// Closed curves where a plane meets the mesh, as points on edges (one per crossed edge).
std::vector<std::vector<Eigen::Vector3d>> plane_loops(const PreparedMesh& mesh, const Eigen::Vector3d& normal,
                                                      double offset, std::vector<std::vector<std::uint32_t>>* edge_ends) {
  const auto& tris = mesh.triangles();
  std::vector<double> s(mesh.n_vertices());
  for (std::size_t v = 0; v < s.size(); ++v) {
    s[v] = normal.dot(mesh.positions()[v]) - offset;
    if (s[v] == 0) s[v] = 1e-300;  // a vertex on the plane counts as above it
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> faces_of;
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = tris[f][k], b = tris[f][(k + 1) % 3];
      if (s[a] * s[b] < 0) faces_of[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  std::vector<char> used(tris.size(), 0);
  std::vector<std::vector<Eigen::Vector3d>> loops;
  for (const auto& [start_edge, start_faces] : faces_of) {
    if (start_faces.size() != 2 || used[start_faces[0]]) continue;
    std::vector<Eigen::Vector3d> loop;
    std::vector<std::uint32_t> ends;
    auto edge = start_edge;
    std::uint32_t f = start_faces[0];
    bool closed = false;
    for (std::size_t guard = 0; guard < tris.size(); ++guard) {
      const auto [a, b] = edge;
      const double t = s[a] / (s[a] - s[b]);
      loop.push_back((1 - t) * mesh.positions()[a] + t * mesh.positions()[b]);
      ends.push_back(t < 0.5 ? a : b);
      if (used[f]) {
        closed = true;
        break;
      }
      used[f] = 1;
      // The face's other crossed edge, then the face across it.
      std::pair<std::uint32_t, std::uint32_t> next{0, 0};
      for (int k = 0; k < 3; ++k) {
        const auto p = tris[f][k], q = tris[f][(k + 1) % 3];
        const std::pair<std::uint32_t, std::uint32_t> e{std::min(p, q), std::max(p, q)};
        if (s[p] * s[q] < 0 && e != edge) next = e;
      }
      const auto it = faces_of.find(next);
      if (it == faces_of.end() || it->second.size() != 2) break;
      edge = next;
      f = it->second[0] == f ? it->second[1] : it->second[0];
    }
    if (closed && loop.size() >= 8) {
      loop.pop_back();
      ends.pop_back();
      loops.push_back(std::move(loop));
      if (edge_ends) edge_ends->push_back(std::move(ends));
    }
  }
  return loops;
}

// Four keys a quarter of the loop's length apart, on the vertices nearest the loop.
std::vector<std::uint32_t> keys_on_loop(const std::vector<Eigen::Vector3d>& loop, const std::vector<std::uint32_t>& ends) {
  std::vector<double> along(loop.size() + 1, 0);
  for (std::size_t i = 0; i < loop.size(); ++i) along[i + 1] = along[i] + (loop[(i + 1) % loop.size()] - loop[i]).norm();
  std::vector<std::uint32_t> keys;
  for (int q = 0; q < 4; ++q) {
    const double target = along.back() * q / 4;
    const auto i = std::size_t(std::lower_bound(along.begin(), along.end(), target) - along.begin()) % loop.size();
    if (keys.empty() || keys.back() != ends[i]) keys.push_back(ends[i]);
  }
  return keys;
}

struct Timed {
  SegmentationResult result;
  double ms = 0;
};

Timed run(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& lines, SegmentationMode mode, int repeat,
          bool merge = false) {
  SegmentationOptions options;
  options.mode = mode;
  options.merge_tiny_segments = merge;
  std::vector<double> times;
  Timed out;
  for (int i = 0; i < repeat; ++i) {
    const auto start = Clock::now();
    out.result = segment_mesh(mesh, lines, options);
    times.push_back(ms_since(start));
  }
  out.ms = median(times);
  return out;
}

double area_of(const std::vector<Eigen::Vector3d>& p, const std::vector<std::array<std::uint32_t, 3>>& t) {
  double area = 0;
  for (const auto& tri : t) area += 0.5 * (p[tri[1]] - p[tri[0]]).cross(p[tri[2]] - p[tri[0]]).norm();
  return area;
}

}  // namespace

// The tables prepare_mesh keeps for segmentation and point keys, per triangle.
void print_table_memory(const PreparedMesh& mesh) {
  const double faces = double(mesh.triangles().size());
  const double face_tables = double((mesh.vertex_faces().offsets.capacity() + mesh.vertex_faces().faces.capacity()) * 4 +
                                    mesh.face_neighbors().capacity() * 12 + mesh.boundary_vertex().capacity());
  std::printf("  built once: face tables %.1f B/triangle, vertex index %.1f B/triangle (prepared mesh in all: %.1f B/triangle)\n",
              face_tables / faces, double(mesh.vertex_index().memory_bytes()) / faces, double(mesh.memory_bytes()) / faces);
}

// Point keys ({"point": [x, y, z]}) snapped to the nearest vertex: the prepared mesh's k-d tree
// against the scan over every vertex the server did before, on points near the surface.
void print_point_key_times(const PreparedMesh& mesh) {
  std::vector<Eigen::Vector3d> queries;
  for (std::size_t v = 0; v < mesh.n_vertices(); v += std::max<std::size_t>(1, mesh.n_vertices() / 1000))
    queries.push_back(mesh.positions()[v] + 0.3 * mesh.statistics().mean_edge_length * Eigen::Vector3d(0.31, -0.52, 0.17));
  auto start = Clock::now();
  const VertexIndex index(mesh.positions(), mesh.component());
  const double build_ms = ms_since(start);
  std::size_t disagree = 0;
  start = Clock::now();
  std::vector<std::uint32_t> found;
  for (const auto& q : queries) found.push_back(mesh.nearest_vertex(q));
  const double tree_ms = ms_since(start);
  start = Clock::now();
  for (std::size_t i = 0; i < queries.size(); ++i) {
    std::uint32_t best = 0;
    double best_d = HUGE_VAL;
    for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
      if (mesh.component()[v] < 0) continue;
      const double d = (mesh.positions()[v] - queries[i]).squaredNorm();
      if (d < best_d) best_d = d, best = v;
    }
    disagree += best != found[i];
  }
  const double scan_ms = ms_since(start);
  std::printf("  point keys: k-d tree %.2f us per key, scan %.1f us per key (%zu keys, %zu disagree); tree built in %.1f ms\n",
              1000 * tree_ms / double(queries.size()), 1000 * scan_ms / double(queries.size()), queries.size(), disagree,
              build_ms);
}

// Detects each cut's loop, then segments along all of them in both modes; false when a loop is missing.
bool bench_model(const Model& model, int repeat) {
  const std::string path = std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + model.file;
  bool ok = true;
  const auto mesh = prepare_mesh(read_mesh_file(path));
  std::printf("%s: %zu vertices, %zu triangles, prepare %.1f ms\n", model.file, mesh->statistics().vertices,
              mesh->statistics().faces, mesh->prepare_ms());
  print_table_memory(*mesh);
  std::vector<FeatureLineResult> lines;
  for (const auto& cut : model.cuts) {
    std::vector<std::vector<std::uint32_t>> ends;
    const auto loops = plane_loops(*mesh, cut.normal, cut.normal.dot(cut.through), &ends);
    std::size_t best = loops.size();
    double best_distance = HUGE_VAL;
    for (std::size_t i = 0; i < loops.size(); ++i) {
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const auto& p : loops[i]) centre += p;
      centre /= double(loops[i].size());
      if ((centre - cut.near).norm() < best_distance) best_distance = (centre - cut.near).norm(), best = i;
    }
    if (best == loops.size()) {
      std::printf("  %-10s no loop found\n", cut.name);
      ok = false;
      continue;
    }
    FeatureLineRequest request;
    request.keys = keys_on_loop(loops[best], ends[best]);
    request.closed = true;
    std::vector<double> times;
    FeatureLineResult line;
    for (int i = 0; i < repeat; ++i) {
      const auto start = Clock::now();
      line = detect_feature_line(*mesh, request);
      times.push_back(ms_since(start));
    }
    std::printf("  %-10s keys", cut.name);
    for (auto k : request.keys) std::printf(" %u", k);
    std::printf(": detect %.2f ms, %zu refined points, length %.4f\n", median(times), line.refined.size(),
                line.refined_length);
    lines.push_back(std::move(line));
  }
  const double area = area_of(mesh->positions(), mesh->triangles());
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    const auto timed = run(*mesh, lines, mode, repeat);
    const auto& r = timed.result;
    std::printf("  %-6s %7.2f ms, %zu segments, %zu cut edges", mode == SegmentationMode::snap ? "snap" : "remesh",
                timed.ms, r.segments.size(), r.cut_edges);
    if (r.remeshed)
      std::printf(", +%zu vertices, +%zu triangles, area change %.1e", r.positions.size() - mesh->n_vertices(),
                  r.triangles.size() - mesh->triangles().size(), std::abs(r.total_area - area) / area);
    std::printf("\n    label    faces        area   area%%  boundary   bbox centre\n");
    for (const auto& s : r.segments)
      std::printf("    %5d %8zu %11.6f %6.2f%% %9.5f   (%.3f, %.3f, %.3f)\n", s.label, s.faces, s.area,
                  100 * s.area / r.total_area, s.boundary_length, 0.5 * (s.bbox_min[0] + s.bbox_max[0]),
                  0.5 * (s.bbox_min[1] + s.bbox_max[1]), 0.5 * (s.bbox_min[2] + s.bbox_max[2]));
    for (const auto& w : r.warnings) std::printf("    warning: %s\n", w.c_str());
  }
  // Slivers (a line doubling back to a pinned key) merged into their neighbours.
  std::printf("  merge_tiny_segments:");
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    const auto timed = run(*mesh, lines, mode, repeat, true);
    std::printf(" %s %.2f ms, %zu segments (areas", mode == SegmentationMode::snap ? "snap" : "remesh", timed.ms,
                timed.result.segments.size());
    for (const auto& s : timed.result.segments) std::printf(" %.6f", s.area);
    std::printf(")%s", mode == SegmentationMode::snap ? ";" : "\n");
  }
  std::printf("\n");
  return ok;
}

int main(int argc, char** argv) {
  int repeat = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
  }
  using V = Eigen::Vector3d;
  // Coordinates read off the models (armadillo: y up, facing +z; bunny: y up).
  const std::vector<Model> models{
      {"armadillo_29k.obj",
       {{"right arm", V(1, 0, 0), V(-0.30, 0, 0), V(-0.30, 0.25, 0.15)},
        {"left arm", V(1, 0, 0), V(0.28, 0, 0), V(0.28, 0.2, 0.1)},
        {"right leg", V(0, 1, 0), V(0, -0.38, 0), V(-0.2, -0.38, 0)},
        {"left leg", V(0, 1, 0), V(0, -0.38, 0), V(0.2, -0.38, 0)}}},
      {"bunny_closed.off",
       {{"ear 1", V(0, 1, 0), V(0, 0.16, 0), V(-0.036, 0.16, -0.004)},
        {"ear 2", V(0, 1, 0), V(0, 0.16, 0), V(-0.068, 0.16, -0.032)}}},
  };

  std::printf("Paper, Fig. 12: Bunny and Venus decomposed along detected feature lines (no timings given).\n");
  std::printf("Times are medians of %d runs; snap and remesh segment the mesh along all of a model's lines at once.\n\n",
              repeat);
  int status = 0;
  for (const auto& model : models) {
    try {
      if (!bench_model(model, repeat)) status = 1;
    } catch (const std::exception& e) {
      std::printf("%s: error: %s\n\n", model.file, e.what());
      status = 1;
    }
  }
  // The largest shared mesh, for the memory the tables add.
  try {
    const auto igea = prepare_mesh(read_mesh_file(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/igea.ply"));
    std::printf("igea.ply: %zu triangles\n", igea->triangles().size());
    print_table_memory(*igea);
    print_point_key_times(*igea);
  } catch (const std::exception& e) {
    std::printf("igea.ply: error: %s\n", e.what());
    status = 1;
  }
  return status;
}
