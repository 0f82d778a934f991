// Threads and wall time of concurrent preparations, as the server runs them: --jobs uploads
// (default 8: the four default meshes twice) prepared at once on the server's engine pool
// (server/work_pool.h, --threads threads, default 8), whose threads are also the executor the
// engine splits its loops over. A sampler reads the process's thread count (Threads: in
// /proc/self/status) every 200 us; the peak, the count at rest and the wall time of each round
// are printed, with the prepared meshes' memory per triangle (memory_bytes, what the cache's
// budget counts) and the process's peak resident memory (VmHWM) at the end.
//
// usage: bench_threads [--jobs N] [--threads T] [--rounds R] [MESH ...]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "engine/mesh_io.h"
#include "engine/prepared_mesh.h"
#include "server/work_pool.h"

namespace {

using namespace featureline;
using Clock = std::chrono::steady_clock;

// A field of /proc/self/status ("Threads", "VmHWM"), its first number; -1 when missing.
long status_field(const std::string& name) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.compare(0, name.size() + 1, name + ":") == 0) return std::atol(line.c_str() + name.size() + 1);
  return -1;
}

// Samples the thread count on a thread of its own (counted in every figure) until destroyed.
class ThreadSampler {
 public:
  ThreadSampler() : thread_([this] {
      while (!stop_) {
        peak_ = std::max(peak_.load(), status_field("Threads"));
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    }) {}
  ~ThreadSampler() {
    stop_ = true;
    thread_.join();
  }
  long take_peak() { return peak_.exchange(0); }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<long> peak_{0};
  std::thread thread_;
};

}  // namespace

int main(int argc, char** argv) {
  std::size_t jobs = 8, threads = 8;
  int rounds = 3;
  std::vector<std::string> paths;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--jobs" && i + 1 < argc) jobs = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--threads" && i + 1 < argc) threads = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--rounds" && i + 1 < argc) rounds = std::max(1, std::atoi(argv[++i]));
    else paths.push_back(arg);
  }
  if (paths.empty())
    for (const char* name : {"dragon_25k.off", "armadillo_29k.obj", "bunny_closed.off", "igea.ply"})
      paths.push_back(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name);
  std::vector<RawMesh> meshes;
  std::size_t triangles = 0;
  for (const auto& path : paths) {
    meshes.push_back(read_mesh_file(path));
    triangles += meshes.back().triangles.size();
  }

  server::WorkPool pool(threads, jobs);
  ThreadSampler sampler;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const long at_rest = sampler.take_peak();
  std::printf("%zu preparations at once on a pool of %zu threads (%zu meshes, %zu triangles; hardware threads: %u)\n",
              jobs, threads, meshes.size(), triangles, std::thread::hardware_concurrency());
  std::printf("threads at rest (main, pool, sampler): %ld\n\n", at_rest);
  std::printf("%5s %12s %8s\n", "round", "peak_threads", "wall_ms");
  for (int round = 1; round <= rounds; ++round) {
    sampler.take_peak();
    const auto start = Clock::now();
    // Each job answers its prepared mesh's memory_bytes (what the cache's budget counts).
    std::vector<std::future<std::size_t>> done;
    for (std::size_t j = 0; j < jobs; ++j) {
      const RawMesh& raw = meshes[j % meshes.size()];
      done.push_back(std::move(*pool.try_submit([&raw, &pool] {
        PrepareOptions options;
        options.executor = &pool;  // as the server passes its own pool
        return prepare_mesh(raw, options)->memory_bytes();
      })));
    }
    std::size_t prepared_bytes = 0, prepared_triangles = 0;
    for (std::size_t j = 0; j < done.size(); ++j) {
      prepared_bytes += done[j].get();
      prepared_triangles += meshes[j % meshes.size()].triangles.size();
    }
    const double wall_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    std::printf("%5d %12ld %8.0f\n", round, sampler.take_peak(), wall_ms);
    if (round == rounds)
      std::printf("\nprepared meshes: %.1f bytes per triangle (memory_bytes over all %zu)\n",
                  double(prepared_bytes) / double(prepared_triangles), done.size());
  }
  std::printf("\npeak resident memory (VmHWM): %ld MB\n", status_field("VmHWM") / 1024);
  return 0;
}
