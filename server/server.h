// featureline-server: the HTTP feature-line service. Routes are registered in one table in
// server.cpp; transport (httplib), work (WorkPool), sessions (SessionCache) and JSON (api/)
// live in separate files.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace featureline::server {

struct ServerOptions {
  std::string host = "127.0.0.1";  ///< loopback by default; put a reverse proxy in front for the world
  int port = 8080;                 ///< 0 picks a free port (printed on start)
  std::size_t engine_threads = std::max(1u, std::thread::hardware_concurrency());  ///< engine work pool
  std::size_t queue_capacity = 256;  ///< engine jobs waiting beyond this are refused with 503
  std::size_t http_threads = 64;     ///< connection workers (each keep-alive connection holds one)
  std::size_t cache_mb = 1024;       ///< byte budget of prepared meshes
  int ttl_s = 1800;                  ///< idle time after which a session expires
  std::size_t max_upload_mb = 256;   ///< largest accepted upload body
  double deadline_s = 30;            ///< a request waiting longer for the engine is answered 503
  int read_timeout_s = 5;            ///< per read or write; slow clients are cut off
  double head_timeout_s = 10;        ///< a request's head must arrive within this from its first byte (else 408)
  std::size_t max_connections = 0;   ///< open connections (served + waiting); beyond: 503 at once (0: 2 x http_threads)
  std::size_t max_triangles = 0;     ///< an upload may expand to this many triangles (0: from the upload limit and cache)
  std::size_t max_vertices = 0;      ///< the same for vertex records (0: as max_triangles' default)
  std::size_t upload_buffer_mb = 0;  ///< upload bodies being received, in total; beyond: 503 (0: 2 x max_upload_mb)
  std::vector<std::string> cors_origins;  ///< allowed browser origins ("*" for any); none by default
  std::vector<std::string> preload;       ///< meshes loaded at start (their ids are printed)
  bool access_log = true;                 ///< one line per request on stderr
  std::string web_root;                   ///< folder served at / instead of the page built into the binary
  bool embedded_page = true;              ///< serve the built-in page at / when web_root is empty
  /// Where uploads are kept so sessions survive eviction and restarts (server/upload_store.h):
  /// a folder ("dir:PATH" or PATH), "redis://[[USER][:PASSWORD]@]HOST:PORT[/DB]", or empty for
  /// memory only. Never printed as is: redacted_store_url.
  std::string store;
  std::string store_password;             ///< Redis' password when the URL has none (main: kRedisPasswordVariable)
  std::size_t store_max_mb = 0;           ///< directory store: total upload bytes kept (0: no limit)
};

class FeaturelineServer {
 public:
  explicit FeaturelineServer(ServerOptions options);
  ~FeaturelineServer();
  FeaturelineServer(const FeaturelineServer&) = delete;
  FeaturelineServer& operator=(const FeaturelineServer&) = delete;

  /// Binds the socket; returns the port (useful with port 0). \throw std::runtime_error
  int bind();
  /// Serves until stop(). Returns false if listening failed.
  bool run();
  /// Stops accepting and returns from run(); safe from any thread.
  void stop();

  /// Loads a mesh file into the cache as if uploaded; returns its mesh id.
  std::string preload(const std::string& path);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace featureline::server
