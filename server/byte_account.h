// A byte budget shared by concurrent requests (upload bodies being received, parsed JSON bodies):
// each request holds what it uses and gives it back when done, so their total stays bounded
// however many arrive at once.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <string>

namespace featureline::server {

class ByteAccount {
 public:
  explicit ByteAccount(std::size_t capacity) : capacity_(capacity) {}

  /// Takes `bytes` if they fit; false (nothing taken) otherwise.
  bool try_take(std::size_t bytes) {
    std::size_t used = used_.load();
    do {
      if (bytes > capacity_ || used > capacity_ - bytes) return false;
    } while (!used_.compare_exchange_weak(used, used + bytes));
    std::size_t peak = peak_.load();
    while (used + bytes > peak && !peak_.compare_exchange_weak(peak, used + bytes)) {
    }
    return true;
  }
  void give_back(std::size_t bytes) { used_ -= bytes; }

  std::size_t used() const { return used_.load(); }
  /// The most used at once since the last call (or since the start); starts the next period.
  std::size_t take_peak() { return peak_.exchange(used_.load()); }
  std::size_t capacity() const { return capacity_; }

 private:
  const std::size_t capacity_;
  std::atomic<std::size_t> used_{0};
  std::atomic<std::size_t> peak_{0};
};

/// What one request holds of an account; given back when it goes.
class ByteHold {
 public:
  explicit ByteHold(ByteAccount& account) : account_(account) {}
  ~ByteHold() { account_.give_back(bytes_); }
  ByteHold(const ByteHold&) = delete;
  ByteHold& operator=(const ByteHold&) = delete;

  /// Holds `total` bytes in all (more or fewer than now); false when more do not fit (the
  /// hold is unchanged then).
  bool hold(std::size_t total) {
    if (total > bytes_ && !account_.try_take(total - bytes_)) return false;
    if (total < bytes_) account_.give_back(bytes_ - total);
    bytes_ = total;
    return true;
  }
  std::size_t bytes() const { return bytes_; }

 private:
  ByteAccount& account_;
  std::size_t bytes_ = 0;
};

/// "N MiB of the M MiB": how much of an account is in use, for the refusal when it is spent.
inline std::string used_of_capacity(const ByteAccount& account) {
  return std::to_string(account.used() >> 20) + " MiB of the " + std::to_string(account.capacity() >> 20) + " MiB";
}

/// What append_held did with a chunk of a body.
enum class Appended { ok, past_limit, account_full };

/// Appends a received chunk to `body`, which never grows past `limit` bytes. The string grows by
/// doubling and `held` holds its capacity, what it has really allocated, so a body is counted
/// by the bytes it received rather than the length it declared.
inline Appended append_held(std::string& body, ByteHold& held, std::size_t limit, const char* data, std::size_t size) {
  if (size > limit || body.size() > limit - size) return Appended::past_limit;
  if (body.size() + size > body.capacity()) {
    const std::size_t capacity = std::min(limit, std::max(body.size() + size, 2 * body.capacity()));
    if (!held.hold(capacity)) return Appended::account_full;
    body.reserve(capacity);
  }
  body.append(data, size);
  return Appended::ok;
}

}  // namespace featureline::server
