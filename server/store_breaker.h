// A circuit breaker in front of an UploadStore. A hung store (Redis stopped, a network that drops
// packets) makes every operation wait for its timeout: with Redis stopped for 8 s, lines fell from
// 114 to 3 per second, each request waiting 2 s. After consecutive timeouts the breaker opens:
// every operation then fails at once with StoreUnavailableError, without touching the store, so
// sessions in memory answer at full speed (DurableSessions treats a failed refresh as "still
// stored") and the rest gets a fast 503; a background probe closes it again once the store answers.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "server/upload_store.h"

namespace featureline::server {

struct BreakerOptions {
  int timeouts_to_open = 3;                         ///< consecutive timeouts that open the breaker
  std::chrono::milliseconds probe_interval{1000};   ///< how often an open breaker asks the store
};

class StoreBreaker final : public UploadStore {
 public:
  StoreBreaker(std::unique_ptr<UploadStore> store, BreakerOptions options);
  ~StoreBreaker() override;
  StoreBreaker(const StoreBreaker&) = delete;
  StoreBreaker& operator=(const StoreBreaker&) = delete;

  void put(const std::string& id, const StoredUpload& upload) override;
  StoreLookup get(const std::string& id) override;
  bool touch(const std::string& id) override;
  bool erase(const std::string& id) override;
  std::size_t expire_idle() override;
  void probe() override;
  StoreLosses losses() const override { return store_->losses(); }
  std::size_t bytes() const override { return store_->bytes(); }
  bool shared() const override { return store_->shared(); }
  std::string describe() const override { return store_->describe(); }

  /// True while operations fail fast.
  bool open() const;
  /// Why it opened (the last timeout's message); "" while closed.
  std::string open_reason() const;
  /// How often it opened since start.
  std::size_t openings() const;

 private:
  template <typename Operation>
  auto guarded(Operation operation) -> decltype(operation());
  void on_answer();
  void on_timeout(const std::string& what);
  void probe_while_open();

  std::unique_ptr<UploadStore> store_;
  const BreakerOptions options_;
  mutable std::mutex mutex_;  // guards everything below
  std::condition_variable wake_;
  int consecutive_timeouts_ = 0;
  bool open_ = false;
  bool stopping_ = false;
  std::string reason_;
  std::size_t openings_ = 0;
  std::thread prober_;
};

}  // namespace featureline::server
