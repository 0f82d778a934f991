// The connection layer under cpp-httplib 0.11.4, which parses HTTP but does not defend itself:
// per read timeouts only, no limit on header size or count, an unbounded worker queue, a listen
// backlog of 5, no way to close after a refusal (see ../shared/docs/dependency-pitfalls.md).
//
// GuardedServer keeps httplib's request parsing, routing and response writing (its protected
// process_request) and replaces what happens around it, per connection:
//  - a bounded connection pool: beyond `max_connections` (being served + waiting for a worker) a
//    new connection gets an immediate 503 instead of waiting in an unbounded queue;
//  - the request head (request line and headers) is read here first, within a deadline counted
//    from its first byte and within size and line-count limits (408 / 431), then checked
//    (check_request_head) before httplib sees a byte of it;
//  - a body must arrive within a deadline that grows with its declared length; a body the
//    handler did not read ends the connection, so its bytes can never become a next request;
//  - every wait is sliced, so stop() never waits for a slow client, and responses written while
//    stopping say "Connection: close".
#pragma once

#include <httplib.h>

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "server/http_errors.h"

namespace featureline::server {

struct TransportLimits {
  std::size_t workers = 64;            ///< connection threads (each connection holds one while open)
  std::size_t max_connections = 128;   ///< served + waiting for a worker; beyond: immediate 503
  int listen_backlog = 1024;           ///< kernel queue of connections not yet accepted (httplib: 5)
  std::size_t max_head_bytes = 64 << 10;  ///< request line + headers; beyond: 431
  std::size_t max_header_lines = 100;     ///< header fields; beyond: 431
  double head_timeout_s = 10;   ///< from the first byte of a request to the end of its head; beyond: 408
  double idle_timeout_s = 5;    ///< keep-alive wait for the next request
  double io_timeout_s = 5;      ///< longest wait for any single read or write
  /// A body must arrive within head_timeout_s + length / this rate (a slow sender is cut off).
  double min_body_bytes_per_s = 256 << 10;
  std::size_t keep_alive_max_requests = 1000;  ///< requests per connection
  /// Largest body accepted for a request (method, path without query); larger: 413 before reading.
  std::function<std::size_t(std::string_view method, std::string_view path)> max_body_bytes;
  /// Told about every request the transport refuses itself (metrics, access log).
  std::function<void(const ErrorReply&)> on_refusal;
};

/// What the transport decides about a complete request head (request line, headers, blank line).
struct HeadCheck {
  std::optional<ErrorReply> refusal;  ///< set: answer this and close
  std::size_t content_length = 0;     ///< the declared body length (0 without one)
  std::string forwarded_head;         ///< the head as httplib gets it (Range fields removed)
};

/// Checks a head: header line count, a single valid Content-Length within max_body_bytes, no
/// Transfer-Encoding (411) and no Content-Encoding (415), since httplib would decode those
/// without any size limit. Range fields are dropped: every answer is whole (RFC 9110 lets a
/// server ignore Range), and httplib answered unsatisfiable ranges with an empty 416.
HeadCheck check_request_head(std::string_view head, const TransportLimits& limits);

/// The raw bytes of a complete error response that closes the connection.
std::string refusal_response(const ErrorReply& reply);

class ConnectionQueue;

class GuardedServer : public httplib::Server {
 public:
  explicit GuardedServer(TransportLimits limits);
  ~GuardedServer() override;

  /// Call after bind: raises the listen backlog from httplib's 5 to limits.listen_backlog.
  void widen_backlog();
  /// Stops accepting; open connections finish their current request and close.
  void stop_gracefully();
  bool stopping() const { return stopping_.load(); }
  const TransportLimits& limits() const { return limits_; }

 private:
  class Connection;
  bool process_and_close_socket(socket_t sock) override;
  /// Serves requests until the connection ends; true when it must close gently (unread bytes).
  bool serve(Connection& connection);
  bool answer_refusal(Connection& connection, const ErrorReply& refusal);
  void refuse_and_close(socket_t sock, const ErrorReply& reply);

  TransportLimits limits_;
  std::shared_ptr<ConnectionQueue> queue_;
  std::atomic<bool> stopping_{false};
};

}  // namespace featureline::server
