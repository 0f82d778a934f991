#include "server/session_cache.h"

#include <sys/random.h>

#include <cerrno>
#include <stdexcept>

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
  if (gone_.emplace(id, why).second) gone_order_.push_back(id);
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
  do session.id = random_session_id();
  while (entries_.count(session.id) != 0);
  while (!lru_.empty() && bytes_ + session.bytes > options_.byte_budget) {
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

bool SessionCache::erase(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(id);
  if (it == entries_.end()) return false;
  bytes_ -= it->second.session->bytes;
  if (it->second.session->pinned) pinned_bytes_ -= it->second.session->bytes;
  else lru_.erase(it->second.position);
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

}  // namespace featureline::server
