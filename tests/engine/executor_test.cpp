// The executor (engine/executor.h, engine/thread_pool.h): parallel_for covers every index once
// with no worker index shared by two participants at a time, parallel work called from the
// pool's own jobs finishes even when every thread is busy, errors reach the caller, and a
// preparation split over a pool equals the serial one exactly.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "engine/errors.h"
#include "engine/executor.h"
#include "engine/prepared_mesh.h"
#include "engine/thread_pool.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace std::chrono_literals;

// Counts the calls each index gets, and fails when two participants use one worker index at once.
struct Coverage {
  explicit Coverage(std::size_t n, std::size_t workers) : hits(n), busy(workers) {}
  std::vector<std::atomic<int>> hits;
  std::vector<std::atomic<bool>> busy;
  std::atomic<int> bad_worker{0}, shared_worker{0};

  void run(Executor& executor, std::size_t block) {
    executor.parallel_for(hits.size(), block, [&](std::size_t begin, std::size_t end, std::size_t worker) {
      if (worker >= busy.size()) {
        ++bad_worker;
        return;
      }
      if (busy[worker].exchange(true)) ++shared_worker;
      for (std::size_t i = begin; i < end; ++i) ++hits[i];
      std::this_thread::yield();  // lets other participants in while this one holds its index
      busy[worker] = false;
    });
  }
  bool every_index_once() const {
    for (const auto& h : hits)
      if (h != 1) return false;
    return true;
  }
};

// Waits for `futures` until `timeout`; false when one is not ready by then (a deadlock).
template <typename T>
bool all_ready(std::vector<std::future<T>>& futures, std::chrono::seconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  for (auto& f : futures)
    if (f.wait_until(until) != std::future_status::ready) return false;
  return true;
}

TEST(Executor, ParallelForCoversEveryIndexExactlyOnce) {
  ThreadPool pool(3);
  SerialExecutor serial;
  for (Executor* executor : {static_cast<Executor*>(&pool), static_cast<Executor*>(&serial), &default_executor()})
    for (const auto& [n, block] : std::vector<std::pair<std::size_t, std::size_t>>{
             {0, 16}, {1, 16}, {63, 16}, {64, 16}, {65, 16}, {1000, 7}, {100000, 1024}, {5, 0}}) {
      Coverage coverage(n, executor->workers());
      coverage.run(*executor, block);
      EXPECT_TRUE(coverage.every_index_once()) << "n " << n << " block " << block;
      EXPECT_EQ(coverage.bad_worker, 0);
      EXPECT_EQ(coverage.shared_worker, 0);
    }
  EXPECT_EQ(pool.workers(), 4u);
  EXPECT_EQ(serial.workers(), 1u);
}

TEST(Executor, IdleThreadsJoinIn) {
  // Blocks that wait for a second participant finish only if one of the pool's threads joins.
  ThreadPool pool(2);
  std::atomic<int> inside{0};
  std::atomic<bool> met{false};
  pool.parallel_for(8, 1, [&](std::size_t, std::size_t, std::size_t) {
    ++inside;
    const auto until = std::chrono::steady_clock::now() + 10s;
    while (inside < 2 && !met && std::chrono::steady_clock::now() < until) std::this_thread::yield();
    if (inside >= 2) met = true;
    --inside;
  });
  EXPECT_TRUE(met);
}

TEST(Executor, ParallelWorkFromEveryBusyPoolThreadFinishes) {
  // Every thread of the pool runs a job that splits work over that same pool and nests more
  // inside its blocks, so no thread is idle to help: the callers must run the blocks themselves.
  // Bounded by a timeout; on a deadlock the pool is left behind so the test can still fail.
  auto pool = std::make_unique<ThreadPool>(3, 64);
  std::atomic<int> started{0};
  std::vector<std::future<std::size_t>> jobs;
  for (int j = 0; j < 6; ++j)
    jobs.push_back(std::move(*pool->try_submit([&started, p = pool.get()] {
      ++started;
      const auto until = std::chrono::steady_clock::now() + 5s;
      while (started < 3 && std::chrono::steady_clock::now() < until) std::this_thread::yield();
      std::atomic<std::size_t> sum{0};
      p->parallel_for(64, 4, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t i = begin; i < end; ++i) {
          std::atomic<std::size_t> inner{0};
          p->run_beside([&] { p->parallel_for(256, 16, [&](std::size_t b, std::size_t e, std::size_t) { inner += e - b; }); },
                        [&] { p->parallel_for(128, 8, [&](std::size_t b, std::size_t e, std::size_t) { inner += e - b; }); });
          sum += inner;
        }
      });
      return sum.load();
    })));
  const bool finished = all_ready(jobs, 60s);
  EXPECT_TRUE(finished) << "parallel work on a busy pool did not finish within 60 s";
  if (!finished) {
    (void)pool.release();  // its threads are stuck: never join them
    return;
  }
  for (auto& job : jobs) EXPECT_EQ(job.get(), 64u * (256 + 128));
}

