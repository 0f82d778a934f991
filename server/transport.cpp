#include "server/transport.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

namespace featureline::server {
namespace {

using Clock = std::chrono::steady_clock;

// Waits are cut into slices this long so that a stopping server never waits on a client.
constexpr std::chrono::milliseconds kWaitSlice{50};

Clock::time_point after_seconds(double seconds) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

const char* reason_phrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 408: return "Request Timeout";
    case 411: return "Length Required";
    case 413: return "Payload Too Large";
    case 415: return "Unsupported Media Type";
    case 431: return "Request Header Fields Too Large";
    case 503: return "Service Unavailable";
    default: return "Error";
  }
}

ErrorReply reply(int status, const char* code, std::string message,
                 std::vector<std::pair<std::string, std::string>> headers = {}) {
  return ErrorReply{status, code, std::move(message), std::move(headers)};
}

// True when the connection was refused by ConnectionQueue: httplib's accept loop then runs the
// connection's job on its own thread, which only writes the 503 and closes.
thread_local bool refusing_connection = false;

// Sends what fits without blocking, then closes: used on the accept thread, which must not wait.
void send_and_close_now(int sock, const std::string& bytes) {
  (void)::send(sock, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(sock, SHUT_WR);
  // Closing with unread bytes resets the connection, which can destroy the answer in flight:
  // discard what the client already sent (without waiting for more).
  char sink[4096];
  for (int i = 0; i < 16 && ::recv(sock, sink, sizeof sink, MSG_DONTWAIT) > 0; ++i) {
  }
  ::close(sock);
}

// After a refusal the client may still be sending: closing with unread bytes would reset the
// connection and could destroy the answer before the client reads it. So half-close, discard
// what still arrives for a short while, then close (what nginx calls a lingering close). When
// the rest of a declared body is known (`unread`), all of it is awaited, up to a bound: a 4 MiB
// JSON body refused after its first chunk still has most of its bytes on the way, and closing
// before they arrive lost the refusal for about one client in a hundred under load.
constexpr std::size_t kLingerMaxBytes = std::size_t(16) << 20;
void lingering_close(int sock, std::size_t unread) {
  ::shutdown(sock, SHUT_WR);
  const bool known = unread > 0;
  const std::size_t limit = known ? std::min(unread, kLingerMaxBytes) : std::size_t(1) << 20;
  const auto deadline = Clock::now() + std::chrono::seconds(known ? 3 : 1);
  std::size_t discarded = 0;
  char sink[16384];
  while (discarded < limit) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    pollfd p{sock, POLLIN, 0};
    if (::poll(&p, 1, int(left)) <= 0) break;
    const ssize_t n = ::recv(sock, sink, std::min(sizeof sink, limit - discarded), 0);
    if (n <= 0) break;
    discarded += std::size_t(n);
  }
  ::close(sock);
}

}  // namespace

// ---- the head check ---------------------------------------------------------------------

namespace {

// One header field: a refusal, or nothing (the field is then kept, or dropped when `forward` is
// set false). Records the Content-Length in `check`.
std::optional<ErrorReply> check_header_field(std::string_view line, HeadCheck& check, std::size_t& content_lengths,
                                             bool& forward) {
  if (line.front() == ' ' || line.front() == '\t') return reply(400, "invalid_request", "folded header lines are not accepted");
  const std::size_t colon = line.find(':');
  const std::string name = lower(trim(line.substr(0, colon)));
  const std::string_view value = colon == std::string_view::npos ? std::string_view() : trim(line.substr(colon + 1));
  if (name == "content-length") {
    if (++content_lengths > 1) return reply(400, "invalid_request", "the request has more than one Content-Length header");
    if (value.empty() || value.size() > 18 || value.find_first_not_of("0123456789") != std::string_view::npos)
      return reply(400, "invalid_request", "Content-Length is not a number");
    check.content_length = std::stoull(std::string(value));
  } else if (name == "transfer-encoding") {
    // httplib decodes chunked bodies without any size limit.
    return reply(411, "length_required", "bodies with a Transfer-Encoding (chunked) are not accepted: send a Content-Length");
  } else if (name == "content-encoding" && lower(value) != "identity") {
    // httplib would decompress without a size limit (a zip bomb).
    return reply(415, "unsupported_format", "compressed bodies (Content-Encoding: " + quote_client_text(value) + ") are not accepted");
  } else if (name == "range") {
    forward = false;  // every answer is whole
  }
  return std::nullopt;
}

}  // namespace

