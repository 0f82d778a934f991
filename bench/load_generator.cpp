#include "bench/load_generator.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <random>
#include <thread>

#include "bench/feature_keys.h"

namespace featureline::bench {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5))];
}

std::vector<std::string> feature_line_bodies(const PreparedMesh& mesh, std::size_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::string> bodies;
  while (bodies.size() < count) {
    const auto keys = pick_feature_keys(mesh, rng);
    if (!keys.empty()) bodies.push_back(nlohmann::json{{"keys", keys}}.dump());
  }
  return bodies;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("missing benchmark mesh " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

LoadLevel run_load(const LoadTarget& target, int connections, double seconds) {
  std::vector<std::vector<double>> latencies{std::size_t(connections)};
  std::atomic<std::size_t> errors{0};
  std::atomic<int> connected{0};
  Clock::time_point end{};
  std::atomic<bool> go{false};
  std::vector<std::thread> clients;
  for (int c = 0; c < connections; ++c)
    clients.emplace_back([&, c] {
      httplib::Client client(target.host, target.port);
      client.set_keep_alive(true);
      client.set_tcp_nodelay(true);
      client.set_read_timeout(60, 0);
      std::size_t i = std::size_t(c);
      auto post = [&] {
        const auto& path = target.paths[i % target.paths.size()];
        const auto& body = target.bodies[i % target.bodies.size()];
        ++i;
        return client.Post(path.c_str(), body, "application/json");
      };
      // Warm-up: connect and send one request before the timed window.
      post();
      ++connected;
      while (!go) std::this_thread::yield();
      while (Clock::now() < end) {
        const auto t0 = Clock::now();
        auto r = post();
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        if (!r || r->status != 200) ++errors;
        else latencies[std::size_t(c)].push_back(ms);
      }
    });
  while (connected < connections) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  go = true;
  for (auto& t : clients) t.join();
  std::vector<double> all;
  for (const auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  LoadLevel level;
  level.connections = connections;
  level.lines_per_s = double(all.size()) / seconds;
  level.p50_ms = percentile(all, 0.5);
  level.p99_ms = percentile(all, 0.99);
  level.max_ms = percentile(all, 1.0);
  level.errors = errors.load();
  return level;
}

void print_load_header(const char* first_column) {
  std::printf("%12s %10s %10s %10s %10s %8s\n", first_column, "lines/s", "p50_ms", "p99_ms", "max_ms", "errors");
}

void print_load_level(const LoadLevel& l, const std::string& label) {
  std::printf("%12s %10.0f %10.2f %10.2f %10.2f %8zu\n", (label.empty() ? std::to_string(l.connections) : label).c_str(),
              l.lines_per_s, l.p50_ms, l.p99_ms, l.max_ms, l.errors);
  std::fflush(stdout);
}

}  // namespace featureline::bench
