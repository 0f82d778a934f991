// The Redis backend of UploadStore (server/upload_store.h), with Debian's hiredis (synchronous).
#include <hiredis/hiredis.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <optional>
#include <vector>

#include "server/session_cache.h"
#include "server/upload_store.h"

namespace featureline::server {
namespace {

struct ReplyDeleter {
  void operator()(redisReply* r) const { freeReplyObject(r); }
};
using Reply = std::unique_ptr<redisReply, ReplyDeleter>;
struct ContextDeleter {
  void operator()(redisContext* c) const { redisFree(c); }
};
using Context = std::unique_ptr<redisContext, ContextDeleter>;

timeval to_timeval(std::chrono::milliseconds ms) { return {time_t(ms.count() / 1000), suseconds_t(ms.count() % 1000 * 1000)}; }

bool is_error(const redisReply* r) { return r->type == REDIS_REPLY_ERROR; }
// "OOM command not allowed when used memory > 'maxmemory'", also inside MULTI ("EXECABORT ... OOM").
bool is_out_of_memory(const redisReply* r) { return is_error(r) && std::string(r->str, r->len).find("OOM") != std::string::npos; }

// One command as arguments (binary-safe: the upload's bytes are passed by pointer, not copied).
struct Command {
  std::vector<const char*> argv;
  std::vector<std::size_t> lengths;
  Command(std::initializer_list<std::string_view> args) {
    for (auto a : args) argv.push_back(a.data()), lengths.push_back(a.size());
  }
};

// Why a connection failed: Redis closed it (restarted, killed the client), it did not answer in
// time (hung, overloaded), or anything else (refused, unresolvable, out of memory).
struct Failure {
  enum Kind { closed, timeout, other } kind = other;
  std::string detail;
};

// `saved_errno`: errno right after the failing hiredis call (hiredis keeps only its text).
Failure failure_of(const redisContext* c, int saved_errno) {
  Failure f{Failure::other, c->errstr};
  if (c->err == REDIS_ERR_EOF || (c->err == REDIS_ERR_IO && (saved_errno == ECONNRESET || saved_errno == EPIPE)))
    f.kind = Failure::closed;
  else if (c->err == REDIS_ERR_IO && (saved_errno == EAGAIN || saved_errno == EWOULDBLOCK || saved_errno == ETIMEDOUT))
    f.kind = Failure::timeout;
  return f;
}

// An idle pooled connection is still usable when nothing is waiting to be read on it: Redis sends
// nothing unasked, so readable means closed (end of file) or broken.
bool still_open(const redisContext* c) {
  char byte = 0;
  const ssize_t n = recv(c->fd, &byte, 1, MSG_PEEK | MSG_DONTWAIT);
  return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
}

// Whether a pipeline may be sent again after its connection was found closed mid-way (Redis may
// or may not have run it): reads, expiry refreshes and whole transactions may; a DEL whose count
// decides the answer may not.
enum class Repeat { safe, never };

class RedisStore final : public UploadStore {
 public:
  RedisStore(RedisAddress address, StoreOptions options)
      : address_(std::move(address)), options_(std::move(options)), identity_key_(address_.key_prefix + ":identity") {
    try {
      release(connect());  // checks the eviction policy now when Redis is up; later otherwise
      std::lock_guard<std::mutex> lock(identity_mutex_);
      identity_ = write_identity();
    } catch (const StoreUnavailableError&) {
      // Redis may start after the server: every operation connects on demand (503 meanwhile).
    }
  }

  void put(const std::string& id, const StoredUpload& upload) override {
    if (!is_mesh_id(id)) throw std::invalid_argument("not a mesh id: " + id);
    const std::string meta = upload_meta_json(upload), ttl = std::to_string(options_.idle_ttl.count()),
                      known_ttl = std::to_string((options_.idle_ttl + options_.tombstone_ttl).count());
    const std::string key = upload_key(id), known = known_key(id), deleted = deleted_key(id);
    // One transaction: the upload never exists without its expiry (it would never expire).
    auto replies = run({{"GET", identity_key_},
                        {"MULTI"},
                        {"HSET", key, "meta", meta, "data", upload.bytes},
                        {"EXPIRE", key, ttl},
                        {"SET", known, "1", "EX", known_ttl},
                        {"DEL", deleted},
                        {"EXEC"}},
                       Repeat::safe);
    observe_identity(replies[0].get());
    for (const auto& r : replies) {
      if (is_out_of_memory(r.get()))
        throw StoreFullError("the upload store (" + describe() + ") is full: Redis refused the upload at its maxmemory limit");
    }
    const auto& exec = replies.back();
    if (is_error(exec.get()) || exec->type != REDIS_REPLY_ARRAY)
      throw StoreUnavailableError("the upload store (" + describe() + ") refused the upload: " + text(exec.get()));
    for (std::size_t i = 0; i < exec->elements; ++i)
      if (is_error(exec->element[i])) throw StoreUnavailableError("the upload store (" + describe() + ") failed: " + text(exec->element[i]));
  }

