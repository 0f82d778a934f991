// The bounded engine pool: results, exceptions, refusal when full.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <stdexcept>

#include "server/work_pool.h"

namespace featureline::server {
namespace {

TEST(WorkPool, RunsJobsAndReturnsResults) {
  WorkPool pool(3, 100);
  std::vector<std::future<int>> futures;
  for (int i = 0; i < 50; ++i) futures.push_back(std::move(*pool.try_submit([i] { return i * i; })));
  for (int i = 0; i < 50; ++i) EXPECT_EQ(futures[i].get(), i * i);
}

TEST(WorkPool, PassesExceptionsToTheCaller) {
  WorkPool pool(1, 10);
  auto f = *pool.try_submit([]() -> int { throw std::invalid_argument("bad keys"); });
  EXPECT_THROW(f.get(), std::invalid_argument);
}

TEST(WorkPool, RefusesWhenTheQueueIsFull) {
  WorkPool pool(1, 2);
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::atomic<bool> started{false};
  auto blocker = pool.try_submit([gate, &started] { started = true; gate.wait(); return 0; });
  ASSERT_TRUE(blocker.has_value());
  while (!started) std::this_thread::yield();
  auto a = pool.try_submit([] { return 1; });
  auto b = pool.try_submit([] { return 2; });
  auto c = pool.try_submit([] { return 3; });
  EXPECT_TRUE(a.has_value());
  EXPECT_TRUE(b.has_value());
  EXPECT_FALSE(c.has_value());  // two waiting is the capacity
  EXPECT_EQ(pool.queue_depth(), 2u);
  EXPECT_EQ(pool.running(), 1u);
  release.set_value();
  EXPECT_EQ(a->get() + b->get(), 3);
}

}  // namespace
}  // namespace featureline::server
