// The session cache: ids, LRU eviction under a byte budget, idle TTL, concurrency.
#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>

#include "engine/prepared_mesh.h"
#include "server/session_cache.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline::server {
namespace {

struct FakeClock {
  SessionCache::Clock::time_point now{};
  std::function<SessionCache::Clock::time_point()> fn() {
    return [this] { return now; };
  }
};

MeshSession session_of_bytes(std::size_t bytes) {
  static const auto mesh = prepare_mesh(featureline::testing::make_icosphere(1.0, 1));
  MeshSession s;
  s.mesh = mesh;
  s.bytes = bytes;
  return s;
}

TEST(SessionIds, Are128BitHexAndUnique) {
  std::set<std::string> ids;
  for (int i = 0; i < 10000; ++i) {
    const auto id = random_session_id();
    ASSERT_EQ(id.size(), 32u);
    ASSERT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos);
    ids.insert(id);
  }
  EXPECT_EQ(ids.size(), 10000u);
}

TEST(SessionCache, EvictsLeastRecentlyUsedBeyondBudget) {
  FakeClock clock;
  SessionCache cache({1000, std::chrono::seconds(60), clock.fn()});
  const auto a = (*cache.insert(session_of_bytes(400)))->id;
  const auto b = (*cache.insert(session_of_bytes(400)))->id;
  ASSERT_NE(cache.find(a), nullptr);  // a is now more recent than b
  const auto c = (*cache.insert(session_of_bytes(400)))->id;
  SessionCache::Miss why = SessionCache::Miss::unknown;
  EXPECT_EQ(cache.find(b, &why), nullptr);
  EXPECT_EQ(why, SessionCache::Miss::evicted);
  EXPECT_NE(cache.find(a), nullptr);
  EXPECT_NE(cache.find(c), nullptr);
  const auto stats = cache.stats();
  EXPECT_EQ(stats.entries, 2u);
  EXPECT_EQ(stats.bytes, 800u);
  EXPECT_EQ(stats.evictions, 1u);
}

TEST(SessionCache, MemoryOutsideTheSessionsCountsInTheBudget) {
  FakeClock clock;
  std::size_t scratch = 0;
  SessionCache cache({1000, std::chrono::seconds(60), clock.fn(), [&scratch] { return scratch; }});
  const auto a = (*cache.insert(session_of_bytes(400)))->id;
  const auto b = (*cache.insert(session_of_bytes(400)))->id;
  EXPECT_EQ(cache.stats().evictions, 0u);
  scratch = 300;  // 400 + 400 + 300 > 1000: the next insert makes room for the scratch too
  const auto c = (*cache.insert(session_of_bytes(200)))->id;
  SessionCache::Miss why = SessionCache::Miss::unknown;
  EXPECT_EQ(cache.find(a, &why), nullptr);
  EXPECT_EQ(why, SessionCache::Miss::evicted);
  EXPECT_NE(cache.find(b), nullptr);
  EXPECT_NE(cache.find(c), nullptr);
  EXPECT_EQ(cache.stats().bytes, 600u);  // what the sessions hold; the scratch is not theirs
}

TEST(SessionCache, RefusesASessionLargerThanTheWholeBudget) {
  SessionCache cache({1000, std::chrono::seconds(60)});
  EXPECT_FALSE(cache.insert(session_of_bytes(1001)).has_value());
  EXPECT_EQ(cache.stats().entries, 0u);
}

TEST(SessionCache, ExpiresIdleSessionsAndSaysSo) {
  FakeClock clock;
  SessionCache cache({1 << 20, std::chrono::seconds(60), clock.fn()});
  const auto a = (*cache.insert(session_of_bytes(10)))->id;
  const auto b = (*cache.insert(session_of_bytes(10)))->id;
  clock.now += std::chrono::seconds(40);
  ASSERT_NE(cache.find(a), nullptr);  // refreshes a only
  EXPECT_NEAR(cache.expires_in_s(a), 60, 1e-9);
  EXPECT_NEAR(cache.expires_in_s(b), 20, 1e-9);
  clock.now += std::chrono::seconds(30);
  SessionCache::Miss why = SessionCache::Miss::unknown;
  EXPECT_EQ(cache.find(b, &why), nullptr);
  EXPECT_EQ(why, SessionCache::Miss::expired);
  EXPECT_NE(cache.find(a), nullptr);
  EXPECT_EQ(cache.stats().expirations, 1u);
  cache.find("0123", &why);
  EXPECT_EQ(why, SessionCache::Miss::unknown);
}

TEST(SessionCache, EraseFreesMemoryOnlyWhenTheLastUserLetsGo) {
  SessionCache cache({1 << 20, std::chrono::seconds(60)});
  auto held = *cache.insert(session_of_bytes(10));
  std::weak_ptr<const MeshSession> watch = held;
  EXPECT_TRUE(cache.erase(held->id));
  EXPECT_FALSE(cache.erase(held->id));
  EXPECT_EQ(cache.find(held->id), nullptr);
  EXPECT_FALSE(watch.expired());  // a request still using it keeps it alive
  held.reset();
  EXPECT_TRUE(watch.expired());
  EXPECT_EQ(cache.stats().bytes, 0u);
}

TEST(SessionCache, PinnedSessionsNeverExpireNorAreEvicted) {
  FakeClock clock;
  SessionCache cache({1000, std::chrono::seconds(60), clock.fn()});
  MeshSession pinned = session_of_bytes(600);
  pinned.pinned = true;
  const auto sample = (*cache.insert(std::move(pinned)))->id;
  const auto a = (*cache.insert(session_of_bytes(300)))->id;
  const auto b = (*cache.insert(session_of_bytes(300)))->id;  // evicts a, not the pinned sample
  EXPECT_EQ(cache.find(a), nullptr);
  EXPECT_NE(cache.find(b), nullptr);
  EXPECT_FALSE(cache.insert(session_of_bytes(500)).has_value());  // cannot fit beside the pinned one
  EXPECT_NE(cache.find(b), nullptr);                               // and nothing was evicted in vain
  clock.now += std::chrono::hours(100);
  EXPECT_NE(cache.find(sample), nullptr);
  EXPECT_EQ(cache.find(b), nullptr);
  EXPECT_EQ(cache.expires_in_s(sample), -1);
  EXPECT_TRUE(cache.erase(sample));
  EXPECT_EQ(cache.stats().bytes, 0u);
}

TEST(SessionCache, ConcurrentUseKeepsTheBudget) {
  SessionCache cache({5000, std::chrono::seconds(60)});
  std::vector<std::thread> threads;
  std::atomic<int> found{0};
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      for (int i = 0; i < 500; ++i) {
        auto s = cache.insert(session_of_bytes(100 + std::size_t(i % 7) * 50));
        if (cache.find((*s)->id)) ++found;
        if (i % 3 == 0) cache.erase((*s)->id);
      }
    });
  for (auto& t : threads) t.join();
  const auto stats = cache.stats();
  EXPECT_LE(stats.bytes, 5000u);
  EXPECT_EQ(stats.inserts, 4000u);
  EXPECT_GT(found.load(), 0);
}

}  // namespace
}  // namespace featureline::server