HeadCheck check_request_head(std::string_view head, const TransportLimits& limits) {
  HeadCheck check;
  if (head.size() > limits.max_head_bytes) {
    check.refusal = reply(431, "headers_too_large", "the request head exceeds " + std::to_string(limits.max_head_bytes) + " bytes");
    return check;
  }
  const std::size_t line_end = std::min(head.find("\r\n"), head.size());
  const std::string_view request_line = head.substr(0, line_end);
  check.forwarded_head.assign(request_line);
  check.forwarded_head += "\r\n";
  const std::size_t first_space = request_line.find(' ');
  const std::string_view method = request_line.substr(0, first_space);
  std::string_view target = first_space == std::string_view::npos ? std::string_view() : request_line.substr(first_space + 1);
  target = target.substr(0, target.find(' '));
  const std::string_view path = target.substr(0, target.find('?'));

  std::size_t header_lines = 0, content_lengths = 0;
  for (std::size_t pos = line_end + 2; pos < head.size();) {
    const std::size_t end = head.find("\r\n", pos);
    if (end == std::string_view::npos || end == pos) break;  // the blank line ends the head
    const std::string_view line = head.substr(pos, end - pos);
    pos = end + 2;
    if (++header_lines > limits.max_header_lines) {
      check.refusal = reply(431, "headers_too_large", "the request has more than " + std::to_string(limits.max_header_lines) + " header fields");
      return check;
    }
    bool forward = true;
    if ((check.refusal = check_header_field(line, check, content_lengths, forward))) return check;
    if (!forward) continue;
    check.forwarded_head.append(line);
    check.forwarded_head += "\r\n";
  }
  check.forwarded_head += "\r\n";
  const std::size_t max_body = limits.max_body_bytes ? limits.max_body_bytes(method, path) : std::size_t(-1);
  if (check.content_length > max_body) {
    const std::string who = method == "POST" && path == "/v1/meshes" ? "uploads accept" : "this route accepts";
    check.refusal = reply(413, "payload_too_large", "the request body is " + std::to_string(check.content_length) + " bytes; " +
                                                      who + " at most " + std::to_string(max_body) + " bytes");
  }
  return check;
}

std::string refusal_response(const ErrorReply& r) {
  const std::string body = r.body();
  std::string out = "HTTP/1.1 " + std::to_string(r.status) + " " + reason_phrase(r.status) + "\r\n";
  out += "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n";
  for (const auto& [name, value] : r.headers) out += name + ": " + value + "\r\n";
  out += "\r\n" + body;
  return out;
}

// ---- the bounded connection pool -----------------------------------------------------------

class ConnectionQueue {
 public:
  ConnectionQueue(std::size_t workers, std::size_t max_connections) : max_connections_(max_connections) {
    for (std::size_t i = 0; i < workers; ++i) threads_.emplace_back([this] { work(); });
  }
  ~ConnectionQueue() { shutdown(); }

  /// Queues the job unless `max_connections` are already being served or waiting.
  bool try_enqueue(std::function<void()>& job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopped_ || busy_ + jobs_.size() >= max_connections_) return false;
      jobs_.push_back(std::move(job));
    }
    wake_.notify_one();
    return true;
  }
  bool has_waiting() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return !jobs_.empty();
  }
  /// Runs what is queued (each job closes its connection at once when the server is stopping), then joins.
  void shutdown() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    wake_.notify_all();
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }

 private:
  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stopped_ || !jobs_.empty(); });
      if (jobs_.empty()) return;
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      ++busy_;
      lock.unlock();
      job();
      lock.lock();
      --busy_;
    }
  }

  const std::size_t max_connections_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  std::size_t busy_ = 0;
  bool stopped_ = false;
  std::vector<std::thread> threads_;
};

