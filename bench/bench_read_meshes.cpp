// Times reading meshes from memory (read_mesh, the bytes already loaded) and prints the median
// of several reads per file, with the vertex and triangle counts and the megabytes per second.
// Reading from memory leaves the disk out: what is measured is the parser.
//
// usage: bench_read_meshes [--repeats N] [MESH ...]   (default: the big shared meshes)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/mesh_io.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshFormatError("Cannot open '" + path + "'.");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 7;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else {
      meshes.push_back(arg);
    }
  }
  if (meshes.empty()) {
    for (const char* name : {"igea.ply", "bun_zipper.ply", "bunny_closed.off", "dragon_25k.off", "fandisk.off",
                             "armadillo_29k.obj", "SheenCloth.glb", "bunny_gltf.drc"}) {
      meshes.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name);
    }
  }
  std::printf("%-20s %9s %10s %9s %10s %8s\n", "mesh", "bytes", "vertices", "triangles", "median_ms", "MB/s");
  int status = 0;
  for (const auto& path : meshes) {
    const std::string name = path.substr(path.find_last_of('/') + 1);
    try {
      const std::string bytes = file_bytes(path);
      const auto format = mesh_format_from_path(path);
      if (!format) throw UnsupportedFormatError("Unknown extension: " + path);
      std::vector<double> ms;
      RawMesh mesh;
      for (int r = 0; r < repeats; ++r) {
        const auto t0 = Clock::now();
        mesh = read_mesh(bytes, *format);
        ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
      const double m = median(ms);
      std::printf("%-20s %9zu %10zu %9zu %10.2f %8.1f\n", name.c_str(), bytes.size(), mesh.positions.size(),
                  mesh.triangles.size(), m, bytes.size() / 1e6 / (m / 1e3));
    } catch (const std::exception& e) {
      std::printf("%-20s failed: %s\n", name.c_str(), e.what());
      status = 1;
    }
  }
  return status;
}
