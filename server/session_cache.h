// The session cache: prepared meshes by unguessable id, with a byte budget (least recently
// used eviction) and an idle time-to-live. Entries are immutable and shared: a request holds
// a shared_ptr, so deleting or evicting a session never disturbs requests already using it;
// the memory is freed when the last of them finishes.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include <future>

#include "engine/mesh_io.h"
#include "engine/prepared_mesh.h"
#include "server/upload_store.h"

namespace featureline::server {

/// One uploaded mesh, prepared once and shared read-only by every request on it.
struct MeshSession {
  std::string id;
  std::shared_ptr<const PreparedMesh> mesh;
  MeshFormat format = MeshFormat::obj;
  double load_ms = 0;
  std::size_t bytes = 0;  ///< what the session costs in the budget (PreparedMesh::memory_bytes)
  bool pinned = false;    ///< preloaded at start: never expires nor is evicted (still counts in the budget)
  /// The store's data losses (StoreLosses::count) when the session was stored or rebuilt: one
  /// found later means the store may have lost this session's upload.
  std::uint64_t store_losses = 0;
};

/// 128 random bits from the operating system's CSPRNG (getrandom), as 32 lowercase hex digits.
std::string random_session_id();

class SessionCache {
 public:
  using Clock = std::chrono::steady_clock;

  struct Options {
    std::size_t byte_budget = std::size_t(1) << 30;   ///< evict least recently used beyond this
    std::chrono::seconds idle_ttl{1800};              ///< a session unused this long expires
    std::function<Clock::time_point()> now = [] { return Clock::now(); };  ///< injectable for tests
    /// Memory outside the sessions that the budget must leave room for (the server passes the
    /// engine's per-thread scratch, engine/scratch_memory.h): evictions make room for it too.
    std::function<std::size_t()> other_bytes{};
  };

  struct Stats {
    std::size_t entries = 0, bytes = 0, evictions = 0, expirations = 0, inserts = 0;
  };

  /// Why a lookup found nothing.
  enum class Miss { unknown, expired, evicted, deleted, lost };

  explicit SessionCache(Options options);

  /// Stores a session under its id, or under a fresh random id (set on the returned copy) when
  /// it has none, and evicts least recently used sessions until the budget holds. A session
  /// larger than the whole budget is refused (std::nullopt). When the id is already cached, the
  /// cached session is returned and `session` dropped (two rebuilds of one id give one entry).
  std::optional<std::shared_ptr<const MeshSession>> insert(MeshSession session);

  /// The session, refreshed as most recently used; or why not.
  std::shared_ptr<const MeshSession> find(const std::string& id, Miss* why = nullptr);

  /// Removes a session (remembered as `why`: deleted, or lost by the store); false when there was none.
  bool erase(const std::string& id, Miss why = Miss::deleted);

  /// Drops every session idle longer than the TTL (also done lazily by find and insert).
  void expire_idle();

  Stats stats() const;
  std::chrono::seconds idle_ttl() const { return options_.idle_ttl; }
  /// Seconds until `id` expires if left unused (0 when unknown, -1 for pinned sessions).
  double expires_in_s(const std::string& id) const;

 private:
  struct Entry {
    std::shared_ptr<const MeshSession> session;
    Clock::time_point last_used;
    std::list<std::string>::iterator position;  // in lru_, front = most recent
  };
  void expire_idle_locked(Clock::time_point now);
  void remember_gone(const std::string& id, Miss why);

  Options options_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Entry> entries_;
  std::list<std::string> lru_;
  std::size_t bytes_ = 0;
  std::size_t pinned_bytes_ = 0;
  Stats counters_;
  // Recently removed ids and why, so a 404 can say "expired" or "evicted" (bounded).
  std::unordered_map<std::string, Miss> gone_;
  std::list<std::string> gone_order_;
};

/// Sessions that outlive memory and restarts: the cache in front of an UploadStore.
/// An upload is stored before it is cached; a cache miss asks the store and rebuilds the prepared
/// mesh from the stored bytes (once, however many requests wait for it), so eviction, a restart
/// or another replica costs a rebuild, not the session. Without a store it is the cache alone.
/// A stored upload whose prepared mesh cannot fit this server's cache (the server restarted with
/// a smaller --cache-mb, or another replica with a larger one took the upload).
class CacheTooSmallError : public std::runtime_error {
 public:
  CacheTooSmallError(const std::string& message, std::string reason)
      : std::runtime_error(message), reason_(std::move(reason)) {}
  /// Why it cannot be prepared here: the limit's own message, or the memory it needs.
  const std::string& reason() const { return reason_; }