namespace {

// What httplib's listen loop gets from new_task_queue (it deletes it when it returns).
class QueueHandle : public httplib::TaskQueue {
 public:
  explicit QueueHandle(std::shared_ptr<ConnectionQueue> queue) : queue_(std::move(queue)) {}
  void enqueue(std::function<void()> fn) override {
    if (queue_->try_enqueue(fn)) return;
    refusing_connection = true;  // fn only answers 503 (see process_and_close_socket)
    fn();
    refusing_connection = false;
  }
  void shutdown() override { queue_->shutdown(); }

 private:
  std::shared_ptr<ConnectionQueue> queue_;
};

}  // namespace

// ---- one connection -------------------------------------------------------------------------

class GuardedServer::Connection : public httplib::Stream {
 public:
  Connection(socket_t sock, const TransportLimits& limits, const std::atomic<bool>& stopping)
      : sock_(sock), limits_(limits), stopping_(stopping) {}

  enum class Wait { ready, closed };

  /// Waits up to `seconds` for the first byte of a request; once `seconds_if_others_wait` have
  /// passed, it gives up as soon as `others_wait` says that other connections wait for a worker.
  Wait wait_for_request(double seconds, double seconds_if_others_wait, const std::function<bool()>& others_wait) {
    if (pos_ < buffer_.size()) return Wait::ready;
    const auto deadline = after_seconds(seconds);
    if (wait_readable(after_seconds(std::min(seconds, seconds_if_others_wait)))) return Wait::ready;
    while (!stopping_ && Clock::now() < deadline) {
      if (others_wait()) return Wait::closed;
      if (wait_readable(std::min(deadline, Clock::now() + 2 * kWaitSlice))) return Wait::ready;
    }
    return Wait::closed;
  }

  struct Head {
    std::string bytes;                  ///< empty when the client closed or the server stops
    std::optional<ErrorReply> refusal;  ///< too large, too many lines, too slow
  };

  /// Reads up to the blank line that ends a request head, within the head deadline and limits.
  Head read_head() {
    buffer_.erase(0, pos_);
    pos_ = 0;
    const auto deadline = after_seconds(limits_.head_timeout_s);
    std::size_t scanned = 0;
    for (;;) {
      const std::size_t from = scanned > 3 ? scanned - 3 : 0;
      const std::size_t end = buffer_.find("\r\n\r\n", from);
      // A head whose lines end in a bare LF would never end for httplib, which skips such lines:
      // refused at once instead of waiting for the head deadline.
      const std::size_t bare = buffer_.find('\n', scanned);  // only the bytes new since the last look
      const std::size_t limit = end == std::string::npos ? buffer_.size() : end;
      for (std::size_t lf = bare; lf != std::string::npos && lf < limit; lf = buffer_.find('\n', lf + 1))
        if (lf == 0 || buffer_[lf - 1] != '\r')
          return {{}, reply(400, "invalid_request", "the request's lines must end with CR LF, not a bare LF")};
      if (end != std::string::npos) {
        pos_ = end + 4;
        return {buffer_.substr(0, pos_), std::nullopt};
      }
      scanned = buffer_.size();
      if (buffer_.size() > limits_.max_head_bytes)
        return {{}, reply(431, "headers_too_large", "the request head exceeds " + std::to_string(limits_.max_head_bytes) + " bytes")};
      if (std::size_t(std::count(buffer_.begin(), buffer_.end(), '\n')) > limits_.max_header_lines + 1)
        return {{}, reply(431, "headers_too_large", "the request has more than " + std::to_string(limits_.max_header_lines) + " header fields")};
      char chunk[16384];
      const ssize_t n = receive(chunk, sizeof chunk, deadline);
      if (n > 0) {
        buffer_.append(chunk, std::size_t(n));
        continue;
      }
      if (n < 0 && !stopping_ && Clock::now() >= deadline)
        return {{}, reply(408, "request_timeout", "the request head did not arrive within " + seconds_text(limits_.head_timeout_s) + " s")};
      return {};  // closed by the client, a socket error, or the server stops
    }
  }

  /// Serves `head` to httplib, then at most `body_length` body bytes before the body deadline.
  void begin_request(std::string head, std::size_t body_length) {
    head_ = std::move(head);
    head_pos_ = 0;
    body_remaining_ = body_length;
    body_deadline_ = after_seconds(limits_.head_timeout_s + double(body_length) / limits_.min_body_bytes_per_s);
  }
  bool body_unread() const { return body_remaining_ > 0; }
  /// Declared body bytes not yet received from the socket.
  std::size_t body_bytes_on_the_way() const {
    const std::size_t buffered = buffer_.size() - std::min(pos_, buffer_.size());
    return body_remaining_ > buffered ? body_remaining_ - buffered : 0;
  }

