// A fixed set of threads that runs submitted jobs from a bounded queue and is an Executor: a
// job on it (or any other caller) splitting its loops with parallel_for is joined by whichever
// of its threads are idle. The server's engine pool is one (server/work_pool.h), so the engine's
// parallel work shares the threads that run the requests and never adds any.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "engine/executor.h"

namespace featureline {

class ThreadPool : public Executor {
 public:
  /// `threads` may be 0: parallel work then runs on its callers alone, and no job is accepted.
  /// More than `queue_capacity` jobs waiting are refused.
  explicit ThreadPool(std::size_t threads, std::size_t queue_capacity = SIZE_MAX);
  ~ThreadPool() override;
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// Queues `job`; std::nullopt when the queue is full, the pool has no threads or is stopping.
  template <typename Job>
  auto try_submit(Job job) -> std::optional<std::future<decltype(job())>> {
    using Result = decltype(job());
    auto task = std::make_shared<std::packaged_task<Result()>>(std::move(job));
    auto future = task->get_future();
    if (!try_enqueue([task] { (*task)(); })) return std::nullopt;
    return future;
  }

  std::size_t queue_depth() const;  ///< jobs waiting (not yet running)
  std::size_t running() const;      ///< jobs running now (threads helping a parallel_for are not counted)
  std::size_t threads() const { return size_; }
  std::size_t capacity() const { return capacity_; }

  /// Finishes queued jobs and joins the threads (also done by the destructor). Parallel work
  /// still in progress on a job's thread then runs on that thread alone.
  void stop();

  /// The threads and a caller that is not one of them.
  std::size_t workers() const override { return size_ + 1; }
  void run_beside(FunctionRef<void()> beside, FunctionRef<void()> here) override;

 protected:
  void run_blocks(std::size_t n, std::size_t block, Body body) override;

 private:
  struct Offer;
  bool try_enqueue(std::function<void()> job);
  void work();
  void help(std::unique_lock<std::mutex>& lock);
  void post(Offer& offer, std::size_t wake);
  void unlist(Offer& offer);
  void finish(Offer& offer, std::unique_lock<std::mutex>& lock);

  const std::size_t size_;
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> queue_;
  std::atomic<std::size_t> waiting_{0};  ///< queue_.size(), read by helpers between blocks
  std::vector<Offer*> offers_;           ///< parallel work open to idle threads, oldest first
  std::size_t running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace featureline
