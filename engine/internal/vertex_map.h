// Internal to the engine: a map from mesh element ids (vertices, faces) to 32-bit values whose
// reset costs O(1), for stages that touch a small part of a large mesh per request (the strip
// around a line). A hash map cost the strip extraction most of its time; this is one 8-byte
// slot per element, valid only when its stamp is the current one.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "engine/scratch_memory.h"

namespace featureline {

class StampedMap {
 public:
  StampedMap() = default;
  StampedMap(const StampedMap&) = delete;
  StampedMap& operator=(const StampedMap&) = delete;
  ~StampedMap() { account_scratch_bytes(-bytes()); }

  /// Starts an empty map over ids below n.
  void begin(std::size_t n) {
    if (slots_.size() < n) {
      const std::ptrdiff_t before = bytes();
      slots_.assign(n, 0);
      account_scratch_bytes(bytes() - before);
    }
    if (++generation_ == 0) {  // wrapped: clear once every 4 billion uses
      std::fill(slots_.begin(), slots_.end(), 0);
      generation_ = 1;
    }
  }
  bool contains(std::uint32_t id) const { return std::uint32_t(slots_[id] >> 32) == generation_; }
  /// The value of `id`; only meaningful when contains(id).
  std::uint32_t at(std::uint32_t id) const { return std::uint32_t(slots_[id]); }
  void set(std::uint32_t id, std::uint32_t value) { slots_[id] = (std::uint64_t(generation_) << 32) | value; }

 private:
  std::ptrdiff_t bytes() const { return std::ptrdiff_t(slots_.capacity() * sizeof(std::uint64_t)); }

  std::vector<std::uint64_t> slots_;
  std::uint32_t generation_ = 0;
};

/// This thread's map number `which` (0: the strip's vertices, 1: the strip's faces). Each is
/// used by one stage at a time.
inline StampedMap& stamped_map(int which) {
  thread_local StampedMap maps[2];
  return maps[which];
}

}  // namespace featureline
