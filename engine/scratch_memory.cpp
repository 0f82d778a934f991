#include "engine/scratch_memory.h"

#include <atomic>

namespace featureline {
namespace {
std::atomic<std::ptrdiff_t> scratch_bytes{0};
}  // namespace

std::size_t engine_scratch_bytes() {
  const std::ptrdiff_t bytes = scratch_bytes.load(std::memory_order_relaxed);
  return bytes > 0 ? std::size_t(bytes) : 0;
}

void account_scratch_bytes(std::ptrdiff_t delta) { scratch_bytes.fetch_add(delta, std::memory_order_relaxed); }

}  // namespace featureline