  // ---- httplib::Stream ----
  bool is_readable() const override {
    if (head_pos_ < head_.size() || (body_remaining_ > 0 && pos_ < buffer_.size())) return true;
    pollfd p{sock_, POLLIN, 0};
    return body_remaining_ > 0 && ::poll(&p, 1, 0) > 0;
  }
  bool is_writable() const override {
    pollfd p{sock_, POLLOUT, 0};
    return ::poll(&p, 1, int(limits_.io_timeout_s * 1000)) > 0 && (p.revents & (POLLERR | POLLHUP)) == 0;
  }
  ssize_t read(char* ptr, size_t size) override {
    if (head_pos_ < head_.size()) {
      const std::size_t n = std::min(size, head_.size() - head_pos_);
      std::memcpy(ptr, head_.data() + head_pos_, n);
      head_pos_ += n;
      return ssize_t(n);
    }
    // Never past the declared body: what follows belongs to the next request.
    size = std::min(size, body_remaining_);
    if (size == 0) return 0;
    ssize_t n = 0;
    if (pos_ < buffer_.size()) {
      n = ssize_t(std::min(size, buffer_.size() - pos_));
      std::memcpy(ptr, buffer_.data() + pos_, std::size_t(n));
      pos_ += std::size_t(n);
    } else {
      n = receive(ptr, size, std::min(body_deadline_, after_seconds(limits_.io_timeout_s)));
      if (n <= 0) return -1;
    }
    body_remaining_ -= std::size_t(n);
    return n;
  }
  ssize_t write(const char* ptr, size_t size) override {
    std::size_t sent = 0;
    while (sent < size) {
      pollfd p{sock_, POLLOUT, 0};
      if (::poll(&p, 1, int(limits_.io_timeout_s * 1000)) <= 0) return -1;
      const ssize_t n = ::send(sock_, ptr + sent, size - sent, MSG_NOSIGNAL);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (n <= 0) return -1;
      sent += std::size_t(n);
    }
    return ssize_t(sent);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(::getpeername, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(::getsockname, ip, port); }
  socket_t socket() const override { return sock_; }

 private:
  static std::string seconds_text(double s) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", s);
    return text;
  }

  /// True when readable before the deadline; false at the deadline or when the server stops.
  bool wait_readable(Clock::time_point deadline) const {
    for (;;) {
      if (stopping_) return false;
      // At least one look, even past the deadline: bytes already there are never ignored.
      const auto left = std::max(deadline - Clock::now(), Clock::duration::zero());
      const auto slice = std::chrono::duration_cast<std::chrono::milliseconds>(std::min<Clock::duration>(left, kWaitSlice));
      pollfd p{sock_, POLLIN, 0};
      const int ready = ::poll(&p, 1, int(slice.count()));
      if (ready > 0) return true;
      if (ready < 0 && errno != EINTR) return false;
      if (Clock::now() >= deadline) return false;
    }
  }

  /// recv with a deadline: > 0 bytes, 0 at the client's end of stream, -1 at the deadline, on stop or on error.
  ssize_t receive(char* ptr, std::size_t size, Clock::time_point deadline) {
    if (!wait_readable(deadline)) return -1;
    for (;;) {
      const ssize_t n = ::recv(sock_, ptr, size, 0);
      if (n < 0 && errno == EINTR) continue;
      return n;
    }
  }

