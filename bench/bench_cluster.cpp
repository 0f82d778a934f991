// Lines through the cluster's nginx versus one replica directly: 3-key lines on
// copies of the 70k-triangle bunny (each copy its own mesh id, so nginx's hash spreads them
// over the replicas), at 32, 128 and 512 keep-alive connections. bench/bench_cluster.sh starts
// the cluster and runs this; it also measures a dead replica's failover.
//
// usage: bench_cluster --front PORT --replica PORT [--seconds S] [--copies K] [--levels 32,128,512]
#include "api/feature_line_json.h"
#include "bench/load_generator.h"
#include "engine/mesh_io.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <csignal>
#include <cstdio>
#include <map>
#include <sstream>

namespace {

std::vector<int> parse_levels(const std::string& text) {
  std::vector<int> levels;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) levels.push_back(std::stoi(item));
  return levels;
}

}  // namespace

int main(int argc, char** argv) {
  int front = 0, replica = 0, copies = 6;
  double seconds = 5;
  std::vector<int> levels = {32, 128, 512};
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--front") front = std::stoi(value);
    else if (flag == "--replica") replica = std::stoi(value);
    else if (flag == "--seconds") seconds = std::stod(value);
    else if (flag == "--copies") copies = std::stoi(value);
    else if (flag == "--levels") levels = parse_levels(value);
  }
  if (front == 0 || replica == 0) {
    std::fprintf(stderr, "usage: bench_cluster --front PORT --replica PORT [--seconds S] [--copies K] [--levels 32,128,512]\n");
    return 2;
  }
  // A server may close a refused connection while a client still writes: an error, not a signal.
  std::signal(SIGPIPE, SIG_IGN);
  try {
    const std::string bunny = featureline::bench::read_file(std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/bunny_closed.off");
    httplib::Client setup("127.0.0.1", front);
    setup.set_read_timeout(60, 0);
    std::vector<std::string> paths;
    std::map<std::string, int> per_replica;
    for (int k = 0; k < copies; ++k) {
      auto res = setup.Post("/v1/meshes?format=off", bunny, "application/octet-stream");
      if (!res || res->status != 201) throw std::runtime_error("bunny upload through nginx failed");
      const std::string id = nlohmann::json::parse(res->body)["mesh_id"];
      paths.push_back("/v1/meshes/" + id + "/feature-lines");
      auto where = setup.Get(("/v1/meshes/" + id).c_str());
      ++per_replica[where ? where->get_header_value("X-Featureline-Replica") : "?"];
    }
    std::printf("%d copies of bunny_closed.off (69,666 triangles) through nginx; nginx placed them:", copies);
    for (const auto& [where, n] : per_replica) std::printf(" %s x%d", where.c_str(), n);
    std::printf("\n");

    const auto mesh = featureline::prepare_mesh(featureline::read_mesh(bunny, featureline::MeshFormat::off));
    const std::vector<std::string> bodies = featureline::bench::feature_line_bodies(*mesh, 64, 7);
    const featureline::bench::LoadTarget through_nginx{"127.0.0.1", front, paths, bodies};
    const featureline::bench::LoadTarget direct{"127.0.0.1", replica, paths, bodies};
    std::printf("\n3-key lines, %.0f s per level (client threads share the machine with the servers)\n", seconds);
    featureline::bench::print_load_header("target/conns");
    for (int connections : levels) {
      featureline::bench::print_load_level(featureline::bench::run_load(through_nginx, connections, seconds),
                                           "nginx/" + std::to_string(connections));
      featureline::bench::print_load_level(featureline::bench::run_load(direct, connections, seconds),
                                           "replica/" + std::to_string(connections));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_cluster: %s\n", e.what());
    return 1;
  }
  return 0;
}
