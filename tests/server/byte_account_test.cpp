#include "server/byte_account.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace featureline::server {
namespace {

TEST(ByteAccount, HoldsGrowShrinkAndAreGivenBack) {
  ByteAccount account(100);
  {
    ByteHold a(account), b(account);
    EXPECT_TRUE(a.hold(60));
    EXPECT_FALSE(b.hold(41));  // 60 + 41 > 100: nothing taken
    EXPECT_EQ(account.used(), 60u);
    EXPECT_TRUE(b.hold(40));
    EXPECT_TRUE(a.hold(10));   // shrinking gives back
    EXPECT_EQ(account.used(), 50u);
    EXPECT_FALSE(a.hold(200));
    EXPECT_EQ(a.bytes(), 10u);
  }
  EXPECT_EQ(account.used(), 0u);
}

TEST(ByteAccount, ThePeakIsTheMostHeldSinceItWasLastTaken) {
  ByteAccount account(100);
  {
    ByteHold a(account), b(account);
    ASSERT_TRUE(a.hold(30));
    ASSERT_TRUE(b.hold(50));
    EXPECT_FALSE(b.hold(80));  // refused: not a peak
    ASSERT_TRUE(b.hold(5));
    EXPECT_EQ(account.take_peak(), 80u);
    EXPECT_EQ(account.take_peak(), 35u);  // a new period starts at what is held now
  }
  EXPECT_EQ(account.take_peak(), 35u);  // given back since, but held at the period's start
  EXPECT_EQ(account.take_peak(), 0u);
}

TEST(ByteAccount, ConcurrentHoldsNeverExceedTheCapacity) {
  ByteAccount account(1000);
  std::atomic<bool> exceeded{false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      for (int i = 0; i < 20000; ++i) {
        ByteHold hold(account);
        if (hold.hold(std::size_t(1 + i % 300)) && account.used() > account.capacity()) exceeded = true;
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_FALSE(exceeded);
  EXPECT_EQ(account.used(), 0u);
}

}  // namespace
}  // namespace featureline::server
