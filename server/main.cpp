// featureline-server: a thin main around FeaturelineServer (flags, signals, banner).
#include <pthread.h>
#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>

#include "featureline_version.h"
#include "server/server.h"
#include "server/upload_store.h"

namespace {

using featureline::server::kRedisPasswordVariable;
using featureline::server::redacted_store_url;
using featureline::server::ServerOptions;

// Every flag, with its range and default from ServerOptions.
// A range check whose help reads "in [lo, hi]" (CLI11's own repeats the type).
CLI::Validator within(double lo, double hi) {
  return CLI::Range(lo, hi).description("in [" + std::to_string((long long)lo) + ", " + std::to_string((long long)hi) + "]");
}

void add_flags(CLI::App& app, ServerOptions& o, std::string& port_file) {
  const auto count = [](double hi) { return within(1, hi); };
  app.add_option("--host", o.host, "Address to bind (loopback by default; put a reverse proxy in front for the world)")
      ->capture_default_str();
  app.add_option("--port", o.port, "Port (0 picks a free one)")->check(within(0, 65535))->capture_default_str();
  app.add_option("--threads", o.engine_threads, "Engine threads (default: the machine's cores)")->check(count(1024));
  app.add_option("--queue", o.queue_capacity, "Engine jobs that may wait before requests get 503")
      ->check(count(1e6))->capture_default_str();
  app.add_option("--http-threads", o.http_threads, "Connection workers (each keep-alive connection holds one)")
      ->check(within(2, 4096))->capture_default_str();
  app.add_option("--cache-mb", o.cache_mb, "Byte budget of prepared meshes and the engine's per-thread scratch, MiB")->check(count(1 << 20))->capture_default_str();
  app.add_option("--ttl-s", o.ttl_s, "Idle seconds before a mesh session expires")->check(count(365 * 86400))->capture_default_str();
  app.add_option("--max-upload-mb", o.max_upload_mb, "Largest accepted upload, MiB")->check(count(1 << 16))->capture_default_str();
  app.add_option("--deadline-s", o.deadline_s, "Longest a request may wait for the engine, s")->check(count(3600))->capture_default_str();
  app.add_option("--max-connections", o.max_connections,
                 "Open connections (served + waiting for a worker); beyond, 503 at once (default 2 x --http-threads)")
      ->check(within(2, 1e6));
  app.add_option("--head-timeout-s", o.head_timeout_s, "A request's headers must arrive within this many s of its first byte")
      ->check(count(3600))->capture_default_str();
  app.add_option("--max-triangles", o.max_triangles,
                 "An upload may expand to at most N triangles (glTF: over all instances and primitives); "
                 "default min(upload limit / 12 B, cache / 128 B)")
      ->check(count(4e9));
  app.add_option("--max-vertices", o.max_vertices, "The same for vertex records; same default")->check(count(4e9));
  app.add_option("--upload-buffer-mb", o.upload_buffer_mb,
                 "Upload bodies being received, in total, MiB; beyond, 503 (default 2 x --max-upload-mb)")
      ->check(count(1 << 20));
  app.add_option("--cors-origin", o.cors_origins, "Allow browser requests from this origin (\"*\" for any); repeatable");
  app.add_option("--preload", o.preload, "Load FILE at start, keep it while the server runs, print its mesh id; repeatable")
      ->check(CLI::ExistingFile);
  app.add_option("--web-root", o.web_root, "Serve this folder at / instead of the page built into the binary")
      ->check(CLI::ExistingDirectory);
  app.add_flag("--no-page{false}", o.embedded_page, "Serve no page at / (API only)");
  app.add_option_function<std::string>(
         "--data-dir", [&o](const std::string& dir) { o.store = "dir:" + dir; },
         "Keep every upload in DIR (atomic writes), so sessions survive eviction and restarts")
      ->type_name("DIR");
  app.add_option("--store", o.store,
                 "Where uploads are kept: redis://[[USER][:PASSWORD]@]HOST:PORT[/DB] (shared by a cluster's replicas; "
                 "the password may instead come from the environment variable " + std::string(kRedisPasswordVariable) +
                 ", which ps does not show) or dir:PATH; default: memory only");
  app.add_option("--store-max-mb", o.store_max_mb, "A directory store holds at most this many MiB of uploads; beyond, 503")
      ->check(count(1 << 24));
  app.add_option("--port-file", port_file, "Write the bound port to this file once listening (for scripts)");
  app.add_flag("--quiet{false}", o.access_log, "No access log");
}

void print_banner(const ServerOptions& options, int port, const std::vector<std::pair<std::string, std::string>>& preloaded) {
  const std::string base = "http://" + options.host + ":" + std::to_string(port);
  std::printf("featureline-server %s listening on %s\n", FEATURELINE_VERSION, base.c_str());
  for (const auto& [path, id] : preloaded) {
    std::printf("preloaded %s as mesh %s\n", path.c_str(), id.c_str());
    std::printf("  curl -s %s/v1/meshes/%s\n", base.c_str(), id.c_str());
  }
  if (!options.web_root.empty() || options.embedded_page) std::printf("open %s/\n", base.c_str());
  std::printf("uploads kept %s\n", options.store.empty() ? "in memory only (a restart forgets them; see --data-dir)"
                                                          : ("in " + redacted_store_url(options.store)).c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  ServerOptions options;
  std::string port_file;
  CLI::App app{"featureline-server: the Featureline HTTP service (feature lines on triangle meshes) and its page at /",
               "featureline-server"};
  app.set_version_flag("--version", std::string("featureline-server ") + FEATURELINE_VERSION);
  app.footer("API: api/openapi.yaml (GET /v1/options lists every request option). Docs: docs/server.md");
  add_flags(app, options, port_file);
  // The Redis password from the environment keeps it off the command line, which ps shows.
  if (const char* password = std::getenv(kRedisPasswordVariable)) options.store_password = password;
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version: stdout, exit 0
  } catch (const CLI::ParseError& e) {
    std::cerr << "featureline-server: " << e.what() << "\nRun 'featureline-server --help' for the options.\n";
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
    // Bound before preloading, so a port in use fails at once rather than after the loads.
    const int port = server.bind();
    std::vector<std::pair<std::string, std::string>> preloaded;
    for (const auto& path : options.preload) preloaded.emplace_back(path, server.preload(path));
    std::thread signal_thread([&server, stop_signals] {
      int received = 0;
      sigwait(&stop_signals, &received);
      std::fprintf(stderr, "featureline-server: %s received, stopping\n", received == SIGINT ? "SIGINT" : "SIGTERM");
      server.stop();
    });
    signal_thread.detach();
    print_banner(options, port, preloaded);
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