  void address(int (*query)(int, sockaddr*, socklen_t*), std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    ip.clear();
    port = 0;
    if (query(sock_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return;
    char text[INET6_ADDRSTRLEN] = {0};
    if (addr.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&addr);
      ::inet_ntop(AF_INET, &a->sin_addr, text, sizeof text);
      port = ntohs(a->sin_port);
    } else if (addr.ss_family == AF_INET6) {
      const auto* a = reinterpret_cast<const sockaddr_in6*>(&addr);
      ::inet_ntop(AF_INET6, &a->sin6_addr, text, sizeof text);
      port = ntohs(a->sin6_port);
    }
    ip = text;
  }

  socket_t sock_;
  const TransportLimits& limits_;
  const std::atomic<bool>& stopping_;
  std::string buffer_;  ///< received bytes; [pos_, end) not yet consumed
  std::size_t pos_ = 0;
  std::string head_;    ///< the current request's head as httplib reads it
  std::size_t head_pos_ = 0;
  std::size_t body_remaining_ = 0;
  Clock::time_point body_deadline_{};
};

// ---- the server -----------------------------------------------------------------------------

GuardedServer::GuardedServer(TransportLimits limits)
    : limits_(std::move(limits)),
      queue_(std::make_shared<ConnectionQueue>(std::max<std::size_t>(1, limits_.workers),
                                               std::max(limits_.workers, limits_.max_connections))) {
  new_task_queue = [queue = queue_] { return new QueueHandle(queue); };
}

GuardedServer::~GuardedServer() { queue_->shutdown(); }

void GuardedServer::widen_backlog() {
  // Calling listen() again on a listening socket only changes its backlog (Linux).
  if (svr_sock_ != INVALID_SOCKET) ::listen(svr_sock_, limits_.listen_backlog);
}

void GuardedServer::stop_gracefully() {
  stopping_ = true;
  stop();
}

void GuardedServer::refuse_and_close(socket_t sock, const ErrorReply& r) {
  if (limits_.on_refusal) limits_.on_refusal(r);
  send_and_close_now(sock, refusal_response(r));
}

bool GuardedServer::process_and_close_socket(socket_t sock) {
  if (refusing_connection) {
    refuse_and_close(sock, reply(503, "overloaded",
                                 "the server has " + std::to_string(limits_.max_connections) +
                                     " connections open, its limit; retry shortly",
                                 {{"Retry-After", "1"}}));
    return true;
  }
  Connection connection(sock, limits_, stopping_);
  bool linger = true;  // if httplib throws outside its own handlers, end the connection gently
  try {
    linger = serve(connection);
  } catch (...) {
  }
  if (linger) {
    lingering_close(sock, connection.body_bytes_on_the_way());
  } else {
    ::shutdown(sock, SHUT_RDWR);
    ::close(sock);
  }
  return true;
}

bool GuardedServer::answer_refusal(Connection& connection, const ErrorReply& refusal) {
  if (limits_.on_refusal) limits_.on_refusal(refusal);
  const std::string bytes = refusal_response(refusal);
  connection.write(bytes.data(), bytes.size());
  return true;  // the rest of the request is unread: linger on close
}

// How long a connection without a request keeps its worker while other connections wait.
constexpr double kIdleWhenOthersWaitS = 1.0;

bool GuardedServer::serve(Connection& connection) {
  for (std::size_t served = 0; served < limits_.keep_alive_max_requests; ++served) {
    // A connection without a request (new, or idle between keep-alive requests) gives its
    // worker up sooner when other connections wait for one, but never at once: a client's
    // request may be on its way (closing then loses it, and a POST cannot be retried). A new
    // connection that sent nothing had kept its worker 5 s, so a few dozen connects a second
    // held every worker. The answer before already said Connection: close if others were waiting.
    if (connection.wait_for_request(limits_.idle_timeout_s, kIdleWhenOthersWaitS, [this] { return queue_->has_waiting(); }) !=
        Connection::Wait::ready)
      return false;
    Connection::Head head = connection.read_head();
    if (head.refusal) return answer_refusal(connection, *head.refusal);
    if (head.bytes.empty()) return false;
    HeadCheck check = check_request_head(head.bytes, limits_);
    if (check.refusal) return answer_refusal(connection, *check.refusal);
    connection.begin_request(std::move(check.forwarded_head), check.content_length);
    // Others waiting for a worker: this answer is the connection's last, and says so.
    const bool last = stopping_ || served + 1 == limits_.keep_alive_max_requests || queue_->has_waiting();
    bool closed_by_request = false;
    const bool ok = process_request(connection, last, closed_by_request, nullptr);
    // A body the handler left unread must never be parsed as a next request.
    if (connection.body_unread()) return true;
    if (!ok || closed_by_request || last || stopping_) return false;
  }
  return false;
}

}  // namespace featureline::server
