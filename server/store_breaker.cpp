#include "server/store_breaker.h"

#include <type_traits>

namespace featureline::server {

StoreBreaker::StoreBreaker(std::unique_ptr<UploadStore> store, BreakerOptions options)
    : store_(std::move(store)), options_(options), prober_([this] { probe_while_open(); }) {}

StoreBreaker::~StoreBreaker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  prober_.join();  // at most one probe in flight: the store's own timeout bounds the wait
}

template <typename Operation>
auto StoreBreaker::guarded(Operation operation) -> decltype(operation()) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (open_)
      throw StoreUnavailableError("the upload store (" + store_->describe() + ") timed out " +
                                  std::to_string(options_.timeouts_to_open) + " times in a row (" + reason_ +
                                  "); its operations fail at once until it answers a probe again (every " +
                                  std::to_string(options_.probe_interval.count()) + " ms)");
  }
  try {
    if constexpr (std::is_void_v<decltype(operation())>) {
      operation();
      on_answer();
    } else {
      auto result = operation();
      on_answer();
      return result;
    }
  } catch (const StoreTimeoutError& e) {
    on_timeout(e.what());
    throw;
  } catch (const StoreUnavailableError&) {
    on_answer();  // refused or broken, but quickly: not a wait the breaker saves anyone
    throw;
  }
}

void StoreBreaker::on_answer() {
  std::lock_guard<std::mutex> lock(mutex_);
  consecutive_timeouts_ = 0;
}

void StoreBreaker::on_timeout(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (open_ || ++consecutive_timeouts_ < options_.timeouts_to_open) return;
  open_ = true;
  reason_ = what;
  ++openings_;
  wake_.notify_all();
}

// The prober sleeps until the breaker opens, then asks the store every probe_interval until it
// answers; requests never wait for a probe.
void StoreBreaker::probe_while_open() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait(lock, [this] { return stopping_ || open_; });
    if (wake_.wait_for(lock, options_.probe_interval, [this] { return stopping_; })) break;
    lock.unlock();
    bool answered = true;
    try {
      store_->probe();
    } catch (const StoreUnavailableError&) {
      answered = false;
    }
    lock.lock();
    if (answered) {
      open_ = false;
      consecutive_timeouts_ = 0;
      reason_.clear();
    }
  }
}

void StoreBreaker::put(const std::string& id, const StoredUpload& upload) {
  guarded([&] { store_->put(id, upload); });
}
StoreLookup StoreBreaker::get(const std::string& id) {
  return guarded([&] { return store_->get(id); });
}
bool StoreBreaker::touch(const std::string& id) {
  return guarded([&] { return store_->touch(id); });
}
bool StoreBreaker::erase(const std::string& id) {
  return guarded([&] { return store_->erase(id); });
}
std::size_t StoreBreaker::expire_idle() {
  return guarded([&] { return store_->expire_idle(); });
}
void StoreBreaker::probe() {
  guarded([&] { store_->probe(); });
}

bool StoreBreaker::open() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return open_;
}
std::string StoreBreaker::open_reason() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reason_;
}
std::size_t StoreBreaker::openings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return openings_;
}

}  // namespace featureline::server
