#include "net/replay_window.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <set>

namespace meshstream {
namespace {

TEST(ReplayWindow, AcceptsOnceRefusesDuplicates) {
  ReplayWindow w;
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(w.Accept(10), DropReason::kNone);
  EXPECT_EQ(w.Accept(10), DropReason::kReplayed);
  EXPECT_EQ(w.Accept(11), DropReason::kNone);
  EXPECT_EQ(w.Accept(10), DropReason::kReplayed);
  EXPECT_EQ(w.Accept(11), DropReason::kReplayed);
  EXPECT_EQ(w.highest(), 11u);
}

TEST(ReplayWindow, ReorderingWithinTheWindow) {
  ReplayWindow w;
  EXPECT_EQ(w.Accept(200), DropReason::kNone);
  for (uint64_t n = 199; n > 200 - ReplayWindow::kWindow; --n) EXPECT_EQ(w.Accept(n), DropReason::kNone) << n;
  EXPECT_EQ(w.Accept(200 - ReplayWindow::kWindow), DropReason::kTooOld);
  for (uint64_t n = 200 - ReplayWindow::kWindow + 1; n <= 200; ++n) EXPECT_EQ(w.Accept(n), DropReason::kReplayed) << n;
}

TEST(ReplayWindow, FarJumpForgetsTheOldWindow) {
  ReplayWindow w;
  EXPECT_EQ(w.Accept(5), DropReason::kNone);
  EXPECT_EQ(w.Accept(5 + 1000), DropReason::kNone);
  EXPECT_EQ(w.Accept(5), DropReason::kTooOld);
  EXPECT_EQ(w.Accept(1005 - 127), DropReason::kNone);
  EXPECT_EQ(w.Accept(1005 - 128), DropReason::kTooOld);
  // Shifts of exactly 64 and 127 keep the bits that are still inside.
  ReplayWindow v;
  EXPECT_EQ(v.Accept(1000), DropReason::kNone);
  EXPECT_EQ(v.Accept(1064), DropReason::kNone);
  EXPECT_EQ(v.Accept(1000), DropReason::kReplayed);
  EXPECT_EQ(v.Accept(1127), DropReason::kNone);
  EXPECT_EQ(v.Accept(1000), DropReason::kReplayed);
  EXPECT_EQ(v.Accept(1064), DropReason::kReplayed);
  EXPECT_EQ(v.Accept(1001), DropReason::kNone);
  EXPECT_EQ(v.Accept(1128), DropReason::kNone);
  EXPECT_EQ(v.Accept(1000), DropReason::kTooOld);
  EXPECT_EQ(v.Accept(1001), DropReason::kReplayed);
}

TEST(ReplayWindow, ZeroAndMax) {
  ReplayWindow w;
  EXPECT_EQ(w.Accept(0), DropReason::kNone);
  EXPECT_EQ(w.Accept(0), DropReason::kReplayed);
  EXPECT_EQ(w.Accept(UINT64_MAX), DropReason::kNone);
  EXPECT_EQ(w.Accept(UINT64_MAX), DropReason::kReplayed);
  EXPECT_EQ(w.Accept(0), DropReason::kTooOld);
  EXPECT_EQ(w.Accept(UINT64_MAX - 1), DropReason::kNone);
  EXPECT_EQ(w.Accept(UINT64_MAX - 127), DropReason::kNone);
  EXPECT_EQ(w.Accept(UINT64_MAX - 128), DropReason::kTooOld);
  ReplayWindow first_max;
  EXPECT_EQ(first_max.Accept(UINT64_MAX), DropReason::kNone);
  EXPECT_EQ(first_max.Accept(UINT64_MAX - 5), DropReason::kNone);
}

TEST(ReplayWindow, CheckDoesNotRecord) {
  ReplayWindow w;
  EXPECT_EQ(w.Check(3), DropReason::kNone);
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(w.Accept(3), DropReason::kNone);
  EXPECT_EQ(w.Check(3), DropReason::kReplayed);
  EXPECT_EQ(w.Check(4), DropReason::kNone);
  EXPECT_EQ(w.Accept(4), DropReason::kNone);
}

// Against a model that remembers every accepted number.
TEST(ReplayWindow, MatchesAModel) {
  std::mt19937_64 rng(7);
  ReplayWindow w;
  std::set<uint64_t> seen;
  uint64_t highest = 0;
  for (int i = 0; i < 20000; ++i) {
    const uint64_t base = highest > 150 ? highest - 150 : 0;
    const uint64_t n = (rng() % 50 == 0) ? highest + rng() % 300 : base + rng() % 200;
    DropReason expected;
    if (seen.empty() || n > highest) expected = DropReason::kNone;
    else if (highest - n >= ReplayWindow::kWindow) expected = DropReason::kTooOld;
    else expected = seen.count(n) ? DropReason::kReplayed : DropReason::kNone;
    ASSERT_EQ(w.Accept(n), expected) << "step " << i << " n " << n;
    if (expected == DropReason::kNone) {
      seen.insert(n);
      if (n > highest) highest = n;
    }
  }
}

}  // namespace
}  // namespace meshstream
