#include "server/session_cache.h"

#include <sys/random.h>

#include <cerrno>
#include <stdexcept>

#include "engine/errors.h"

namespace featureline::server {

std::string random_session_id() {
  unsigned char bytes[16];
  std::size_t filled = 0;
  while (filled < sizeof bytes) {
    const ssize_t got = getrandom(bytes + filled, sizeof bytes - filled, 0);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error("the operating system's random number generator failed");
    }
    filled += std::size_t(got);
  }
  static const char* hex = "0123456789abcdef";
  std::string id(32, '0');
  for (std::size_t i = 0; i < 16; ++i) {
    id[2 * i] = hex[bytes[i] >> 4];
    id[2 * i + 1] = hex[bytes[i] & 15];
  }
  return id;
}

SessionCache::SessionCache(Options options) : options_(std::move(options)) {}

void SessionCache::remember_gone(const std::string& id, Miss why) {
  constexpr std::size_t kRemembered = 4096;
  // The latest reason wins: an id evicted, rebuilt and then deleted was deleted.
  if (auto [it, inserted] = gone_.emplace(id, why); inserted) gone_order_.push_back(id);
  else it->second = why;
  while (gone_order_.size() > kRemembered) {
    gone_.erase(gone_order_.front());
    gone_order_.pop_front();
  }
}

void SessionCache::expire_idle_locked(Clock::time_point now) {
  // The least recently used are at the back: stop at the first one still fresh.
  while (!lru_.empty()) {
    auto it = entries_.find(lru_.back());
    if (now - it->second.last_used < options_.idle_ttl) break;
    bytes_ -= it->second.session->bytes;
    remember_gone(it->first, Miss::expired);
    ++counters_.expirations;
    lru_.pop_back();
    entries_.erase(it);
  }
}

std::optional<std::shared_ptr<const MeshSession>> SessionCache::insert(MeshSession session) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Evicting can only free unpinned bytes: refuse up front rather than evict in vain.
  if (pinned_bytes_ + session.bytes > options_.byte_budget) return std::nullopt;
  const auto now = options_.now();
  expire_idle_locked(now);
  if (session.id.empty()) {
    do session.id = random_session_id();
    while (entries_.count(session.id) != 0);
  } else if (auto existing = entries_.find(session.id); existing != entries_.end()) {
    return existing->second.session;
  }
  const std::size_t other = options_.other_bytes ? options_.other_bytes() : 0;
  while (!lru_.empty() && bytes_ + session.bytes + other > options_.byte_budget) {
    auto it = entries_.find(lru_.back());
    bytes_ -= it->second.session->bytes;
    remember_gone(it->first, Miss::evicted);
    ++counters_.evictions;
    lru_.pop_back();
    entries_.erase(it);
  }
  auto shared = std::make_shared<const MeshSession>(std::move(session));
  // Pinned sessions stay out of the LRU list, so neither expiry nor eviction ever sees them.
  auto position = lru_.end();
  if (!shared->pinned) {
    lru_.push_front(shared->id);
    position = lru_.begin();
  }
  entries_.emplace(shared->id, Entry{shared, now, position});
  bytes_ += shared->bytes;
  if (shared->pinned) pinned_bytes_ += shared->bytes;
  ++counters_.inserts;
  return shared;
}

std::shared_ptr<const MeshSession> SessionCache::find(const std::string& id, Miss* why) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = options_.now();
  expire_idle_locked(now);
  auto it = entries_.find(id);
  if (it == entries_.end()) {
    if (why != nullptr) {
      auto gone = gone_.find(id);
      *why = gone == gone_.end() ? Miss::unknown : gone->second;
    }
    return nullptr;
  }
  it->second.last_used = now;
  if (!it->second.session->pinned) lru_.splice(lru_.begin(), lru_, it->second.position);
  return it->second.session;
}

bool SessionCache::erase(const std::string& id, Miss why) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(id);
  if (it == entries_.end()) return false;
  bytes_ -= it->second.session->bytes;
  if (it->second.session->pinned) pinned_bytes_ -= it->second.session->bytes;
  else lru_.erase(it->second.position);
  remember_gone(id, why);
  entries_.erase(it);
  return true;
}

