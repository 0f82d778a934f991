#include "server/server.h"

// Eigen (through the engine headers) must come before httplib.h: httplib pulls in
// <resolv.h>, whose `_res` macro breaks Eigen's templates.
#include "api/export_formats.h"
#include "api/feature_line_json.h"
#include "api/feature_seeds_json.h"
#include "api/gltf_export.h"
#include "api/json_writer.h"
#include "api/options_table.h"
#include "api/requests.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/segmentation.h"
#include "engine/scratch_memory.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <iostream>
#include <malloc.h>
#include <mutex>

#include "server/byte_account.h"
#include "server/compression.h"
#include "server/content_negotiation.h"
#include "server/engine_jobs.h"
#include "server/http_errors.h"
#include "server/json_body.h"
#include "server/metrics.h"
#include "server/session_cache.h"
#include "server/store_breaker.h"
#include "server/transport.h"
#include "server/upload_body.h"
#include "server/upload_store.h"
#include "server/web_assets.h"
#include "server/work_pool.h"

namespace featureline::server {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

constexpr std::size_t kMaxJsonBytes = RequestLimits::max_json_bytes;
constexpr const char* kMeshesPath = "/v1/meshes";
// The front (deploy/nginx.conf.template) names what it asks of a replica in this header:
// "hand-off" on an upload (store it and hand it back), "uploaded" when it sends that upload on
// to the replica its id belongs to. The front sets or clears it on every request it forwards.
constexpr const char* kFrontHeader = "X-Featureline-Front";
// Where the front takes a handed-off upload back (an internal location of the front's).
constexpr const char* kHandedOffPrefix = "/_featureline/uploaded/";

// The time routing started on this worker thread (set in the pre-routing handler), for the
// access log and the latency metrics.
thread_local Clock::time_point request_start;
thread_local const char* request_route = "unmatched";
// False for a request the library refused before routing (unparseable request line or
// headers): the pre-routing handler never ran, so request_start and request_route are stale.
thread_local bool request_routed = false;

// The method as a metrics label. An unparseable request carries whatever bytes the client sent
// as its method; they must not reach the exposition text (quotes, control bytes) nor add series.
const char* method_label(const std::string& method) {
  for (const char* known : {"GET", "POST", "DELETE", "OPTIONS", "HEAD", "PUT", "PATCH"})
    if (method == known) return known;
  return "other";
}

void write_error(httplib::Response& res, const ErrorReply& error) {
  res.status = error.status;
  for (const auto& [k, v] : error.headers) res.set_header(k, v);
  res.set_content(error.body(), "application/json");
}

void write_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

bool is_upload(std::string_view method, std::string_view path) { return method == "POST" && path == kMeshesPath; }

// The transport's limits from the server's options: bodies are refused before they are read when
// larger than the upload limit (uploads) or the JSON limit (every other route).
TransportLimits transport_limits(const ServerOptions& o, std::function<void(const ErrorReply&)> on_refusal) {
  TransportLimits limits;
  limits.on_refusal = std::move(on_refusal);
  limits.workers = std::max<std::size_t>(2, o.http_threads);
  limits.max_connections = o.max_connections != 0 ? std::max(o.max_connections, limits.workers) : 2 * limits.workers;
  limits.head_timeout_s = o.head_timeout_s;
  limits.io_timeout_s = o.read_timeout_s;
  const std::size_t max_upload = o.max_upload_mb << 20;
  limits.max_body_bytes = [max_upload](std::string_view method, std::string_view path) {
    return is_upload(method, path) ? max_upload : std::size_t(kMaxJsonBytes);
  };
  return limits;
}

// How far an upload may expand (glTF instancing): tied to the upload limit and the cache budget.
ReadMeshOptions upload_read_limits(const ServerOptions& o) {
  ReadMeshOptions limits = read_limits_for(o.max_upload_mb << 20, o.cache_mb << 20);
  if (o.max_triangles != 0) limits.max_triangles = o.max_triangles;
  if (o.max_vertices != 0) limits.max_vertices = o.max_vertices;
  return limits;
}

// All upload bodies being received at once (4 uploads of 200 MB had reached 880 MB of resident
// memory before they were bounded).
std::size_t upload_buffer_bytes(const ServerOptions& o) {
  return o.upload_buffer_mb != 0 ? o.upload_buffer_mb << 20 : 2 * (o.max_upload_mb << 20);
}

// The store's idle clock is restarted at most this often per session: a quarter of the TTL, at
// most a minute. The store keeps uploads this much longer than the cache keeps prepared meshes.
std::chrono::seconds store_touch_interval(const ServerOptions& o) { return std::chrono::seconds(std::clamp(o.ttl_s / 4, 1, 60)); }

// The store behind a circuit breaker (server/store_breaker.h); `breaker` is set to it.
std::unique_ptr<UploadStore> open_store(const ServerOptions& o, StoreBreaker*& breaker) {
  if (o.store.empty()) return nullptr;
  StoreOptions store_options;
  store_options.idle_ttl = std::chrono::seconds(o.ttl_s) + store_touch_interval(o);
  store_options.max_bytes = o.store_max_mb << 20;
  auto guarded = std::make_unique<StoreBreaker>(open_upload_store(o.store, store_options, o.store_password), BreakerOptions{});
  breaker = guarded.get();
  return guarded;
}

std::string utc_time(std::int64_t unix_s) {
  char stamp[32];
  const std::time_t t = unix_s;
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return stamp;
}

}  // namespace

