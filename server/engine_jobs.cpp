#include "server/engine_jobs.h"

#include <algorithm>
#include <utility>

#include "engine/valid_range.h"
#include "server/http_errors.h"
#include "server/metrics.h"

namespace featureline::server {

MeshSession prepare_session(std::string_view bytes, MeshFormat format, const ReadMeshOptions& limits,
                            const Cancellation* cancel, Executor& executor) {
  const auto t0 = EngineJobs::Clock::now();
  RawMesh raw = read_mesh(bytes, format, limits);
  MeshSession s;
  s.load_ms = std::chrono::duration<double, std::milli>(EngineJobs::Clock::now() - t0).count();
  s.format = format;
  PrepareOptions options;
  options.max_memory_bytes = limits.memory_budget_bytes;  // nothing is prepared that the cache could never keep
  options.executor = &executor;
  s.mesh = prepare_mesh(std::move(raw), options, cancel);
  s.bytes = s.mesh->memory_bytes();
  return s;
}

MeshSession EngineJobs::prepare(std::shared_ptr<const StoredUpload> upload, const ReadMeshOptions& limits) {
  return run([this, upload = std::move(upload), limits](const Cancellation* cancel) {
    return prepare_session(upload->bytes, upload->format, limits, cancel, pool_);
  });
}

std::vector<FeatureLineResult> EngineJobs::run_lines(const std::shared_ptr<const MeshSession>& session,
                                                     const std::vector<FeatureLineRequest>& lines, BatchTiming* timing) {
  const auto deadline = request_deadline();
  const auto cancel = std::make_shared<Cancellation>(deadline);
  struct CancelUnlessDone {
    std::shared_ptr<Cancellation> cancel;
    bool done = false;
    ~CancelUnlessDone() {
      if (!done) cancel->cancel();
    }
  } guard{cancel};
  using Timed = std::pair<FeatureLineResult, double>;  // the line, and its wait for a thread in ms
  std::vector<std::future<Timed>> futures;
  for (auto line : lines) {
    line.cancel = cancel.get();
    futures.push_back(submit_or_503([session, line, cancel, &pool = pool_, queued = Clock::now()]() mutable {
      const double waited = std::chrono::duration<double, std::milli>(Clock::now() - queued).count();
      // Pieces side by side only while engine threads are idle: run on two cores, a line costs
      // about a tenth more CPU (bench_server lost 5-15% of its lines/s at 8-32 connections).
      SerialExecutor one_thread;
      const bool idle = pool.queue_depth() == 0 && pool.running() < pool.threads();
      line.executor = idle ? static_cast<Executor*>(&pool) : &one_thread;
      return Timed{detect_feature_line(*session->mesh, line), waited};
    }));
  }
  std::vector<FeatureLineResult> results;
  for (auto& f : futures) {
    if (f.wait_until(deadline) != std::future_status::ready) throw_past_deadline();
    auto [result, waited] = f.get();
    if (timing != nullptr) {
      timing->queue_ms = std::max(timing->queue_ms, waited);
      timing->engine_ms += result.timings.total_ms;
    }
    results.push_back(std::move(result));
  }
  guard.done = true;
  return results;
}

EngineJobs::Clock::time_point EngineJobs::request_deadline() const {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(deadline_s_));
}

void EngineJobs::throw_queue_full() {
  metrics_.record_rejected("queue_full");
  throw HttpError(503, "overloaded", "the server is busy; retry shortly", {{"Retry-After", "1"}});
}

void EngineJobs::throw_past_deadline() {
  metrics_.record_rejected("deadline");
  throw HttpError(503, "deadline_exceeded", "the request took longer than the server's deadline of " + format_number(deadline_s_) + " s",
                  {{"Retry-After", "5"}});
}

}  // namespace featureline::server
