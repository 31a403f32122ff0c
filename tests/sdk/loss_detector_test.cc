// The receiver's loss detection by packet numbers (sdk/loss_detector.h),
// alone: the packet rule, the time rule and its window, how reordering and
// spurious declarations widen it, and the bounded history. Times are the
// test's own numbers (microseconds); nothing here reads a clock.
#include "sdk/loss_detector.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace meshstream::sdk {
namespace {

constexpr uint64_t kStraggler = 50000;

TEST(LossDetector, WithoutAnRttTheRulesAreOffAndTheWindowIsTheStragglerTimeout) {
  LossDetector d(kStraggler);
  EXPECT_FALSE(d.active());
  EXPECT_EQ(d.WindowUs(), kStraggler);
  d.SetRtt(80000);
  EXPECT_TRUE(d.active());
  EXPECT_EQ(d.WindowUs(), 10000u);  // an eighth of the round trip
  d.SetRtt(4000);
  EXPECT_EQ(d.WindowUs(), LossDetector::kMinReorderWindowUs);  // at least 2 ms
  d.SetRtt(2000000);
  EXPECT_EQ(d.WindowUs(), kStraggler);  // never more than the straggler timeout
}

TEST(LossDetector, ThePacketRuleNeedsThreeLaterNumbers) {
  LossDetector d(kStraggler);
  d.SetRtt(40000);
  EXPECT_FALSE(d.Seen(0));
  for (uint64_t n = 10; n <= 12; ++n) d.OnPacket(n, 1000 * n);
  EXPECT_TRUE(d.Seen(12));
  EXPECT_FALSE(d.Seen(13));
  EXPECT_TRUE(d.LostByPackets(9));    // 12 = 9 + 3 arrived
  EXPECT_FALSE(d.LostByPackets(10));  // 13 has not
  d.OnPacket(13, 13000);
  EXPECT_TRUE(d.LostByPackets(10));
}

TEST(LossDetector, TheTimeRuleWaitsTheWindowAfterALaterDatagram) {
  LossDetector d(kStraggler);
  d.SetRtt(80000);  // window 10 ms
  EXPECT_FALSE(d.LostByTime(0, 1000000)) << "nothing numbered later has arrived";
  EXPECT_FALSE(d.LostByTime(100000, 109999));
  EXPECT_TRUE(d.LostByTime(100000, 110000));
}

TEST(LossDetector, ReorderingWidensTheWindowAndStopsThePacketRule) {
  LossDetector d(kStraggler);
  d.SetRtt(80000);  // 10 ms
  d.OnPacket(1, 0);
  d.OnPacket(5, 1000);
  d.OnPacket(3, 17000);  // 16 ms after 5, the first numbered above it
  EXPECT_EQ(d.reorder_seen_us(), 16000u);
  EXPECT_EQ(d.WindowUs(), 18000u);  // 16 ms x 9/8
  EXPECT_TRUE(d.packet_rule()) << "3 came less than three numbers behind the highest";
  d.OnPacket(9, 18000);
  d.OnPacket(4, 19000);  // 9 >= 4 + 3: reordering beyond the packet rule
  EXPECT_FALSE(d.packet_rule());
  EXPECT_FALSE(d.LostByPackets(1));
}

TEST(LossDetector, SpuriousDeclarationsDoubleTheWindowUpToTheCap) {
  LossDetector d(kStraggler);
  d.SetRtt(80000);  // 10 ms
  d.OnSpurious();
  EXPECT_FALSE(d.packet_rule());
  EXPECT_EQ(d.WindowUs(), 20000u);
  d.OnSpurious();
  EXPECT_EQ(d.WindowUs(), 40000u);
  d.OnSpurious();
  EXPECT_EQ(d.WindowUs(), kStraggler);
}

TEST(LossDetector, AReorderedDatagramOlderThanTheHistoryTakesTheCap) {
  LossDetector d(kStraggler);
  d.SetRtt(80000);
  for (uint64_t n = 0; n < LossDetector::kRiseHistory + 10; ++n) d.OnPacket(1000 + n, n);
  d.OnPacket(5, 100000);  // before every number kept
  EXPECT_EQ(d.WindowUs(), kStraggler);
  // Untrusted numbers: the largest value and 0 are fine.
  d.OnPacket(UINT64_MAX, 100001);
  EXPECT_TRUE(d.Seen(UINT64_MAX));
  d.OnPacket(0, 100002);
}

}  // namespace
}  // namespace meshstream::sdk