struct FeaturelineServer::Impl {
  ServerOptions options;
  GuardedServer http;
  const ReadMeshOptions read_limits;
  SessionCache cache;
  WorkPool pool;
  StoreBreaker* breaker = nullptr;  // in front of the upload store (owned by sessions); null without one
  DurableSessions sessions;         // the cache in front of the upload store (if any)
  Metrics metrics;
  EngineJobs jobs{pool, metrics, options.deadline_s};
  // Bodies being received or parsed sit outside the cache budget, each kind within its own.
  UploadBodies uploads{options.max_upload_mb << 20, upload_buffer_bytes(options), metrics};
  JsonBodies json_bodies{JsonBodies::budget_for(options.cache_mb << 20), metrics};
  std::atomic<std::uint64_t> uploads_handed_off{0};
  const Clock::time_point started = Clock::now();
  std::mutex log_mutex;
  // Background expiry of idle sessions, so their memory goes even when nobody asks.
  std::thread sweeper;
  std::mutex sweeper_mutex;
  std::condition_variable sweeper_wake;
  bool sweeper_stop = false;

  explicit Impl(ServerOptions o)
      : options(std::move(o)),
        http(transport_limits(options, [this](const ErrorReply& refusal) { record_transport_refusal(refusal); })),
        read_limits(upload_read_limits(options)),
        cache(SessionCache::Options{options.cache_mb << 20, std::chrono::seconds(options.ttl_s), [] { return Clock::now(); },
                                    engine_scratch_bytes}),
        pool(options.engine_threads, options.queue_capacity),
        sessions(cache, open_store(options, breaker), [this](std::shared_ptr<const StoredUpload> upload) { return rebuild(std::move(upload)); },
                 {store_touch_interval(options)}) {
    configure_transport();
    register_routes();
    sweeper = std::thread([this] {
      std::unique_lock<std::mutex> lock(sweeper_mutex);
      while (!sweeper_wake.wait_for(lock, std::chrono::seconds(5), [this] { return sweeper_stop; })) {
        if (!sessions.expire_idle()) log_line("the upload store could not be swept; retrying in 5 s");
        return_freed_memory();
      }
    });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(sweeper_mutex);
      sweeper_stop = true;
    }
    sweeper_wake.notify_all();
    sweeper.join();
    pool.stop();
  }

  // glibc keeps freed heap pages (and per-thread arenas) mapped: after sessions are deleted,
  // expired or evicted, RSS stayed at the peak (234 MB after deleting everything), and after
  // 64 concurrent 4 MiB JSON bodies 266 MB stayed held. malloc_trim hands them back; it runs on
  // the sweeper, only after the cache shrank or request bodies had held more than they do now.
  std::size_t bytes_at_last_trim = 0;
  void return_freed_memory() {
    const std::size_t bytes = cache.stats().bytes;
    const std::size_t bodies_peak = json_bodies.memory().take_peak() + uploads.buffer().take_peak();
    const std::size_t bodies_now = json_bodies.memory().used() + uploads.buffer().used();
    constexpr std::size_t kWorthTrimming = std::size_t(16) << 20;
    if (bytes < bytes_at_last_trim || bodies_peak > bodies_now + kWorthTrimming) malloc_trim(0);
    bytes_at_last_trim = bytes;
  }

  // ---- transport ----------------------------------------------------------------------
  void configure_transport() {
    // Connection workers, their bounded queue, keep-alive, timeouts, header and body limits are
    // GuardedServer's (server/transport.h); httplib's own settings for them are not used.
    // Headers and body go out in separate writes: without TCP_NODELAY, Nagle's algorithm
    // holds the body until the client's delayed ACK (about 40 ms per response, measured).
    http.set_tcp_nodelay(true);
    // httplib's default also sets SO_REUSEPORT, which lets a second server bind a port in use
    // and share its connections; SO_REUSEADDR alone still allows a restart over TIME_WAIT.
    http.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, reinterpret_cast<const void*>(&yes), sizeof yes);
    });
    // Only for the Keep-Alive header httplib writes: the transport applies these itself.
    http.set_keep_alive_max_count(http.limits().keep_alive_max_requests);
    http.set_keep_alive_timeout(std::time_t(http.limits().idle_timeout_s));
    // A safety net only: the transport refuses larger bodies before they are read.
    http.set_payload_max_length((options.max_upload_mb << 20) + 1);
    http.set_expect_100_continue_handler([this](const httplib::Request& req, httplib::Response& res) {
      return expect_continue(req, res);
    });

    http.set_pre_routing_handler([](const httplib::Request&, httplib::Response&) {
      request_start = Clock::now();
      request_route = "unmatched";
      request_routed = true;
      return httplib::Server::HandlerResponse::Unhandled;
    });
    // Errors the library produces itself (unknown route, oversized body) get our JSON shape.
    http.set_error_handler([](const httplib::Request&, httplib::Response& res) {
      if (res.body.empty() && !res.has_header("Content-Type")) write_error(res, error_reply_for_status(res.status));
    });
    // Never let exception text reach a response header (EXCEPTION_WHAT).
    http.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr error) {
      write_error(res, error_reply(error));
    });
    http.set_post_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      add_cors(req, res);
      // The connection closes after this answer: say so, or a keep-alive client's next request fails.
      if (http.stopping() && res.get_header_value("Connection") != "close") res.set_header("Connection", "close");
      if (res.get_header_value("Connection") == "close") res.headers.erase("Keep-Alive");
      // Answers are always whole (Range is ignored): advertise no byte ranges (httplib adds it to HEAD).
      res.headers.erase("Accept-Ranges");
    });
    http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
      const bool routed = request_routed;
      request_routed = false;
      const double seconds = routed ? std::chrono::duration<double>(Clock::now() - request_start).count() : 0.0;
      metrics.record_request(routed ? request_route : "unmatched", method_label(req.method), res.status, seconds);
      if (!options.access_log) return;
      char stamp[32];
      const std::time_t now = std::time(nullptr);
      std::tm tm{};
      gmtime_r(&now, &tm);
      std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
      std::lock_guard<std::mutex> lock(log_mutex);
      std::fprintf(stderr, "%s %s %s %s %d %zu %.2fms\n", stamp, req.remote_addr.c_str(), req.method.c_str(),
                   req.path.c_str(), res.status, res.body.size(), seconds * 1000);
    });
  }

  // Requests the transport refused before httplib saw them: counted and logged like the others.
  void record_transport_refusal(const ErrorReply& refusal) {
    metrics.record_rejected(refusal.code);
    metrics.record_request("unmatched", "other", refusal.status, 0.0);
    if (!options.access_log) return;
    std::lock_guard<std::mutex> lock(log_mutex);
    std::fprintf(stderr, "refused by the transport: %d %s\n", refusal.status, refusal.code.c_str());
  }

  bool origin_allowed(const std::string& origin) const {
    for (const auto& allowed : options.cors_origins)
      if (allowed == "*" || allowed == origin) return true;
    return false;
  }

  void add_cors(const httplib::Request& req, httplib::Response& res) const {
    const std::string origin = req.get_header_value("Origin");
    if (origin.empty() || !origin_allowed(origin)) return;
    res.set_header("Access-Control-Allow-Origin", origin);
    res.set_header("Vary", "Origin");
    res.set_header("Access-Control-Expose-Headers", "Location, Retry-After");
  }

  // ---- helpers shared by handlers -------------------------------------------------------
  // A session from the cache, or rebuilt from the upload store (a 503 when the store is down).
  std::shared_ptr<const MeshSession> session_or_404(const std::string& id) {
    auto found = sessions.find(id);
    if (!found.session) throw not_found(id, found.why);
    return found.session;
  }

  // The 404 says which: never issued, deleted, expired or (memory only) evicted.
  HttpError not_found(const std::string& id, DurableSessions::Gone why) const {
    const std::string mesh = "mesh " + quote_client_text(id);
    switch (why) {
      case DurableSessions::Gone::deleted: return HttpError(404, "not_found", mesh + " was deleted");
      case DurableSessions::Gone::expired:
        return HttpError(404, "not_found", mesh + " expired after " + std::to_string(options.ttl_s) + " s without use; upload it again");
      case DurableSessions::Gone::evicted:
        return HttpError(404, "not_found", mesh + " was evicted to make room for newer uploads; upload it again");
      case DurableSessions::Gone::lost:
        return HttpError(404, "not_found", mesh + " was lost by the upload store, which lost its data at " + last_store_loss() +
                                               " (restarted empty?); upload it again");
      case DurableSessions::Gone::unknown_after_loss:
        return HttpError(404, "not_found", "no mesh with id " + quote_client_text(id) + "; the upload store lost its data at " +
                                               last_store_loss() + " (restarted empty?): a mesh uploaded before then must be uploaded again");
      default: return HttpError(404, "not_found", "no mesh with id " + quote_client_text(id));
    }
  }

  std::string last_store_loss() const { return utc_time(sessions.store_losses().last_unix_s); }

  // Readiness: whether this replica should get traffic. Not ready (503 storage_unavailable) while
  // the store's breaker is open or the store does not answer a probe: a replica without its store
  // can neither take uploads nor rebuild sessions. The body says when the store lost its data.
  json readiness() {
    json ready = {{"status", "ready"}, {"store", nullptr}, {"store_data_losses", 0}, {"store_last_data_loss", nullptr}};
    if (!breaker) return ready;
    ready["store"] = breaker->describe();
    if (breaker->open()) throw StoreUnavailableError("not ready: " + breaker->open_reason() + "; the breaker is open until it answers");
    breaker->probe();  // throws StoreUnavailableError: not ready
    const StoreLosses losses = sessions.store_losses();
    ready["store_data_losses"] = losses.count;
    if (losses.count > 0) ready["store_last_data_loss"] = utc_time(losses.last_unix_s);
    return ready;
  }

  // Prepares a stored upload again after a cache miss (eviction, restart, another replica's id).
  MeshSession rebuild(std::shared_ptr<const StoredUpload> upload) {
    return jobs.prepare(std::move(upload), read_limits);
  }

  void log_line(const std::string& text) {
    std::lock_guard<std::mutex> lock(log_mutex);
    std::fprintf(stderr, "featureline-server: %s\n", text.c_str());
  }

  json describe(const MeshSession& s) const {
    json j = mesh_info_to_json(*s.mesh, s.load_ms);
    j["mesh_id"] = s.id;
    j["format"] = to_string(s.format);
    const double expires = cache.expires_in_s(s.id);
    j["expires_in_s"] = expires < 0 ? json(nullptr) : json(expires);  // null: preloaded, never expires
    return j;
  }

  // Wraps a handler: the route's name for metrics, and every error through error_reply.
  template <typename Handler>
  auto guarded(const char* route, Handler handler) {
    return [route, handler](const httplib::Request& req, httplib::Response& res) {
      request_route = route;
      try {
        handler(req, res);
      } catch (...) {
        write_error(res, error_reply(std::current_exception()));
      }
    };
  }

  // What /metrics reports at scrape time beside the request counts.
  std::map<std::string, std::pair<std::string, double>> gauges() {
    const auto s = cache.stats();
    return {
        {"featureline_cache_entries", {"Prepared meshes in the session cache.", double(s.entries)}},
        {"featureline_cache_bytes", {"Bytes held by the session cache.", double(s.bytes)}},
        {"featureline_cache_budget_bytes", {"Byte budget of the session cache.", double(options.cache_mb << 20)}},
        {"featureline_engine_scratch_bytes",
         {"Per-thread engine scratch kept between requests; counts in the cache's budget.", double(engine_scratch_bytes())}},
        {"featureline_cache_evictions_total", {"Sessions evicted to stay within the budget.", double(s.evictions)}},
        {"featureline_cache_expirations_total", {"Sessions expired after their idle time.", double(s.expirations)}},
        {"featureline_cache_inserts_total", {"Meshes uploaded and prepared.", double(s.inserts)}},
        {"featureline_store_rebuilds_total", {"Sessions prepared again from the upload store after a cache miss.",
                                              double(sessions.rebuilds())}},
        {"featureline_uploads_handed_off_total", {"Uploads stored and handed back to the front for the replica their id belongs to.",
                                                  double(uploads_handed_off.load())}},
        {"featureline_uploads_taken_over_total", {"Uploads handed off by another replica and prepared here.",
                                                  double(sessions.handoffs())}},
        {"featureline_store_bytes", {"Upload bytes held by a directory store.",
                                     double(sessions.store() ? sessions.store()->bytes() : 0)}},
        {"featureline_store_breaker_open", {"1 while the upload store's circuit breaker is open (operations fail at once).",
                                            breaker && breaker->open() ? 1.0 : 0.0}},
        {"featureline_store_breaker_openings_total", {"Times the upload store's circuit breaker opened after consecutive timeouts.",
                                                      double(breaker ? breaker->openings() : 0)}},
        {"featureline_store_data_losses_total", {"Times the upload store was found to have lost its data (Redis restarted empty).",
                                                 double(sessions.store_losses().count)}},
        {"featureline_pool_queue_depth", {"Engine jobs waiting for a thread.", double(pool.queue_depth())}},
        {"featureline_pool_running", {"Engine jobs running.", double(pool.running())}},
        {"featureline_pool_threads", {"Engine threads.", double(pool.threads())}},
        {"featureline_pool_queue_capacity", {"Engine jobs that may wait before requests are refused.", double(pool.capacity())}},
        {"featureline_uptime_seconds", {"Seconds since the server started.",
                                        std::chrono::duration<double>(Clock::now() - started).count()}},
    };
  }

  // Wraps a handler of a route with a body, as guarded does. A body left unread closes the
  // connection (the transport does), so the answer says so.
  template <typename Handler>
  auto guarded_with_body(const char* route, Handler handler) {
    return [route, handler](const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader) {
      request_route = route;
      bool body_read = false;
      try {
        handler(req, res, reader, body_read);
      } catch (...) {
        write_error(res, error_reply(std::current_exception()));
        if (!body_read) res.set_header("Connection", "close");
      }
    };
  }

  // A route with a JSON body, read by bytes received within RequestLimits::max_json_bytes and
  // the budget shared by every JSON body before the handler runs.
  template <typename Handler>
  auto with_json_body(const char* route, Handler handler) {
    return guarded_with_body(route, [this, handler](const auto& req, auto& res, const auto& reader, bool& body_read) {
      JsonBody body(json_bodies.memory());
      json_bodies.read(reader, body);
      body_read = true;
      handler(req, body, res);
    });
  }

  // ---- routes (the one table) -------------------------------------------------------------
  void register_routes() {
    const std::string mesh = std::string(kMeshesPath) + "/([^/]+)";
    http.Post(served("POST", kMeshesPath), guarded_with_body(kMeshesPath, [this](const auto& req, auto& res, const auto& reader, bool& body_read) {
      upload(req, res, reader, body_read);
    }));
    http.Get(served("GET", mesh), guarded("/v1/meshes/{id}", [this](const auto& req, auto& res) {
      if (req.get_header_value(kFrontHeader) == "uploaded") return prepare_handed_off(req.matches[1], res);
      write_json(res, 200, describe(*session_or_404(req.matches[1])));
    }));
    http.Delete(served("DELETE", mesh), guarded("/v1/meshes/{id}", [this](const auto& req, auto& res) {
      auto why = DurableSessions::Gone::unknown;
      if (!sessions.erase(req.matches[1], &why)) throw not_found(req.matches[1], why);
      res.status = 204;
    }));
    http.Get(served("GET", mesh + "/mesh\\.glb"), guarded("/v1/meshes/{id}/mesh.glb", [this](const auto& req, auto& res) {
      auto session = session_or_404(req.matches[1]);
      const bool compact = compact_glb_requested(req);
      std::string glb = jobs.run([session, compact](const Cancellation*) {
        return compact ? prepared_mesh_to_compact_glb(*session->mesh) : feature_line_to_glb(*session->mesh, {}, true);
      });
      res.set_header("Cache-Control", "private, max-age=3600");
      // The page's largest download: gzip when accepted (httplib compresses no model/* type).
      set_content_gzip_if_accepted(req, res, std::move(glb), export_format_info(ExportFormat::glb).mime_type);
    }));
    http.Get(served("GET", mesh + "/features"), guarded("/v1/meshes/{id}/features", [this](const auto& req, auto& res) {
      // Crease chains and ridge/valley vertices to pick keys from; options as query parameters.
      auto session = session_or_404(req.matches[1]);
      const FeatureSeedOptions seed_options = parse_feature_seed_query({req.params.begin(), req.params.end()});
      write_json(res, 200, jobs.run([session, seed_options](const Cancellation* cancel) {
        return feature_seeds_to_json(*session->mesh, find_feature_seeds(*session->mesh, seed_options, cancel));
      }));
    }));
    http.Get(served("GET", mesh + "/curvature"), guarded("/v1/meshes/{id}/curvature", [this](const auto& req, auto& res) {
      curvature(req, res);
    }));
    http.Post(served("POST", mesh + "/feature-lines"), with_json_body("/v1/meshes/{id}/feature-lines", [this](const auto& req, JsonBody& body, auto& res) {
      feature_lines(req, body, res);
    }));
    http.Post(served("POST", mesh + "/segmentation"), with_json_body("/v1/meshes/{id}/segmentation", [this](const auto& req, JsonBody& body, auto& res) {
      segmentation(req, body, res);
    }));
    http.Get(served("GET", "/v1/options"), guarded("/v1/options", [](const auto&, auto& res) {
      // Every option with its type, default, limits and description (the page's inputs use it).
      static const std::string description = describe_api_options().dump();
      res.set_header("Cache-Control", "public, max-age=3600");
      res.set_content(description, "application/json");
    }));
    http.Get(served("GET", "/healthz"), guarded("/healthz", [this](const auto&, auto& res) {
      write_json(res, 200,
                 {{"status", "ok"},
                  {"meshes", cache.stats().entries},
                  {"uptime_s", std::chrono::duration<double>(Clock::now() - started).count()}});
    }));
    http.Get(served("GET", "/readyz"), guarded("/readyz", [this](const auto&, auto& res) { write_json(res, 200, readiness()); }));
    http.Get(served("GET", "/metrics"), guarded("/metrics", [this](const auto&, auto& res) {
      res.set_content(metrics.render(gauges()), "text/plain; version=0.0.4");
    }));
    http.Options(".*", guarded("OPTIONS", [this](const auto& req, auto& res) {
      // CORS preflight: allowed origins get the methods and headers they may use.
      res.status = 204;
      if (origin_allowed(req.get_header_value("Origin"))) {
        res.set_header("Access-Control-Allow-Methods", "GET, POST, DELETE, OPTIONS");
        res.set_header("Access-Control-Allow-Headers", "Content-Type, Accept");
        res.set_header("Access-Control-Max-Age", "600");
      }
    }));
    refuse_unserved_methods();
    register_page();
  }

  // The methods each route pattern serves, as registered (served()); refuse_unserved_methods
  // answers the others.
  std::vector<std::pair<std::string, std::vector<std::string>>> route_methods;

  std::string served(const char* method, const std::string& pattern) {
    auto it = std::find_if(route_methods.begin(), route_methods.end(), [&](const auto& r) { return r.first == pattern; });
    if (it == route_methods.end()) it = route_methods.insert(route_methods.end(), {pattern, {}});
    it->second.push_back(method);
    return pattern;
  }

  // A method a route does not serve is 405 with the methods it does in Allow (RFC 9110 15.5.6),
  // so a client can tell a wrong method from a missing mesh or a mistyped path. HEAD comes with
  // GET, and OPTIONS (CORS preflight) is served everywhere. Registered before the page's
  // catch-all GET, which would otherwise answer a GET of a POST route with 404.
  void refuse_unserved_methods() {
    for (const auto& [pattern, methods] : route_methods) {
      std::string allow;
      for (const auto& m : methods) allow += (allow.empty() ? "" : ", ") + m + (m == "GET" ? ", HEAD" : "");
      allow += ", OPTIONS";
      auto refusal = [allow](const httplib::Request& req) {
        return HttpError(405, "method_not_allowed", req.method + " is not served here; this route serves " + allow,
                         {{"Allow", allow}});
      };
      auto refuse = guarded("method not allowed", [refusal](const auto& req, auto&) { throw refusal(req); });
      // A body sent with a refused method is never read (the connection closes instead).
      auto refuse_body = guarded_with_body("method not allowed",
                                           [refusal](const auto& req, auto&, const auto&, bool&) { throw refusal(req); });
      auto has = [&](const char* m) { return std::find(methods.begin(), methods.end(), m) != methods.end(); };
      if (!has("GET")) http.Get(pattern, refuse);
      if (!has("POST")) http.Post(pattern, refuse_body);
      if (!has("PUT")) http.Put(pattern, refuse_body);
      if (!has("PATCH")) http.Patch(pattern, refuse_body);
      if (!has("DELETE")) http.Delete(pattern, refuse);
    }
  }

  // The page: a folder given with --web-root, else the copy compiled into the binary.
  void register_page() {
    if (!options.web_root.empty()) {
      if (!http.set_mount_point("/", options.web_root, {{"Cache-Control", kWebCacheControl}}))
        throw std::runtime_error("cannot serve the web page folder " + options.web_root);
      http.set_file_request_handler([](const auto& req, auto& res) { revalidate_folder_file(req, res); });
    } else if (options.embedded_page) {
      http.Get("/(.*)", guarded("/{page}", [](const auto& req, auto& res) { serve_embedded_page(req, res); }));
    }
  }

  static void serve_embedded_page(const httplib::Request& req, httplib::Response& res) {
    const WebAsset* asset = find_web_asset(req.path);
    if (asset == nullptr) throw HttpError(404, "not_found", "nothing at " + quote_client_text(req.path));
    res.set_header("ETag", std::string(asset->etag));
    // Revalidated on every load (the next build of the page must show at once); 304 when unchanged.
    res.set_header("Cache-Control", kWebCacheControl);
    if (etag_matches(req.get_header_value("If-None-Match"), asset->etag)) {
      res.status = 304;
      return;
    }
    res.set_content(asset->bytes.data(), asset->bytes.size(), web_content_type(asset->path));
  }

  // A file of the --web-root folder, read by httplib: its ETag, and 304 without the body when
  // the browser already has these bytes.
  static void revalidate_folder_file(const httplib::Request& req, httplib::Response& res) {
    const std::string etag = content_etag(res.body);
    res.set_header("ETag", etag);
    if (!etag_matches(req.get_header_value("If-None-Match"), etag)) return;
    res.status = 304;
    res.body.clear();
  }

  // ---- handlers ----------------------------------------------------------------------------
  // Expect: 100-continue: an upload that will be refused gets its refusal instead of 100 Continue
  // (the client then never sends the body, and the transport closes the connection).
  int expect_continue(const httplib::Request& req, httplib::Response& res) {
    if (!is_upload(req.method, req.path)) return 100;
    try {
      uploads.check_head(req);
      return 100;
    } catch (...) {
      write_error(res, error_reply(std::current_exception()));
      res.set_header("Connection", "close");  // the transport closes: the body was never read
      return res.status;
    }
  }

  void upload(const httplib::Request& req, httplib::Response& res, const httplib::ContentReader& reader, bool& body_read) {
    // The head is checked before the body is read. Whatever is refused, a body left unread ends
    // the connection (server/transport.cpp), so its bytes are never parsed as a next request.
    const UploadHead head = uploads.check_head(req);
    ByteHold held(uploads.buffer());
    const std::shared_ptr<StoredUpload> upload = uploads.read(head, reader, held, body_read);
    if (hand_off_requested(req)) return hand_off(*upload, res);

    MeshSession session = jobs.prepare(upload, read_limits);
    const std::size_t needed = session.bytes;
    auto stored = sessions.create(std::move(session), *upload);  // a full or unreachable store: 503, nothing kept
    if (!stored)
      throw HttpError(413, "payload_too_large",
                      "the prepared mesh needs " + std::to_string(needed >> 20) + " MiB, more than the cache's whole budget of " +
                          std::to_string(options.cache_mb) + " MiB");
    res.set_header("Location", std::string(kMeshesPath) + "/" + (*stored)->id);
    write_json(res, 201, describe(**stored));
  }

  // Behind the front, an upload is stored here under a fresh id and handed back to the front,
  // which sends it on to the replica that id hashes to: the mesh is prepared once, where its
  // lines will be asked for, instead of here and again there. Only with a shared store (the
  // owner reads the upload from it); a replica without one prepares the upload itself.
  bool hand_off_requested(const httplib::Request& req) const {
    return req.get_header_value(kFrontHeader) == "hand-off" && sessions.store() != nullptr && sessions.store()->shared();
  }

  void hand_off(const StoredUpload& upload, httplib::Response& res) {
    const std::string id = sessions.stash(upload);
    ++uploads_handed_off;
    res.status = 200;
    res.set_header("X-Accel-Redirect", kHandedOffPrefix + id);
  }

  // The owner's half of a handed-off upload: prepared from the store and answered as the upload
  // (201 and its description). An upload that cannot be prepared is removed from the store, and
  // the error is the one a direct upload gets.
  void prepare_handed_off(const std::string& id, httplib::Response& res) {
    DurableSessions::Found found;
    try {
      found = sessions.find_stashed(id);
    } catch (const CacheTooSmallError& e) {
      discard_handed_off(id);
      throw HttpError(413, "payload_too_large", "the mesh cannot be prepared within this server's memory: " + e.reason());
    } catch (...) {
      discard_handed_off(id);
      throw;
    }
    if (!found.session)
      throw StoreUnavailableError("the upload store lost the upload " + quote_client_text(id) + " before it was prepared; upload it again");
    res.set_header("Location", std::string(kMeshesPath) + "/" + found.session->id);
    write_json(res, 201, describe(*found.session));
  }

  void discard_handed_off(const std::string& id) {
    try {
      DurableSessions::Gone why;
      sessions.erase(id, &why);
    } catch (...) {
      log_line("a handed-off upload that could not be prepared could not be removed from the store; it expires unused");
    }
  }

  void curvature(const httplib::Request& req, httplib::Response& res) {
    auto session = session_or_404(req.matches[1]);
    // The field the engine reads (engine/curvature.h), not the one-ring mean curvature H: on a
    // noisy scan H is mostly noise, and the page snaps keys to this field's extremes.
    const auto h = dominant_curvatures(session->mesh->curvature());
    if (accepts(req, kOctetStream)) {
      static_assert(sizeof(float) == sizeof(std::uint32_t), "float32 output");
      std::string bytes(h.size() * sizeof(float), '\0');
      for (std::size_t i = 0; i < h.size(); ++i) {
        const float f = float(h[i]);
        std::uint32_t bits;
        std::memcpy(&bits, &f, sizeof bits);
        for (std::size_t b = 0; b < sizeof bits; ++b) bytes[sizeof bits * i + b] = char((bits >> (8 * b)) & 0xFF);  // little-endian
      }
      res.set_content(std::move(bytes), kOctetStream);
      return;
    }
    write_json(res, 200, {{"vertices", h.size()}, {"curvature", h}});
  }

  void segmentation(const httplib::Request& req, JsonBody& request_body, httplib::Response& res) {
    auto session = session_or_404(req.matches[1]);
    const ExportFormat format = answer_format(req, ExportContent::segmentation);
    SegmentationRequest request = parse_segmentation_request(json_bodies.parse(req, request_body), *session->mesh);
    const SegmentationOptions segmentation_options = request.options;
    // Items are line requests (detected here) or lines the client already has (computed once).
    std::vector<FeatureLineResult> detected;
    if (!request.requests.empty()) detected = jobs.run_lines(session, request.requests);
    const auto results = std::move(request).lines_with(std::move(detected));
    const SegmentationResult segments = jobs.run([session, results, segmentation_options](const Cancellation* cancel) {
      return segment_mesh(*session->mesh, results, segmentation_options, cancel);
    });
    const char* type = export_format_info(format).mime_type;
    if (format == ExportFormat::json) write_json(res, 200, segmentation_to_json(segments, segmentation_options.mode));
    else if (format == ExportFormat::glb) res.set_content(segmentation_to_glb(*session->mesh, segments), type);
    else res.set_content(export_segmentation(*session->mesh, segments, format), type);
  }

  void feature_lines(const httplib::Request& req, JsonBody& request_body, httplib::Response& res) {
    auto session = session_or_404(req.matches[1]);
    const ExportFormat answer = answer_format(req, ExportContent::lines);
    bool batch = false;
    const std::vector<FeatureLineRequest> lines = parse_feature_line_body(json_bodies.parse(req, request_body), *session->mesh, batch);
    request_body.release();  // the keys are all a line needs from here on
    BatchTiming timing;
    const std::vector<FeatureLineResult> results = jobs.run_lines(session, lines, &timing);
    char server_timing[96];
    std::snprintf(server_timing, sizeof server_timing, "queue;dur=%.3f, engine;dur=%.3f", timing.queue_ms, timing.engine_ms);
    res.set_header("Server-Timing", server_timing);
    const char* type = export_format_info(answer).mime_type;
    if (answer == ExportFormat::glb) {
      res.set_content(feature_line_to_glb(*session->mesh, results, false), type);
    } else if (answer == ExportFormat::gltf) {
      res.set_content(feature_line_to_gltf_json(*session->mesh, results, false), type);
    } else if (answer != ExportFormat::json) {
      res.set_content(export_lines(results, answer), type);
    } else if (batch) {
      JsonWriter answer_text;
      answer_text.begin_object().key("lines").begin_array();
      for (const auto& r : results) answer_text.raw(feature_line_json_text(r));
      res.set_content(answer_text.end_array().end_object().take(), type);
    } else {
      res.set_content(feature_line_json_text(results[0]), type);
    }
  }
};

