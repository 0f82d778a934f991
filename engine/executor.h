// Where the engine's parallel work runs. Stages start no threads of their own: they split their
// loops over an Executor given in their options (nullptr: default_executor()), so the server,
// which passes its engine pool, runs every upload's preparation on its --threads threads however
// many uploads are being prepared at once. A call's per-worker scratch belongs to the call
// (a vector of workers() slots), so nothing sized to a mesh outlives it.
#pragma once

#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>

namespace featureline {

/// A reference to a callable for the length of one call: no allocation, no ownership.
template <typename Signature>
class FunctionRef;

template <typename R, typename... Args>
class FunctionRef<R(Args...)> {
 public:
  template <typename F, typename = std::enable_if_t<!std::is_same_v<std::decay_t<F>, FunctionRef>>>
  FunctionRef(F&& f)  // NOLINT(google-explicit-constructor): a lambda passes as it is
      : object_(const_cast<void*>(static_cast<const void*>(std::addressof(f)))),
        call_([](void* object, Args... args) -> R {
          return (*static_cast<std::remove_reference_t<F>*>(object))(std::forward<Args>(args)...);
        }) {}
  R operator()(Args... args) const { return call_(object_, std::forward<Args>(args)...); }

 private:
  void* object_;
  R (*call_)(void*, Args...);
};

class Executor {
 public:
  /// body(begin, end, worker): indices [begin, end) on behalf of participant `worker`.
  using Body = FunctionRef<void(std::size_t begin, std::size_t end, std::size_t worker)>;

  virtual ~Executor() = default;

  /// The most participants one parallel_for can have (its caller included): every `worker`
  /// given to a body is below this, so per-worker scratch is a vector of this many slots.
  virtual std::size_t workers() const = 0;

  /// Calls body(begin, end, worker) on consecutive blocks of `block` indices covering [0, n),
  /// each exactly once, and returns when all have run. The caller runs blocks itself and idle
  /// threads of the executor join in, each taking the next block when it finishes one (uneven
  /// work leaves nobody waiting), so a call made from one of the executor's own threads (a job
  /// on the server's pool) finishes even when every other thread is busy. Two participants of
  /// one call never share a `worker`. When a body throws, no further block starts and the
  /// exception is rethrown here once the other participants have stopped. Below four blocks
  /// (waking helpers costs more than it saves) or with one worker, body(0, n, 0) on the caller.
  void parallel_for(std::size_t n, std::size_t block, Body body) {
    if (block == 0) block = 1;
    if (workers() == 1 || n < 4 * block) return body(std::size_t(0), n, std::size_t(0));
    run_blocks(n, block, body);
  }

  /// Runs `beside` on an idle thread of the executor while the caller runs `here`, and returns
  /// when both have run; when no thread took `beside` by the time `here` is done, the caller
  /// runs it itself. For independent parts of a stage, which must not wait for each other.
  /// Rethrows what `here` threw (`beside` then runs only if a thread had already taken it, and
  /// is waited for), else what `beside` threw.
  virtual void run_beside(FunctionRef<void()> beside, FunctionRef<void()> here) = 0;

 protected:
  /// parallel_for with at least four blocks.
  virtual void run_blocks(std::size_t n, std::size_t block, Body body) = 0;
};

/// Everything on the caller's thread, in order (worker 0): what the parallel results must equal.
class SerialExecutor final : public Executor {
 public:
  std::size_t workers() const override { return 1; }
  void run_beside(FunctionRef<void()> beside, FunctionRef<void()> here) override {
    here();
    beside();
  }

 protected:
  void run_blocks(std::size_t n, std::size_t, Body body) override { body(0, n, 0); }
};

/// The process's executor for callers that pass none (the CLI, tests, benchmarks): a pool made
/// on first use, never destroyed, whose calls have min(hardware threads, 8) participants (the
/// caller and up to that many less one of the pool's threads).
Executor& default_executor();

/// `executor`, or default_executor() when it is null.
inline Executor& executor_or_default(Executor* executor) { return executor != nullptr ? *executor : default_executor(); }

}  // namespace featureline
