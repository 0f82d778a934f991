// A fixed set of threads for engine work with a bounded queue: when the queue is full a job
// is refused at once (the server answers 503 with Retry-After) instead of growing a backlog.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace featureline::server {

class WorkPool {
 public:
  WorkPool(std::size_t threads, std::size_t queue_capacity);
  ~WorkPool();
  WorkPool(const WorkPool&) = delete;
  WorkPool& operator=(const WorkPool&) = delete;

  /// Queues `job`; std::nullopt when the queue is full or the pool is stopping.
  template <typename Job>
  auto try_submit(Job job) -> std::optional<std::future<decltype(job())>> {
    using Result = decltype(job());
    auto task = std::make_shared<std::packaged_task<Result()>>(std::move(job));
    auto future = task->get_future();
    if (!try_enqueue([task] { (*task)(); })) return std::nullopt;
    return future;
  }

  std::size_t queue_depth() const;   ///< jobs waiting (not yet running)
  std::size_t running() const;       ///< jobs running now
  std::size_t threads() const { return workers_.size(); }
  std::size_t capacity() const { return capacity_; }

  /// Finishes queued jobs and joins the threads (also done by the destructor).
  void stop();

 private:
  bool try_enqueue(std::function<void()> job);
  void work();

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> queue_;
  std::size_t running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace featureline::server
