// Durable uploads: each upload's original bytes and format, kept outside the process so that a
// restart, an eviction or another replica can prepare the mesh again. Two backends
// behind one interface: a directory on disk (the single-binary default) and Redis (shared by
// the replicas of a cluster). The prepared mesh itself is never stored: it is rebuilt from the
// bytes, which keeps the store small (an upload is 10-20x smaller than its prepared mesh) and
// independent of the engine's in-memory layout.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "engine/mesh_io.h"

namespace featureline::server {

/// One upload as received.
struct StoredUpload {
  std::string bytes;                    ///< the body exactly as uploaded
  MeshFormat format = MeshFormat::obj;  ///< as given or sniffed at upload time
  std::int64_t uploaded_at_unix_s = 0;  ///< when it was uploaded (wall clock)
};

/// Why a store has no upload under an id.
enum class StoreMiss {
  unknown,  ///< never stored here (or forgotten after the tombstone period)
  deleted,  ///< removed by DELETE
  expired,  ///< unused longer than the idle time-to-live
};

struct StoreLookup {
  std::optional<StoredUpload> upload;    ///< set when found
  StoreMiss why = StoreMiss::unknown;    ///< meaningful when not found
};

/// The store refuses more bytes (its size limit, a full disk, Redis' maxmemory). Nothing was stored.
class StoreFullError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The store cannot be reached or read (I/O error, Redis down or timing out, a damaged record).
class StoreUnavailableError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Redis refused the credentials, or wants a password and none was given: a configuration error
/// like an evicting Redis, so fatal when found at start; found later (Redis restarted with another
/// password) it reaches requests and /readyz as StoreUnavailableError. Its message never holds the
/// password.
class StoreAuthError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The store did not answer within its timeout (a hung Redis): the request waited for nothing.
/// Consecutive ones open the circuit breaker (server/store_breaker.h).
class StoreTimeoutError : public StoreUnavailableError {
  using StoreUnavailableError::StoreUnavailableError;
};

/// Times this process found the store to have lost its data (Redis restarted empty or flushed):
/// uploads stored before then are gone without a delete or an expiry to say so.
struct StoreLosses {
  std::uint64_t count = 0;
  std::int64_t last_unix_s = 0;  ///< when the last loss was found (wall clock; 0: never)
};

/// Every operation is safe from any thread. Ids must be 32 lowercase hex digits (they become
/// file names and keys); other ids are unknown to get/erase and refused by put.
class UploadStore {
 public:
  virtual ~UploadStore() = default;
  /// Keeps `upload` under `id`, its idle clock started. \throw StoreFullError, StoreUnavailableError
  virtual void put(const std::string& id, const StoredUpload& upload) = 0;
  /// The upload, or why there is none. \throw StoreUnavailableError
  virtual StoreLookup get(const std::string& id) = 0;
  /// Restarts `id`'s idle clock; false when `id` is not stored (deleted or expired, perhaps by
  /// another process sharing the store). \throw StoreUnavailableError
  virtual bool touch(const std::string& id) = 0;
  /// Removes `id`, remembering it as deleted; false when it was not stored. \throw StoreUnavailableError
  virtual bool erase(const std::string& id) = 0;
  /// Removes uploads idle longer than the time-to-live (remembered as expired) and forgets old
  /// tombstones; returns how many uploads expired. Redis expires keys itself: 0 there.
  virtual std::size_t expire_idle() = 0;
  /// Bytes of uploads held (the directory's own count; Redis: 0, its limit is its maxmemory).
  virtual std::size_t bytes() const = 0;
  /// One round trip that needs no upload: readiness and the circuit breaker's probe.
  /// \throw StoreUnavailableError (StoreTimeoutError when it did not answer in time)
  virtual void probe() = 0;
  /// The data losses found so far (see StoreLosses).
  virtual StoreLosses losses() const = 0;
  /// True when other processes use the same store (Redis: a cluster's replicas), so an upload
  /// may be deleted or expire behind this process' back.
  virtual bool shared() const = 0;
  /// "directory PATH" or "redis HOST:PORT/DB", for the banner and errors.
  virtual std::string describe() const = 0;
};

/// Options shared by both backends.
struct StoreOptions {
  std::chrono::seconds idle_ttl{1800};              ///< an upload untouched this long expires
  std::chrono::seconds tombstone_ttl{7 * 86400};    ///< how long "deleted"/"expired" is remembered
  std::size_t max_bytes = 0;                        ///< directory: refuse uploads beyond this total (0: none)
  std::function<std::chrono::system_clock::time_point()> now = [] { return std::chrono::system_clock::now(); };
};

/// A directory: DIR/uploads/ID (a one-line JSON header, then the bytes; the file's mtime is the
/// last use), DIR/gone/ID.deleted|expired (tombstones), DIR/tmp/ (writes in progress). Writes are
/// atomic (temporary file, fsync, rename, fsync of the directory): a crash leaves the old state
/// or the new one, never a torn upload. Creates the folders. \throw StoreUnavailableError
std::unique_ptr<UploadStore> open_directory_store(const std::string& path, StoreOptions options);

/// Redis (hiredis): keys PREFIX:upload:ID (a hash of meta and bytes, with Redis' own expiry as
/// the idle TTL), PREFIX:known:ID and PREFIX:deleted:ID (tell expired and deleted from unknown),
/// and PREFIX:identity, a random value written when first used and read with every operation:
/// when it is gone or changed, Redis lost its data (counted in losses()).
/// Connections are opened on demand and reopened after errors, so Redis may start later or
/// restart: a pooled connection that Redis closed is dropped before use, and an operation safe to
/// repeat that fails because its connection was closed is retried once on a new connection.
/// With a password, every new connection (the first, and each one after Redis closed the last)
/// sends AUTH before anything else. A timeout throws StoreTimeoutError. Redis must not evict
/// keys on its own (that would lose uploads silently): an evicting maxmemory-policy is refused.
/// \throw std::runtime_error for such a Redis, StoreAuthError when Redis refuses the password or
/// wants one
struct RedisAddress {
  std::string host = "127.0.0.1";
  int port = 6379;
  int db = 0;
  std::string user;      ///< an ACL user ("": Redis' default user)
  std::string password;  ///< "": no AUTH
  std::string key_prefix = "featureline";
  std::chrono::milliseconds timeout{2000};  ///< connect and per-command timeout
};
std::unique_ptr<UploadStore> open_redis_store(const RedisAddress& address, StoreOptions options);

/// The environment variable that gives the Redis password when the store URL has none, so that
/// it need not be on a command line (which every user of the machine can read).
inline constexpr const char* kRedisPasswordVariable = "FEATURELINE_REDIS_PASSWORD";

/// "redis://[[USER][:PASSWORD]@]HOST[:PORT][/DB]", user and password percent-encoded (a URL's
/// userinfo: "redis://USER@HOST" names a user and no password).
/// \throw std::invalid_argument, its message showing the URL redacted
RedisAddress parse_redis_url(const std::string& url);

/// `url` fit for logs and errors: a redis:// URL's user and password replaced by "***".
std::string redacted_store_url(const std::string& url);

/// Opens a store from a flag's value: "redis://..." (parse_redis_url), "dir:PATH" or a plain
/// PATH. `password` is Redis' when the URL has none (from kRedisPasswordVariable); a folder
/// ignores it. \throw std::invalid_argument for a malformed URL, and what the backends throw
std::unique_ptr<UploadStore> open_upload_store(const std::string& url, StoreOptions options, const std::string& password = "");

/// The header line both backends keep with the bytes: {"format": ..., "uploaded_at": ..., "bytes": N}.
std::string upload_meta_json(const StoredUpload& upload);
/// Reads a header into `upload` (format, time) and returns the byte count it announces.
/// \throw StoreUnavailableError naming `id` when the header is damaged
std::size_t parse_upload_meta(std::string_view meta, const std::string& id, StoredUpload& upload);

/// True for a well-formed mesh id (32 lowercase hex digits).
bool is_mesh_id(std::string_view id);

}  // namespace featureline::server