  StoreLookup get(const std::string& id) override {
    StoreLookup found;
    if (!is_mesh_id(id)) return found;
    auto replies = run({{"GET", identity_key_}, {"HMGET", upload_key(id), "meta", "data"}, {"EXISTS", deleted_key(id)},
                        {"EXISTS", known_key(id)}},
                       Repeat::safe);
    observe_identity(replies[0].get());
    const redisReply* fields = replies[1].get();
    if (is_error(fields) || fields->type != REDIS_REPLY_ARRAY || fields->elements != 2)
      throw StoreUnavailableError("the upload store (" + describe() + ") failed: " + text(fields));
    if (fields->element[0]->type == REDIS_REPLY_STRING && fields->element[1]->type == REDIS_REPLY_STRING) {
      StoredUpload upload;
      const std::size_t length = parse_upload_meta({fields->element[0]->str, fields->element[0]->len}, id, upload);
      if (length != fields->element[1]->len)
        throw StoreUnavailableError("the stored upload of mesh " + id + " is damaged (" + std::to_string(fields->element[1]->len) +
                                    " bytes instead of " + std::to_string(length) + ")");
      upload.bytes.assign(fields->element[1]->str, fields->element[1]->len);
      found.upload = std::move(upload);
    } else if (replies[2]->type == REDIS_REPLY_INTEGER && replies[2]->integer == 1) {
      found.why = StoreMiss::deleted;
    } else if (replies[3]->type == REDIS_REPLY_INTEGER && replies[3]->integer == 1) {
      found.why = StoreMiss::expired;  // known, not deleted, and its upload key timed out
    }
    return found;
  }

  bool touch(const std::string& id) override {
    if (!is_mesh_id(id)) return false;
    auto replies = run({{"GET", identity_key_},
                        {"EXPIRE", upload_key(id), std::to_string(options_.idle_ttl.count())},
                        {"EXPIRE", known_key(id), std::to_string((options_.idle_ttl + options_.tombstone_ttl).count())}},
                       Repeat::safe);
    observe_identity(replies[0].get());
    if (replies[1]->type != REDIS_REPLY_INTEGER) throw StoreUnavailableError("the upload store (" + describe() + ") failed: " + text(replies[1].get()));
    return replies[1]->integer == 1;
  }

  bool erase(const std::string& id) override {
    if (!is_mesh_id(id)) return false;
    // Not repeated: a DEL that ran before its connection closed would answer 0 the second time.
    auto removed = run({{"DEL", upload_key(id)}}, Repeat::never);
    if (removed[0]->type != REDIS_REPLY_INTEGER || removed[0]->integer == 0) return false;
    // DEL is allowed at maxmemory; the tombstone is small but may be refused then (the 404 would
    // then say "unknown" instead of "deleted": nothing is lost).
    run({{"DEL", known_key(id)}, {"SET", deleted_key(id), "1", "EX", std::to_string(options_.tombstone_ttl.count())}}, Repeat::safe);
    return true;
  }

  void probe() override { observe_identity(run({{"GET", identity_key_}}, Repeat::safe)[0].get()); }

  StoreLosses losses() const override {
    std::lock_guard<std::mutex> lock(identity_mutex_);
    return losses_;
  }

  std::size_t expire_idle() override { return 0; }  // Redis expires the keys itself
  std::size_t bytes() const override { return 0; }
  bool shared() const override { return true; }
  std::string describe() const override {
    return "redis " + address_.host + ":" + std::to_string(address_.port) + "/" + std::to_string(address_.db);
  }

 private:
  std::string upload_key(const std::string& id) const { return address_.key_prefix + ":upload:" + id; }
  std::string known_key(const std::string& id) const { return address_.key_prefix + ":known:" + id; }
  std::string deleted_key(const std::string& id) const { return address_.key_prefix + ":deleted:" + id; }