TEST(Executor, ErrorsReachTheCaller) {
  ThreadPool pool(2);
  EXPECT_THROW(pool.parallel_for(100000, 100,
                                 [&](std::size_t begin, std::size_t, std::size_t) {
                                   if (begin == 5000) throw InvalidInputError("block 50");
                                 }),
               InvalidInputError);
  EXPECT_THROW(pool.run_beside([] { throw GeometryError("beside"); }, [] {}), GeometryError);
  EXPECT_THROW(pool.run_beside([] {}, [] { throw CancelledError("here"); }), CancelledError);
  // The pool still works afterwards.
  Coverage coverage(10000, pool.workers());
  coverage.run(pool, 64);
  EXPECT_TRUE(coverage.every_index_once());
}

TEST(Executor, RunBesideRunsBothParts) {
  ThreadPool pool(1);
  SerialExecutor serial;
  for (Executor* executor : {static_cast<Executor*>(&pool), static_cast<Executor*>(&serial)}) {
    int beside = 0, here = 0;
    executor->run_beside([&] { beside = 1; }, [&] { here = 2; });
    EXPECT_EQ(beside + here, 3);
  }
  // With the pool's one thread busy, the caller runs `beside` itself.
  std::promise<void> release;
  auto blocker = pool.try_submit([gate = release.get_future().share()] { gate.wait(); });
  std::thread::id ran_on;
  pool.run_beside([&] { ran_on = std::this_thread::get_id(); }, [] {});
  EXPECT_EQ(ran_on, std::this_thread::get_id());
  release.set_value();
  blocker->get();
}

TEST(Executor, AStoppedPoolRunsParallelWorkOnItsCallers) {
  ThreadPool pool(2);
  pool.stop();
  EXPECT_FALSE(pool.try_submit([] { return 1; }).has_value());
  Coverage coverage(20000, pool.workers());
  coverage.run(pool, 100);
  EXPECT_TRUE(coverage.every_index_once());
}

void expect_same_preparation(const PreparedMesh& a, const PreparedMesh& b) {
  // Exact equality: the parallel parts write each vertex, edge or face from one participant,
  // and nothing is summed across participants.
  EXPECT_EQ(a.curvature().mean, b.curvature().mean);
  EXPECT_EQ(a.curvature().k_max, b.curvature().k_max);
  EXPECT_EQ(a.curvature().k_min, b.curvature().k_min);
  EXPECT_EQ(a.curvature().crease, b.curvature().crease);
  EXPECT_EQ(a.curvature().noise, b.curvature().noise);
  EXPECT_EQ(a.curvature().radius, b.curvature().radius);
  EXPECT_EQ(a.curvature().smoothing_passes, b.curvature().smoothing_passes);
  EXPECT_EQ(a.face_neighbors(), b.face_neighbors());
  EXPECT_EQ(a.triangles(), b.triangles());
  EXPECT_EQ(a.statistics().non_manifold_edges, b.statistics().non_manifold_edges);
  EXPECT_EQ(a.statistics().non_manifold_vertices, b.statistics().non_manifold_vertices);
  EXPECT_EQ(a.curvature_scale(), b.curvature_scale());
  for (std::uint32_t v = 0; v < a.n_vertices(); v += 97) EXPECT_EQ(a.nearest_vertex(a.positions()[v]), b.nearest_vertex(b.positions()[v]));
}

TEST(Executor, PreparationEqualsTheSerialOne) {
  // Noisy, with creases and several thousand vertices: the fits, the crease angles and the
  // smoothing passes all span many blocks.
  const RawMesh noisy = testing::with_noise(testing::make_crease_field(121, 0.2, 5, 0.3, 0.3).mesh, 0.1, 7);
  SerialExecutor serial;
  PrepareOptions options;
  options.executor = &serial;
  const auto expected = prepare_mesh(noisy, options);
  ASSERT_GT(expected->n_vertices(), 4u * 1024);
  ASSERT_GT(expected->curvature().smoothing_passes, 0);
  ASSERT_GT(expected->statistics().crease_edges, 0u);

  // On a pool from outside it, and as the server runs it: from jobs on the pool itself.
  ThreadPool pool(3, 16);
  options.executor = &pool;
  expect_same_preparation(*expected, *prepare_mesh(noisy, options));
  std::vector<std::future<std::shared_ptr<const PreparedMesh>>> jobs;
  for (int j = 0; j < 4; ++j) jobs.push_back(std::move(*pool.try_submit([&noisy, options] { return prepare_mesh(noisy, options); })));
  ASSERT_TRUE(all_ready(jobs, 120s));
  for (auto& job : jobs) expect_same_preparation(*expected, *job.get());
  expect_same_preparation(*expected, *prepare_mesh(noisy));  // the default executor
}

TEST(Executor, CancellationStopsAPreparationOnAPool) {
  const auto field = testing::make_ridge_field(101, 0.2, 3, 0.3, 0.25, 0.3);
  ThreadPool pool(2);
  PrepareOptions options;
  options.executor = &pool;
  Cancellation cancelled;
  cancelled.cancel();
  EXPECT_THROW(prepare_mesh(field.mesh, options, &cancelled), CancelledError);
  EXPECT_NO_THROW(prepare_mesh(field.mesh, options));
}

}  // namespace
}  // namespace featureline
