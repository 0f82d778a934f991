// The session cache: prepared meshes by unguessable id, with a byte budget (least recently
// used eviction) and an idle time-to-live. Entries are immutable and shared: a request holds
// a shared_ptr, so deleting or evicting a session never disturbs requests already using it;
// the memory is freed when the last of them finishes.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "engine/mesh_io.h"
#include "engine/prepared_mesh.h"

namespace featureline::server {

/// One uploaded mesh, prepared once and shared read-only by every request on it.
struct MeshSession {
  std::string id;
  std::shared_ptr<const PreparedMesh> mesh;
  MeshFormat format = MeshFormat::obj;
  double load_ms = 0;
  std::size_t bytes = 0;  ///< what the session costs in the budget (PreparedMesh::memory_bytes)
  bool pinned = false;    ///< preloaded at start: never expires nor is evicted (still counts in the budget)
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
  };

  struct Stats {
    std::size_t entries = 0, bytes = 0, evictions = 0, expirations = 0, inserts = 0;
  };

  /// Why a lookup found nothing.
  enum class Miss { unknown, expired, evicted };

  explicit SessionCache(Options options);

  /// Stores a new session under a fresh random id (set on the returned copy) and evicts least
  /// recently used sessions until the budget holds. A session larger than the whole budget is
  /// refused (std::nullopt).
  std::optional<std::shared_ptr<const MeshSession>> insert(MeshSession session);

  /// The session, refreshed as most recently used; or why not.
  std::shared_ptr<const MeshSession> find(const std::string& id, Miss* why = nullptr);

  /// Removes a session; false when there was none.
  bool erase(const std::string& id);

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

}  // namespace featureline::server
