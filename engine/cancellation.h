// Stopping engine work early. A server gives each request a deadline and drops requests whose
// client went away; the engine's long loops (path searches, marching, snake iterations) check
// the request's Cancellation and stop with CancelledError, so refused or timed-out work does
// not go on using a worker.
#pragma once

#include <atomic>
#include <chrono>

#include "engine/errors.h"

namespace featureline {

class Cancellation {
 public:
  using Clock = std::chrono::steady_clock;
  Cancellation() = default;
  /// Requested from `deadline` on, or earlier by cancel().
  explicit Cancellation(Clock::time_point deadline) : deadline_(deadline), has_deadline_(true) {}

  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool requested() const {
    return cancelled_.load(std::memory_order_relaxed) || (has_deadline_ && Clock::now() >= deadline_);
  }

 private:
  std::atomic<bool> cancelled_{false};
  Clock::time_point deadline_{};
  bool has_deadline_ = false;
};

/// Throws CancelledError when `cancel` (which may be null: never) has been requested.
inline void throw_if_cancelled(const Cancellation* cancel) {
  if (cancel != nullptr && cancel->requested()) throw CancelledError("the request was cancelled (deadline passed or client gone)");
}

}  // namespace featureline
