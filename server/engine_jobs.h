// Engine work for a request, run on the engine pool within the request's deadline: one job
// (a preparation, a segmentation, a mesh export) or a batch of lines in parallel. A full queue
// and a passed deadline are the two refusals (503), worded and counted here alone.
#pragma once

#include <chrono>
#include <future>
#include <memory>
#include <string_view>
#include <vector>

#include "engine/cancellation.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "server/session_cache.h"
#include "server/upload_store.h"
#include "server/work_pool.h"

namespace featureline::server {

class Metrics;

/// Reads and prepares an upload's bytes; the preparation's parallel parts run on `executor`.
/// \throw as read_mesh and prepare_mesh
MeshSession prepare_session(std::string_view bytes, MeshFormat format, const ReadMeshOptions& limits,
                            const Cancellation* cancel, Executor& executor);

/// Where a batch of lines spent its time: waiting for an engine thread (the longest wait of its
/// lines) and computing (the lines' engine time, summed), for the Server-Timing header.
struct BatchTiming {
  double queue_ms = 0;
  double engine_ms = 0;
};

class EngineJobs {
 public:
  using Clock = std::chrono::steady_clock;

  /// `pool` and `metrics` must outlive this. `deadline_s`: how long a request waits for its work.
  EngineJobs(WorkPool& pool, Metrics& metrics, double deadline_s) : pool_(pool), metrics_(metrics), deadline_s_(deadline_s) {}

  /// Runs job(cancel) on the pool and waits for it until the request's deadline. The job's
  /// Cancellation carries that deadline, so work that is refused or times out stops at its next
  /// check instead of holding an engine thread. Rethrows what the job threw.
  /// \throw HttpError 503 (overloaded, deadline_exceeded)
  template <typename Job>
  auto run(Job job) {
    const auto deadline = request_deadline();
    const auto cancel = std::make_shared<Cancellation>(deadline);
    auto future = submit_or_503([job = std::move(job), cancel]() mutable { return job(cancel.get()); });
    if (future.wait_until(deadline) != std::future_status::ready) {
      cancel->cancel();
      throw_past_deadline();
    }
    return future.get();
  }

  /// An upload read and prepared on the pool (uploads and rebuilds from the store alike).
  MeshSession prepare(std::shared_ptr<const StoredUpload> upload, const ReadMeshOptions& limits);

  /// The lines in parallel on the pool, each sharing the session's immutable mesh, in order.
  /// They share one Cancellation with the request's deadline: when it passes, or the batch is
  /// refused or a line fails, the other lines stop instead of holding threads for an answer
  /// nobody will read. \throw HttpError 503, and the first failing line's error
  std::vector<FeatureLineResult> run_lines(const std::shared_ptr<const MeshSession>& session,
                                           const std::vector<FeatureLineRequest>& lines, BatchTiming* timing = nullptr);

 private:
  Clock::time_point request_deadline() const;

  template <typename Task>
  auto submit_or_503(Task task) {
    auto future = pool_.try_submit(std::move(task));
    if (!future) throw_queue_full();
    return std::move(*future);
  }
  [[noreturn]] void throw_queue_full();
  [[noreturn]] void throw_past_deadline();

  WorkPool& pool_;
  Metrics& metrics_;
  const double deadline_s_;
};

}  // namespace featureline::server
