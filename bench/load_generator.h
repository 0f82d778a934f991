// The benchmarks' HTTP load generator: N client threads, each on one keep-alive connection,
// POSTing JSON bodies in turn for a fixed time; latencies of 200 answers, everything else an
// error. Shared by bench_server (in-process server) and bench_cluster (nginx vs one replica).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/prepared_mesh.h"

namespace featureline::bench {

struct LoadTarget {
  std::string host = "127.0.0.1";
  int port = 0;
  std::vector<std::string> paths;   ///< client i starts at paths[i % size] and cycles with its bodies
  std::vector<std::string> bodies;  ///< JSON bodies, cycled
};

struct LoadLevel {
  int connections = 0;
  double lines_per_s = 0, p50_ms = 0, p99_ms = 0, max_ms = 0;
  std::size_t errors = 0;  ///< answers other than 200 and failed connections
  /// From the answers' Server-Timing header (0 when the server sends none): the wait for an
  /// engine thread and the engine's time per request.
  double queue_p50_ms = 0, queue_p99_ms = 0, engine_p50_ms = 0, engine_p99_ms = 0;
};

/// Runs `connections` clients for `seconds` after each sent one warm-up request (connection
/// setup is not steady-state latency).
LoadLevel run_load(const LoadTarget& target, int connections, double seconds);

double percentile(std::vector<double> values, double q);

/// `count` feature-line request bodies {"keys": [...]} with 3 keys along features of `mesh`
/// (bench/feature_keys.h), from a seeded generator: the same set for every run and level.
std::vector<std::string> feature_line_bodies(const PreparedMesh& mesh, std::size_t count, std::uint64_t seed);

/// The same with 3 keys anywhere, each 30 rings from the last (bench/feature_keys.h).
std::vector<std::string> random_line_bodies(const PreparedMesh& mesh, std::size_t count, std::uint64_t seed);

/// A benchmark input file's bytes. \throw std::runtime_error naming the missing file
std::string read_file(const std::string& path);

/// One table row, and its header: connections, lines/s, p50_ms, p99_ms, max_ms, errors, then the
/// server's queue wait and engine time (p50, p99).
void print_load_header(const char* first_column = "connections");
void print_load_level(const LoadLevel& level, const std::string& label = "");

}  // namespace featureline::bench