namespace {
// glibc raises its mmap threshold after each large free (up to 32 MiB) and its trim threshold
// with it (to 64 MiB), so request buffers of a few MiB came back as heap memory that neither
// free nor malloc_trim returned: after 64 concurrent 4 MiB bodies the server stayed at 241 MB
// (31 MB with these settings), and 243 MB after every session was deleted (46 MB). Fixed
// thresholds keep buffers above 1 MiB in their own mappings, returned at free; bench_server's
// lines/s did not change measurably.
void return_large_frees_to_the_system() {
  static std::once_flag once;
  std::call_once(once, [] {
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
    mallopt(M_TRIM_THRESHOLD, 8 << 20);
  });
}
}  // namespace

FeaturelineServer::FeaturelineServer(ServerOptions options)
    : impl_((return_large_frees_to_the_system(), std::make_unique<Impl>(std::move(options)))) {}
FeaturelineServer::~FeaturelineServer() = default;

int FeaturelineServer::bind() {
  const auto& o = impl_->options;
  int port = o.port;
  errno = 0;
  if (port == 0) port = impl_->http.bind_to_any_port(o.host);
  else if (!impl_->http.bind_to_port(o.host, port)) port = -1;
  if (port <= 0) {
    const std::string reason = errno == EADDRINUSE ? ": the port is already in use (--port picks another)"
                               : errno != 0        ? std::string(": ") + std::strerror(errno)
                                                   : "";
    throw std::runtime_error("cannot listen on " + o.host + ":" + std::to_string(o.port) + reason);
  }
  impl_->http.widen_backlog();
  return port;
}

bool FeaturelineServer::run() { return impl_->http.listen_after_bind(); }

void FeaturelineServer::stop() { impl_->http.stop_gracefully(); }

std::string FeaturelineServer::preload(const std::string& path) {
  // Stored like an upload, so the printed id answers through a data dir or Redis store too
  // (and after a restart, until the store expires it).
  MeshFile file = read_mesh_file_bytes(path, impl_->read_limits);
  StoredUpload upload;
  upload.bytes = std::move(file.bytes);
  upload.format = file.format;
  upload.uploaded_at_unix_s = std::int64_t(std::time(nullptr));
  MeshSession s = prepare_session(upload.bytes, upload.format, impl_->read_limits, nullptr, impl_->pool);
  s.pinned = true;  // the bundled sample stays available however long the server runs
  auto stored = impl_->sessions.create(std::move(s), upload);
  if (!stored) throw std::runtime_error(path + " is larger than the whole cache budget");
  return (*stored)->id;
}

}  // namespace featureline::server
