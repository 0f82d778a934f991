// The server's engine pool: a fixed set of threads with a bounded queue. When the queue is full
// a job is refused at once (the server answers 503 with Retry-After) instead of growing a
// backlog. It is also the executor of the engine work it runs (PrepareOptions::executor), so
// preparations split their loops over its idle threads and the process never runs more engine
// threads than --threads, however many uploads arrive at once.
#pragma once

#include <algorithm>
#include <cstddef>

#include "engine/thread_pool.h"

namespace featureline::server {

class WorkPool : public ThreadPool {
 public:
  /// At least one thread, so every accepted job runs.
  WorkPool(std::size_t threads, std::size_t queue_capacity) : ThreadPool(std::max<std::size_t>(threads, 1), queue_capacity) {}
};

}  // namespace featureline::server
