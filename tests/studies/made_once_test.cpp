// MadeOnce (base/made_once.h): one maker per key however many threads ask, a failed making
// forgotten, and only the last `keep` keys held.
#include "shadefit/base/made_once.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace shadefit {
namespace {

TEST(MadeOnceTest, ThreadsAskingForOneKeyShareOneMaking) {
  MadeOnce<int> values;
  std::atomic<int> makings = 0;
  std::vector<std::thread> threads;
  std::vector<int> got(8, 0);
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      got[i] = values.Get("a", [&] {
        ++makings;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));  // Others arrive meanwhile.
        return 42;
      });
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(makings.load(), 1);
  for (int v : got) EXPECT_EQ(v, 42);
  EXPECT_EQ(values.Get("b", [] { return 7; }), 7);
}

TEST(MadeOnceTest, AFailedMakingIsForgotten) {
  MadeOnce<int> values;
  EXPECT_THROW(values.Get("a", []() -> int { throw std::runtime_error("no"); }),
               std::runtime_error);
  EXPECT_EQ(values.Get("a", [] { return 3; }), 3);  // Tried again, not the stored failure.
}

TEST(MadeOnceTest, KeepsTheLastKeys) {
  MadeOnce<int> values(2);
  int makings = 0;
  const auto make = [&] { return ++makings; };
  values.Get("a", make);
  values.Get("b", make);
  values.Get("c", make);                 // Evicts "a".
  EXPECT_EQ(values.Get("c", make), 3);   // Still held.
  EXPECT_EQ(values.Get("a", make), 4);   // Made again.
  EXPECT_EQ(makings, 4);
}

}  // namespace
}  // namespace shadefit