 private:
  std::string reason_;
};

class DurableSessions {
 public:
  /// Prepares a stored upload again (read + prepare); the server runs it on its engine pool.
  using Rebuild = std::function<MeshSession(std::shared_ptr<const StoredUpload>)>;

  struct Options {
    /// The store's idle clock is restarted at most this often per session; the store keeps
    /// uploads this much longer than the cache. A shared store (Redis) is asked on every use
    /// instead: another replica may have deleted the upload, and a cached copy must not outlive it.
    std::chrono::seconds touch_interval{60};
  };

  /// Why a session could not be found. `lost`: the store lost its upload (Redis restarted
  /// empty); `unknown_after_loss`: unknown, but the store lost its data since this process
  /// started, so an id from before then may have been lost with it.
  enum class Gone { unknown, deleted, expired, evicted, lost, unknown_after_loss };

  struct Found {
    std::shared_ptr<const MeshSession> session;  ///< null when gone
    Gone why = Gone::unknown;                    ///< meaningful when session is null
    bool rebuilt = false;                        ///< prepared again from the store by this lookup
  };

  DurableSessions(SessionCache& cache, std::unique_ptr<UploadStore> store, Rebuild rebuild, Options options);

  /// The session: from the cache, else rebuilt from the store. \throw StoreUnavailableError,
  /// CacheTooSmallError (remembered: the upload is not prepared again for every request), and
  /// what Rebuild throws (every waiter on the same rebuild gets the same exception)
  Found find(const std::string& id);

  /// The session of an upload stash()ed by another replica: find, counted as the upload's
  /// preparation (handoffs()) rather than as a rebuild.
  Found find_stashed(const std::string& id);

  /// A new upload's session: stored first, then cached under a fresh id. std::nullopt when the
  /// prepared mesh exceeds the cache's whole budget (nothing is stored then).
  /// \throw StoreFullError, StoreUnavailableError (nothing is kept then)
  std::optional<std::shared_ptr<const MeshSession>> create(MeshSession session, const StoredUpload& upload);

  /// A new upload stored under a fresh id without preparing it here: the replica that id belongs
  /// to prepares it when it is first asked for (find). Needs a store; returns the id.
  /// \throw StoreFullError, StoreUnavailableError
  std::string stash(const StoredUpload& upload);

  /// Removes the session from the store, then the cache; false (and why) when neither had it.
  /// \throw StoreUnavailableError (the session is kept whole, cached copy included)
  bool erase(const std::string& id, Gone* why);

  /// Expires idle sessions in the cache and idle uploads in the store; false when the store
  /// failed (the next call tries again).
  bool expire_idle();

  bool durable() const { return store_ != nullptr; }
  const UploadStore* store() const { return store_.get(); }
  std::size_t rebuilds() const { return rebuilds_.load(); }
  /// Stashed uploads prepared here (find_stashed).
  std::size_t handoffs() const { return handoffs_.load(); }
  /// The store's data losses found so far (none without a store).
  StoreLosses store_losses() const { return store_ ? store_->losses() : StoreLosses{}; }

 private:
  Found rebuild_once(const std::string& id, std::atomic<std::size_t>& counter);
  Found load_from_store(const std::string& id, std::atomic<std::size_t>& counter);
  Found find(const std::string& id, std::atomic<std::size_t>& counter);
  Gone why_gone(const std::string& id, StoreMiss store_miss);
  Gone drop_unstored(const std::shared_ptr<const MeshSession>& session);
  bool still_stored(const std::string& id);
  CacheTooSmallError too_large(const std::string& id, const std::string& why);

  SessionCache& cache_;
  std::unique_ptr<UploadStore> store_;
  Rebuild rebuild_;
  Options options_;
  std::atomic<std::size_t> rebuilds_{0};
  std::atomic<std::size_t> handoffs_{0};
  std::mutex mutex_;  // guards flights_ and touched_
  std::unordered_map<std::string, std::shared_future<Found>> flights_;  // rebuilds in progress
  std::unordered_map<std::string, SessionCache::Clock::time_point> touched_;
  std::unordered_map<std::string, CacheTooSmallError> too_large_;  // ids whose rebuild cannot fit
};

}  // namespace featureline::server
