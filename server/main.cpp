// featureline-server: a thin main around FeaturelineServer (flags, signals, banner).
#include <pthread.h>
#include <signal.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>

#include "server/server.h"

namespace {

const char* const kUsage = R"(usage: featureline-server [options]
  --host H            address to bind (default 127.0.0.1, loopback only)
  --port P            port (default 8080; 0 picks a free one)
  --threads N         engine threads (default: the machine's cores)
  --queue N           engine jobs that may wait before requests get 503 (default 256)
  --http-threads N    connection workers (default 64; each keep-alive connection holds one)
  --cache-mb M        byte budget of prepared meshes (default 1024)
  --ttl-s T           idle seconds before a mesh session expires (default 1800)
  --max-upload-mb U   largest accepted upload (default 256)
  --deadline-s S      longest a request may wait for the engine (default 30)
  --max-connections C open connections (served + waiting for a worker); beyond, 503 at once
                      (default 2 x --http-threads)
  --head-timeout-s T  a request's headers must arrive within T s of its first byte (default 10)
  --max-triangles N   an upload may expand to at most N triangles (glTF: over all node instances
                      and primitives); default min(upload limit / 12 bytes, cache / 128 bytes)
  --max-vertices N    the same for vertex records; same default
  --upload-buffer-mb B  upload bodies being received, in total; beyond, 503 (default 2 x --max-upload-mb)
  --cors-origin O     allow browser requests from origin O ("*" for any); repeatable
  --preload FILE      load FILE at start and print its mesh id; repeatable
  --web-root DIR      serve DIR at / (the browser front-end)
  --data-dir DIR      keep every upload in DIR (atomic writes), so sessions survive eviction and
                      restarts (a miss prepares the mesh again from the stored upload)
  --store URL         where uploads are kept: redis://HOST:PORT[/DB] (shared by a cluster's
                      replicas) or dir:PATH (as --data-dir); default: memory only
  --store-max-mb M    a directory store holds at most M MiB of uploads; beyond, uploads get 503
                      storage_full (Redis: its own maxmemory, with maxmemory-policy noeviction)
  --port-file F       write the bound port to F once listening (for tests)
  --quiet             no access log
)";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

long number(const std::string& text, const char* flag, long lo, long hi) {
  try {
    std::size_t used = 0;
    const long v = std::stol(text, &used);
    if (used == text.size() && v >= lo && v <= hi) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(std::string(flag) + " expects an integer between " + std::to_string(lo) + " and " + std::to_string(hi));
}

}  // namespace

int main(int argc, char** argv) {
  using featureline::server::ServerOptions;
  ServerOptions options;
  std::string port_file;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string flag = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw UsageError(flag + " needs a value");
        return argv[++i];
      };
      if (flag == "--host") options.host = value();
      else if (flag == "--port") options.port = int(number(value(), "--port", 0, 65535));
      else if (flag == "--threads") options.engine_threads = std::size_t(number(value(), "--threads", 1, 1024));
      else if (flag == "--queue") options.queue_capacity = std::size_t(number(value(), "--queue", 1, 1000000));
      else if (flag == "--http-threads") options.http_threads = std::size_t(number(value(), "--http-threads", 2, 4096));
      else if (flag == "--cache-mb") options.cache_mb = std::size_t(number(value(), "--cache-mb", 1, 1 << 20));
      else if (flag == "--ttl-s") options.ttl_s = int(number(value(), "--ttl-s", 1, 365 * 86400));
      else if (flag == "--max-upload-mb") options.max_upload_mb = std::size_t(number(value(), "--max-upload-mb", 1, 1 << 16));
      else if (flag == "--deadline-s") options.deadline_s = double(number(value(), "--deadline-s", 1, 3600));
      else if (flag == "--max-connections") options.max_connections = std::size_t(number(value(), "--max-connections", 2, 1000000));
      else if (flag == "--head-timeout-s") options.head_timeout_s = double(number(value(), "--head-timeout-s", 1, 3600));
      else if (flag == "--max-triangles") options.max_triangles = std::size_t(number(value(), "--max-triangles", 1, 4000000000L));
      else if (flag == "--max-vertices") options.max_vertices = std::size_t(number(value(), "--max-vertices", 1, 4000000000L));
      else if (flag == "--upload-buffer-mb") options.upload_buffer_mb = std::size_t(number(value(), "--upload-buffer-mb", 1, 1 << 20));
      else if (flag == "--cors-origin") options.cors_origins.push_back(value());
      else if (flag == "--preload") options.preload.push_back(value());
      else if (flag == "--web-root") options.web_root = value();
      else if (flag == "--data-dir") options.store = "dir:" + value();
      else if (flag == "--store") options.store = value();
      else if (flag == "--store-max-mb") options.store_max_mb = std::size_t(number(value(), "--store-max-mb", 1, 1 << 24));
      else if (flag == "--port-file") port_file = value();
      else if (flag == "--quiet") options.access_log = false;
      else if (flag == "-h" || flag == "--help") throw UsageError("");
      else throw UsageError("unknown option \"" + flag + "\"");
    }
  } catch (const UsageError& e) {
    if (std::strlen(e.what()) > 0) std::cerr << "featureline-server: " << e.what() << "\n";
    std::cerr << kUsage;
    return 2;
  }

  // SIGINT/SIGTERM are handled by one thread (sigwait), so no handler runs inside the
  // server's threads; block them before any thread starts.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  try {
    featureline::server::FeaturelineServer server(options);
    std::vector<std::pair<std::string, std::string>> preloaded;
    for (const auto& path : options.preload) preloaded.emplace_back(path, server.preload(path));
    const int port = server.bind();
    std::thread signal_thread([&server, stop_signals] {
      int received = 0;
      sigwait(&stop_signals, &received);
      std::fprintf(stderr, "featureline-server: %s received, stopping\n", received == SIGINT ? "SIGINT" : "SIGTERM");
      server.stop();
    });
    signal_thread.detach();
    const std::string base = "http://" + options.host + ":" + std::to_string(port);
    std::printf("featureline-server listening on %s\n", base.c_str());
    for (const auto& [path, id] : preloaded) {
      std::printf("preloaded %s as mesh %s\n", path.c_str(), id.c_str());
      std::printf("  curl -s %s/v1/meshes/%s\n", base.c_str(), id.c_str());
    }
    if (!options.web_root.empty()) std::printf("open %s/\n", base.c_str());
    std::printf("uploads kept %s\n", options.store.empty() ? "in memory only (a restart forgets them; see --data-dir)"
                                                            : ("in " + options.store).c_str());
    std::fflush(stdout);
    if (!port_file.empty()) {
      std::FILE* f = std::fopen(port_file.c_str(), "w");
      if (f == nullptr) throw std::runtime_error("cannot write " + port_file);
      std::fprintf(f, "%d\n", port);
      std::fclose(f);
    }
    if (!server.run()) throw std::runtime_error("the server stopped unexpectedly");
    std::fprintf(stderr, "featureline-server: stopped\n");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "featureline-server: " << e.what() << "\n";
    return 1;
  }
}