void SessionCache::expire_idle() {
  std::lock_guard<std::mutex> lock(mutex_);
  expire_idle_locked(options_.now());
}

SessionCache::Stats SessionCache::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Stats s = counters_;
  s.entries = entries_.size();
  s.bytes = bytes_;
  return s;
}

double SessionCache::expires_in_s(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(id);
  if (it == entries_.end()) return 0;
  if (it->second.session->pinned) return -1;  // never
  const auto left = options_.idle_ttl - (options_.now() - it->second.last_used);
  return std::max(0.0, std::chrono::duration<double>(left).count());
}

// ---- DurableSessions ---------------------------------------------------------------------------

namespace {
DurableSessions::Gone gone_from(SessionCache::Miss miss) {
  switch (miss) {
    case SessionCache::Miss::expired: return DurableSessions::Gone::expired;
    case SessionCache::Miss::evicted: return DurableSessions::Gone::evicted;
    case SessionCache::Miss::deleted: return DurableSessions::Gone::deleted;
    case SessionCache::Miss::lost: return DurableSessions::Gone::lost;
    default: return DurableSessions::Gone::unknown;
  }
}
}  // namespace

DurableSessions::DurableSessions(SessionCache& cache, std::unique_ptr<UploadStore> store, Rebuild rebuild, Options options)
    : cache_(cache), store_(std::move(store)), rebuild_(std::move(rebuild)), options_(options) {}

DurableSessions::Gone DurableSessions::why_gone(const std::string& id, StoreMiss store_miss) {
  if (store_miss == StoreMiss::deleted) return Gone::deleted;
  if (store_miss == StoreMiss::expired) return Gone::expired;
  // The store never had it (or no store): what this process remembers, if anything.
  SessionCache::Miss miss = SessionCache::Miss::unknown;
  if (cache_.find(id, &miss)) return Gone::unknown;  // cached meanwhile: the caller retries
  if (miss == SessionCache::Miss::unknown && store_ && store_->losses().count > 0) return Gone::unknown_after_loss;
  return gone_from(miss);
}

// A cached session whose upload the store no longer has: deleted or expired by another replica,
// or lost with the store's data (no tombstone says otherwise, and the store lost data since the
// session was stored). The cached copy goes either way: no replica can rebuild it any more.
DurableSessions::Gone DurableSessions::drop_unstored(const std::shared_ptr<const MeshSession>& session) {
  const StoreMiss miss = store_->get(session->id).why;
  const bool lost = miss == StoreMiss::unknown && store_->losses().count > session->store_losses;
  cache_.erase(session->id, lost ? SessionCache::Miss::lost : SessionCache::Miss::deleted);
  return why_gone(session->id, miss);
}

DurableSessions::Found DurableSessions::find(const std::string& id) { return find(id, rebuilds_); }

DurableSessions::Found DurableSessions::find_stashed(const std::string& id) { return find(id, handoffs_); }

// `counter` counts the preparation, if this lookup prepares the session.
DurableSessions::Found DurableSessions::find(const std::string& id, std::atomic<std::size_t>& counter) {
  Found found;
  SessionCache::Miss miss = SessionCache::Miss::unknown;
  found.session = cache_.find(id, &miss);
  if (found.session) {
    // A preloaded mesh stays while the server runs, even if the store expires its copy.
    if (found.session->pinned || still_stored(id)) return found;
    found.why = drop_unstored(found.session);
    found.session = nullptr;
    return found;
  }
  if (!store_) {
    found.why = gone_from(miss);
    return found;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = too_large_.find(id); it != too_large_.end()) throw it->second;
  }
  return rebuild_once(id, counter);
}

// Single flight: the first request for a missing id rebuilds it; the others wait for its result.
DurableSessions::Found DurableSessions::rebuild_once(const std::string& id, std::atomic<std::size_t>& counter) {
  std::promise<Found> promise;
  std::shared_future<Found> flight;
  bool leader = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = flights_.find(id); it != flights_.end()) {
      flight = it->second;
    } else {
      flight = promise.get_future().share();
      flights_.emplace(id, flight);
      leader = true;
    }
  }
  if (leader) {
    try {
      promise.set_value(load_from_store(id, counter));
    } catch (...) {
      promise.set_exception(std::current_exception());
    }
    std::lock_guard<std::mutex> lock(mutex_);
    flights_.erase(id);
  }
  return flight.get();  // rethrows the leader's exception
}

