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

namespace {

// `count` bodies {"keys": [...]} from `pick`, seeded.
template <class Pick>
std::vector<std::string> line_bodies(std::size_t count, std::uint64_t seed, Pick pick) {
  std::mt19937_64 rng(seed);
  std::vector<std::string> bodies;
  while (bodies.size() < count) {
    const auto keys = pick(rng);
    if (!keys.empty()) bodies.push_back(nlohmann::json{{"keys", keys}}.dump());
  }
  return bodies;
}

}  // namespace

std::vector<std::string> feature_line_bodies(const PreparedMesh& mesh, std::size_t count, std::uint64_t seed) {
  return line_bodies(count, seed, [&mesh](std::mt19937_64& rng) { return pick_feature_keys(mesh, rng); });
}

std::vector<std::string> random_line_bodies(const PreparedMesh& mesh, std::size_t count, std::uint64_t seed) {
  return line_bodies(count, seed, [&mesh](std::mt19937_64& rng) { return pick_random_keys(mesh, rng); });
}

namespace {

// A metric's duration from a Server-Timing header ("queue;dur=0.012, engine;dur=1.3"), or -1.
double server_timing(const httplib::Result& r, const std::string& metric) {
  const std::string header = r->get_header_value("Server-Timing");
  const auto at = header.find(metric + ";dur=");
  return at == std::string::npos ? -1 : std::atof(header.c_str() + at + metric.size() + 5);
}

}  // namespace

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("missing benchmark mesh " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

LoadLevel run_load(const LoadTarget& target, int connections, double seconds) {
  std::vector<std::vector<double>> latencies{std::size_t(connections)}, queue{std::size_t(connections)},
      engine{std::size_t(connections)};
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
        if (!r || r->status != 200) {
          ++errors;
          continue;
        }
        latencies[std::size_t(c)].push_back(ms);
        if (const double q = server_timing(r, "queue"); q >= 0) queue[std::size_t(c)].push_back(q);
        if (const double e = server_timing(r, "engine"); e >= 0) engine[std::size_t(c)].push_back(e);
      }
    });
  while (connected < connections) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  go = true;
  for (auto& t : clients) t.join();
  const auto merged = [](const std::vector<std::vector<double>>& per_client) {
    std::vector<double> all;
    for (const auto& l : per_client) all.insert(all.end(), l.begin(), l.end());
    return all;
  };
  const std::vector<double> all = merged(latencies), waits = merged(queue), computes = merged(engine);
  LoadLevel level;
  level.queue_p50_ms = percentile(waits, 0.5);
  level.queue_p99_ms = percentile(waits, 0.99);
  level.engine_p50_ms = percentile(computes, 0.5);
  level.engine_p99_ms = percentile(computes, 0.99);
  level.connections = connections;
  level.lines_per_s = double(all.size()) / seconds;
  level.p50_ms = percentile(all, 0.5);
  level.p99_ms = percentile(all, 0.99);
  level.max_ms = percentile(all, 1.0);
  level.errors = errors.load();
  return level;
}

void print_load_header(const char* first_column) {
  std::printf("%12s %10s %10s %10s %10s %8s | %9s %9s %9s %9s\n", first_column, "lines/s", "p50_ms", "p99_ms", "max_ms",
              "errors", "queue_p50", "queue_p99", "engine_p50", "engine_p99");
}

void print_load_level(const LoadLevel& l, const std::string& label) {
  std::printf("%12s %10.0f %10.2f %10.2f %10.2f %8zu | %9.2f %9.2f %9.2f %9.2f\n",
              (label.empty() ? std::to_string(l.connections) : label).c_str(), l.lines_per_s, l.p50_ms, l.p99_ms,
              l.max_ms, l.errors, l.queue_p50_ms, l.queue_p99_ms, l.engine_p50_ms, l.engine_p99_ms);
  std::fflush(stdout);
}

}  // namespace featureline::bench