  static std::string text(const redisReply* r) {
    if (r->type == REDIS_REPLY_ERROR || r->type == REDIS_REPLY_STATUS || r->type == REDIS_REPLY_STRING) return std::string(r->str, r->len);
    return "unexpected reply type " + std::to_string(r->type);
  }

  [[noreturn]] void unavailable(const std::string& detail) const {
    throw StoreUnavailableError("the upload store (" + describe() + ") is unreachable: " + detail);
  }
  [[noreturn]] void fail(const Failure& f) const {
    if (f.kind == Failure::timeout)
      throw StoreTimeoutError("the upload store (" + describe() + ") did not answer within " +
                              std::to_string(address_.timeout.count()) + " ms: " + f.detail);
    unavailable(f.detail);
  }

  // A new connection, authenticated, on its database, its eviction policy checked.
  Context connect() const {
    Context c(redisConnectWithTimeout(address_.host.c_str(), address_.port, to_timeval(address_.timeout)));
    const int saved_errno = errno;
    if (!c) unavailable("out of memory");
    if (c->err) fail(failure_of(c.get(), saved_errno));
    redisSetTimeout(c.get(), to_timeval(address_.timeout));
    authenticate(c.get());
    if (address_.db != 0) {
      const std::string db = std::to_string(address_.db);
      if (auto r = command(c.get(), {"SELECT", db}); is_error(r.get())) unavailable("SELECT " + db + ": " + text(r.get()));
    }
    check_eviction_policy(c.get());
    return c;
  }

  // One command during connect(). Redis answers NOAUTH to anything before AUTH when it has a
  // password: without one of ours that is a configuration error, not an outage.
  Reply command(redisContext* c, Command cmd) const {
    Reply r(static_cast<redisReply*>(redisCommandArgv(c, int(cmd.argv.size()), cmd.argv.data(), cmd.lengths.data())));
    const int command_errno = errno;
    if (!r) fail(failure_of(c, command_errno));
    if (is_error(r.get()) && text(r.get()).rfind("NOAUTH", 0) == 0)
      throw StoreAuthError("Redis at " + describe() + " requires a password and none was given: set " + kRedisPasswordVariable +
                           " or give it in the store URL (redis://:PASSWORD@HOST:PORT)");
    return r;
  }

  // AUTH first on every new connection (Redis forgets it when the connection closes). Redis'
  // refusal never repeats the password it was sent.
  void authenticate(redisContext* c) const {
    if (address_.password.empty()) return;
    const Reply r = address_.user.empty() ? command(c, {"AUTH", address_.password})
                                          : command(c, {"AUTH", address_.user, address_.password});
    if (!is_error(r.get())) return;
    const std::string refusal = text(r.get());
    if (refusal.find("WRONGPASS") != std::string::npos || refusal.find("invalid password") != std::string::npos)
      throw StoreAuthError("Redis at " + describe() + " refused the password" +
                           (address_.user.empty() ? "" : " of the user in the store URL") + " (" + refusal + "); check " +
                           kRedisPasswordVariable + " or the store URL");
    throw StoreAuthError("Redis at " + describe() + " refused AUTH: " + refusal);
  }

  // An evicting policy would drop uploads without a word: refuse such a Redis. (A user without
  // the right to CONFIG gets an error reply: nothing to check then.)
  void check_eviction_policy(redisContext* c) const {
    auto policy = command(c, {"CONFIG", "GET", "maxmemory-policy"});
    if (policy->type != REDIS_REPLY_ARRAY || policy->elements != 2 || policy->element[1]->type != REDIS_REPLY_STRING) return;
    const std::string value(policy->element[1]->str, policy->element[1]->len);
    if (value != "noeviction")
      throw std::runtime_error("Redis at " + describe() + " evicts keys (maxmemory-policy " + value +
                               "), which would lose uploads silently; configure maxmemory-policy noeviction");
  }

  Context connect_for_request() const {
    try {
      return connect();
    } catch (const StoreUnavailableError&) {
      throw;
    } catch (const std::runtime_error& e) {
      throw StoreUnavailableError(e.what());  // a misconfigured Redis found after start: 503, not a crash
    }
  }

