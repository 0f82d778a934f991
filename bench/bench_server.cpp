// Load benchmark of featureline-server on loopback: lines per second and p50/p99 latency of
// 3-key lines on the 70k-triangle bunny at 1, 8 and 32 connections (keys along features, then
// anywhere 30 rings apart; the server's Server-Timing header splits queue wait from compute), and the
// upload-to-ready time of igea (270k triangles). The server runs in this process on its own
// threads (as it would beside a load generator on the same 2-core machine); every client
// thread keeps one keep-alive connection.
//
// usage: bench_server [--seconds S] [--threads N]
#include "api/feature_line_json.h"
#include "bench/load_generator.h"
#include "engine/mesh_io.h"
#include "server/server.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include <unistd.h>

namespace {

using Clock = std::chrono::steady_clock;


// Resident memory of this process (server and clients share it), from /proc/self/statm.
double resident_mib() {
  std::ifstream statm("/proc/self/statm");
  double size = 0, resident = 0;
  statm >> size >> resident;
  return resident * double(sysconf(_SC_PAGESIZE)) / (1 << 20);
}


}  // namespace

int main(int argc, char** argv) {
  double seconds = 5;
  std::size_t engine_threads = std::max(1u, std::thread::hardware_concurrency());
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--seconds") seconds = std::atof(argv[i + 1]);
    if (std::string(argv[i]) == "--threads") engine_threads = std::size_t(std::atoi(argv[i + 1]));
  }
  const std::string meshes = std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/";
  try {
    featureline::server::ServerOptions options;
    options.port = 0;
    options.engine_threads = engine_threads;
    options.access_log = false;
    options.cache_mb = 4096;
    featureline::server::FeaturelineServer server(options);
    const int port = server.bind();
    std::thread serving([&] { server.run(); });

    // Upload-to-ready of igea: the whole POST (transfer, parse, prepare), median of 3.
    const std::string igea = featureline::bench::read_file(meshes + "igea.ply");
    std::vector<double> upload_ms;
    for (int i = 0; i < 3; ++i) {
      httplib::Client client("127.0.0.1", port);
      client.set_read_timeout(60, 0);
      const auto t0 = Clock::now();
      auto res = client.Post("/v1/meshes", igea, "application/x-ply");
      upload_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (!res || res->status != 201) throw std::runtime_error("igea upload failed");
      client.Delete(("/v1/meshes/" + nlohmann::json::parse(res->body)["mesh_id"].get<std::string>()).c_str());
    }
    std::printf("upload-to-ready igea.ply (268,686 triangles, %zu bytes): median %.0f ms of 3\n", igea.size(),
                featureline::bench::percentile(upload_ms, 0.5));
    {
      // Memory per cached triangle: resident growth while 4 copies of igea are cached.
      httplib::Client client("127.0.0.1", port);
      client.set_read_timeout(60, 0);
      const double before = resident_mib();
      std::vector<std::string> ids;
      std::size_t reported = 0;
      for (int i = 0; i < 4; ++i) {
        auto res = client.Post("/v1/meshes", igea, "application/x-ply");
        if (!res || res->status != 201) throw std::runtime_error("igea upload failed");
        const auto description = nlohmann::json::parse(res->body);
        ids.push_back(description["mesh_id"]);
        reported += description["memory_bytes"].get<std::size_t>();
      }
      const double after = resident_mib();
      for (const auto& mesh_id : ids) client.Delete(("/v1/meshes/" + mesh_id).c_str());
      std::printf("memory per cached triangle: %.0f bytes measured (resident growth with 4 igea sessions), "
                  "%.0f bytes as reported in memory_bytes\n\n",
                  (after - before) * (1 << 20) / (4.0 * 268686), double(reported) / (4.0 * 268686));
    }

    // Lines on the bunny: keys picked along features, the same set for every concurrency.
    const std::string bunny = featureline::bench::read_file(meshes + "bunny_closed.off");
    httplib::Client setup("127.0.0.1", port);
    auto res = setup.Post("/v1/meshes?format=off", bunny, "application/octet-stream");
    if (!res || res->status != 201) throw std::runtime_error("bunny upload failed");
    const std::string id = nlohmann::json::parse(res->body)["mesh_id"];
    const auto mesh = featureline::prepare_mesh(featureline::read_mesh(bunny, featureline::MeshFormat::off));
    const std::vector<std::string> along = featureline::bench::feature_line_bodies(*mesh, 64, 7),
                                   anywhere = featureline::bench::random_line_bodies(*mesh, 64, 7);
    for (const auto& [name, bodies] : {std::pair{"along features", &along}, std::pair{"anywhere, 30 rings apart", &anywhere}}) {
      std::printf("3-key lines on bunny_closed.off (69,666 triangles), keys %s, %zu engine threads, %.0f s per level "
                  "(queue: wait for an engine thread; engine: the line's own time; both from Server-Timing):\n",
                  name, engine_threads, seconds);
      featureline::bench::print_load_header();
      const featureline::bench::LoadTarget target{"127.0.0.1", port, {"/v1/meshes/" + id + "/feature-lines"}, *bodies};
      for (int connections : {1, 8, 32})
        featureline::bench::print_load_level(featureline::bench::run_load(target, connections, seconds));
      std::printf("\n");
    }
    server.stop();
    serving.join();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_server: %s\n", e.what());
    return 1;
  }
  return 0;
}