DurableSessions::Found DurableSessions::load_from_store(const std::string& id, std::atomic<std::size_t>& counter) {
  Found found;
  // A flight that ended between this request's cache miss and now may have cached it already.
  if ((found.session = cache_.find(id))) return found;
  StoreLookup lookup = store_->get(id);
  if (!lookup.upload) {
    found.why = why_gone(id, lookup.why);
    return found;
  }
  MeshSession session;
  try {
    session = rebuild_(std::make_shared<const StoredUpload>(std::move(*lookup.upload)));
  } catch (const LimitExceededError& e) {
    throw too_large(id, e.what());
  }
  session.id = id;
  session.store_losses = store_->losses().count;
  const std::size_t bytes = session.bytes;
  auto cached = cache_.insert(std::move(session));
  if (!cached) throw too_large(id, "it needs " + std::to_string(bytes >> 20) + " MiB prepared");
  ++counter;
  found.session = *cached;
  found.rebuilt = true;
  still_stored(id);  // restarts the store's idle clock
  return found;
}

// Remembers that `id` cannot fit (until it is deleted), so later requests are refused at once.
CacheTooSmallError DurableSessions::too_large(const std::string& id, const std::string& why) {
  CacheTooSmallError error("mesh " + id + " is stored but cannot be prepared within this server's memory: " + why +
                               "; a server with a larger --cache-mb can serve it",
                           why);
  std::lock_guard<std::mutex> lock(mutex_);
  if (too_large_.size() > 10000) too_large_.clear();  // bounded: forgetting only costs one more attempt
  too_large_.insert_or_assign(id, error);
  return error;
}

// Restarts the store's idle clock when due (every use for a shared store); false only when
// the store says the upload is gone.
bool DurableSessions::still_stored(const std::string& id) {
  if (!store_) return true;
  const auto now = SessionCache::Clock::now();
  if (!store_->shared()) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (touched_.size() > 100000) touched_.clear();  // bounded: forgetting only costs an early touch
    auto& last = touched_[id];
    if (last != SessionCache::Clock::time_point{} && now - last < options_.touch_interval) return true;
    last = now;
  }
  try {
    return store_->touch(id);
  } catch (const StoreUnavailableError&) {
    // The session is in memory and answers; the next use tries again.
    std::lock_guard<std::mutex> lock(mutex_);
    touched_.erase(id);
    return true;
  }
}

std::optional<std::shared_ptr<const MeshSession>> DurableSessions::create(MeshSession session, const StoredUpload& upload) {
  session.id.clear();  // a fresh random id
  if (store_) session.store_losses = store_->losses().count;
  auto cached = cache_.insert(std::move(session));
  if (!cached || !store_) return cached;
  const std::string id = (*cached)->id;
  try {
    store_->put(id, upload);
  } catch (...) {
    cache_.erase(id);  // not durable, so not a session: the client gets the store's error
    throw;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  touched_[id] = SessionCache::Clock::now();
  return cached;
}

std::string DurableSessions::stash(const StoredUpload& upload) {
  if (!store_) throw std::logic_error("stash needs an upload store");
  const std::string id = random_session_id();
  store_->put(id, upload);
  std::lock_guard<std::mutex> lock(mutex_);
  touched_[id] = SessionCache::Clock::now();
  return id;
}

bool DurableSessions::erase(const std::string& id, Gone* why) {
  // The store first: when it cannot delete (unreachable, read-only) the request fails and the
  // session stays whole; dropping the cached copy first had answered 503 while the mesh came
  // back from the store later.
  const bool stored = store_ && store_->erase(id);
  const bool cached = cache_.erase(id);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    touched_.erase(id);
    too_large_.erase(id);
  }
  if (cached || stored) return true;
  if (why != nullptr) *why = why_gone(id, store_ ? store_->get(id).why : StoreMiss::unknown);
  return false;
}

bool DurableSessions::expire_idle() {
  cache_.expire_idle();
  if (!store_) return true;
  try {
    store_->expire_idle();
    return true;
  } catch (const StoreUnavailableError&) {
    return false;
  }
}

}  // namespace featureline::server
