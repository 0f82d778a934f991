#include "engine/thread_pool.h"

#include <algorithm>
#include <exception>

namespace featureline {

// Parallel work open to idle threads: the blocks of a parallel_for, or one task beside its
// caller. It lives on its caller's stack; the caller takes it off the list and waits until no
// helper is in it before returning, so a helper never touches it after its caller returned.
struct ThreadPool::Offer {
  const Body* body = nullptr;                 // blocks...
  const FunctionRef<void()>* task = nullptr;  // ...or one task
  std::size_t n = 0, block = 1;
  std::atomic<std::size_t> next{0};  // the first index no participant has taken
  // Under the pool's mutex:
  std::size_t max_helpers = 0;  // joined stops here (worker indices 1..max_helpers)
  std::size_t joined = 0;       // helpers that joined so far
  std::size_t active = 0;       // helpers that joined and have not finished
  bool listed = false;          // in offers_
  std::exception_ptr error;     // the first a helper caught
  std::condition_variable done; // active fell to 0
};

namespace {

// Takes blocks until none is left; a helper (`leave_when` set) also stops once a job waits for
// a thread, so queued requests do not wait while threads speed up someone else's work (its
// caller finishes it regardless).
template <typename Offer>
void run_some_blocks(Offer& offer, std::size_t worker, const std::atomic<std::size_t>* leave_when) {
  while (leave_when == nullptr || leave_when->load(std::memory_order_relaxed) == 0) {
    const std::size_t begin = offer.next.fetch_add(offer.block);
    if (begin >= offer.n) return;
    (*offer.body)(begin, std::min(offer.n, begin + offer.block), worker);
  }
}

}  // namespace

ThreadPool::ThreadPool(std::size_t threads, std::size_t queue_capacity) : size_(threads), capacity_(queue_capacity) {
  workers_.reserve(threads);
  for (std::size_t i = 0; i < threads; ++i) workers_.emplace_back([this] { work(); });
}

ThreadPool::~ThreadPool() { stop(); }

bool ThreadPool::try_enqueue(std::function<void()> job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (size_ == 0 || stopping_ || queue_.size() >= capacity_) return false;
    queue_.push_back(std::move(job));
    waiting_.store(queue_.size(), std::memory_order_relaxed);
  }
  wake_.notify_one();
  return true;
}

void ThreadPool::work() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty() || !offers_.empty(); });
    // Waiting jobs before helping: see run_some_blocks.
    if (!queue_.empty()) {
      std::function<void()> job = std::move(queue_.front());
      queue_.pop_front();
      waiting_.store(queue_.size(), std::memory_order_relaxed);
      ++running_;
      lock.unlock();
      job();  // packaged_task stores any exception in its future
      job = nullptr;
      lock.lock();
      --running_;
    } else if (!offers_.empty()) {
      help(lock);
    } else {
      return;  // stopping, nothing queued or offered
    }
  }
}

void ThreadPool::help(std::unique_lock<std::mutex>& lock) {
  Offer& offer = *offers_.front();
  const std::size_t worker = ++offer.joined;
  ++offer.active;
  if (offer.joined == offer.max_helpers) unlist(offer);
  lock.unlock();
  std::exception_ptr error;
  try {
    if (offer.task != nullptr) (*offer.task)();
    else run_some_blocks(offer, worker, &waiting_);
  } catch (...) {
    error = std::current_exception();
    offer.next.store(offer.n);  // no further block starts
  }
  lock.lock();
  if (error && !offer.error) offer.error = error;
  // Nothing left to take: threads that would join only to find that out need not wake.
  if (offer.listed && offer.task == nullptr && offer.next.load() >= offer.n) unlist(offer);
  // Notified under the mutex: the caller cannot return (and free the offer) before it is released.
  if (--offer.active == 0) offer.done.notify_all();
}

void ThreadPool::post(Offer& offer, std::size_t wake) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    offers_.push_back(&offer);
    offer.listed = true;
  }
  for (std::size_t i = 0; i < wake; ++i) wake_.notify_one();
}

void ThreadPool::unlist(Offer& offer) {
  offers_.erase(std::find(offers_.begin(), offers_.end(), &offer));
  offer.listed = false;
}

void ThreadPool::finish(Offer& offer, std::unique_lock<std::mutex>& lock) {
  if (offer.listed) unlist(offer);
  offer.done.wait(lock, [&offer] { return offer.active == 0; });
}

void ThreadPool::run_blocks(std::size_t n, std::size_t block, Body body) {
  Offer offer;
  offer.body = &body;
  offer.n = n;
  offer.block = block;
  offer.max_helpers = std::min(size_, (n + block - 1) / block - 1);
  if (offer.max_helpers == 0) return body(0, n, 0);
  post(offer, offer.max_helpers);
  std::exception_ptr error;
  try {
    run_some_blocks(offer, 0, nullptr);
  } catch (...) {
    error = std::current_exception();
    offer.next.store(n);
  }
  std::unique_lock<std::mutex> lock(mutex_);
  finish(offer, lock);
  if (!error) error = offer.error;
  lock.unlock();
  if (error) std::rethrow_exception(error);
}

void ThreadPool::run_beside(FunctionRef<void()> beside, FunctionRef<void()> here) {
  if (size_ == 0) {
    here();
    beside();
    return;
  }
  Offer offer;
  offer.task = &beside;
  offer.max_helpers = 1;
  post(offer, 1);
  std::exception_ptr error;
  try {
    here();
  } catch (...) {
    error = std::current_exception();
  }
  std::unique_lock<std::mutex> lock(mutex_);
  if (offer.listed) {  // no thread took it
    unlist(offer);
    lock.unlock();
    if (error) std::rethrow_exception(error);
    beside();
    return;
  }
  finish(offer, lock);
  if (!error) error = offer.error;
  lock.unlock();
  if (error) std::rethrow_exception(error);
}

std::size_t ThreadPool::queue_depth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

std::size_t ThreadPool::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_;
}

void ThreadPool::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  for (auto& t : workers_)
    if (t.joinable()) t.join();
  workers_.clear();
}

Executor& default_executor() {
  // Made once and never destroyed: nothing at exit joins threads that another static's
  // destructor or a still-running thread might be using.
  static ThreadPool* const pool =
      new ThreadPool(std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1, 8) - 1);
  return *pool;
}

}  // namespace featureline