  // A pooled connection Redis has not closed (one it closed after a restart is dropped here,
  // before a command is lost on it), else a new one; `reused` says which.
  Context acquire(bool& reused) {
    for (;;) {
      Context c;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (idle_.empty()) break;
        c = std::move(idle_.back());
        idle_.pop_back();
      }
      if (still_open(c.get())) {
        reused = true;
        return c;
      }
    }
    reused = false;
    return connect_for_request();
  }
  void release(Context c) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (idle_.size() < 16) idle_.push_back(std::move(c));
  }

  // Pipelines the commands on one connection and returns every reply; Redis' error replies are
  // returned to the caller. A connection that failed is dropped (the next call reconnects). When
  // a reused connection turns out closed (Redis restarted between the check and the send), a
  // pipeline that is safe to repeat is sent once more on a new connection.
  std::vector<Reply> run(std::initializer_list<Command> commands, Repeat repeat) {
    bool reused = false;
    Failure failure;
    if (auto replies = exchange(acquire(reused), commands, failure)) return std::move(*replies);
    if (!reused || failure.kind != Failure::closed || repeat != Repeat::safe) fail(failure);
    if (auto replies = exchange(connect_for_request(), commands, failure)) return std::move(*replies);
    fail(failure);
  }

  // The replies, with the connection back in the pool; or nothing, with `failure` set.
  std::optional<std::vector<Reply>> exchange(Context c, std::initializer_list<Command> commands, Failure& failure) {
    for (const auto& cmd : commands) {
      if (redisAppendCommandArgv(c.get(), int(cmd.argv.size()), const_cast<const char**>(cmd.argv.data()), cmd.lengths.data()) != REDIS_OK) {
        failure = failure_of(c.get(), errno);
        return std::nullopt;
      }
    }
    std::vector<Reply> replies;
    for (std::size_t i = 0; i < commands.size(); ++i) {
      void* reply = nullptr;
      if (redisGetReply(c.get(), &reply) != REDIS_OK || reply == nullptr) {
        const int saved_errno = errno;
        failure = c->err ? failure_of(c.get(), saved_errno) : Failure{Failure::other, "no reply"};
        return std::nullopt;
      }
      replies.emplace_back(static_cast<redisReply*>(reply));
    }
    release(std::move(c));
    return replies;
  }

  // ---- the store's identity --------------------------------------------------------------------
  // Writes an identity unless one is there, and returns the one now in Redis (perhaps another
  // replica's): "" when Redis refused to keep it (at maxmemory).
  std::string write_identity() {
    auto replies = run({{"SET", identity_key_, random_session_id(), "NX"}, {"GET", identity_key_}}, Repeat::safe);
    const redisReply* r = replies[1].get();
    return r->type == REDIS_REPLY_STRING ? std::string(r->str, r->len) : std::string();
  }

  // Compares the identity read with an operation against the one this process knows: gone or
  // changed means Redis lost its data since (restarted empty, flushed), which is counted once.
  void observe_identity(const redisReply* read) {
    if (read->type != REDIS_REPLY_STRING && read->type != REDIS_REPLY_NIL) return;
    std::string seen = read->type == REDIS_REPLY_STRING ? std::string(read->str, read->len) : std::string();
    {
      std::lock_guard<std::mutex> lock(identity_mutex_);
      if (!seen.empty() && seen == identity_) return;
    }
    if (seen.empty()) {
      try {
        seen = write_identity();
      } catch (const StoreUnavailableError&) {
        return;  // the next operation looks again
      }
    }
    std::lock_guard<std::mutex> lock(identity_mutex_);
    // Equal now: a read from before another thread wrote the new identity, counted there.
    if (seen.empty() || seen == identity_) return;
    if (!identity_.empty()) {
      ++losses_.count;
      losses_.last_unix_s = std::chrono::duration_cast<std::chrono::seconds>(options_.now().time_since_epoch()).count();
    }
    identity_ = seen;
  }

  const RedisAddress address_;
  const StoreOptions options_;
  const std::string identity_key_;
  std::mutex mutex_;
  std::vector<Context> idle_;  // open connections not in use (hiredis contexts are not thread-safe)
  mutable std::mutex identity_mutex_;  // guards identity_ and losses_
  std::string identity_;               // the identity this process last saw; "" before the first
  StoreLosses losses_;
};

}  // namespace

std::unique_ptr<UploadStore> open_redis_store(const RedisAddress& address, StoreOptions options) {
  return std::make_unique<RedisStore>(address, std::move(options));
}

}  // namespace featureline::server
