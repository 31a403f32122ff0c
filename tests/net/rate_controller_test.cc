// The session's rate controller: slow start doubles per round, a queue
// (RTT above min_rtt + max(4 ms, min_rtt / 2)) or overwhelming loss cuts by
// 0.7 at most once per round, random loss below the ceiling does not, the
// caps hold.
#include "net/rate_controller.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

RateControllerOptions Options() {
  RateControllerOptions o;
  o.initial_bps = 10e6;
  o.min_bps = 1e6;
  o.max_bps = 100e6;
  return o;
}

TEST(RateController, SlowStartDoublesOncePerRound) {
  RateController c(Options());
  c.OnRttSample(10000);  // 10 ms
  uint64_t t = 1000000;
  c.OnReport(t, 10, 0, 10000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 20e6);
  // Within the same round: no change.
  c.OnReport(t + 5000, 10, 0, 10000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 20e6);
  c.OnReport(t + 10000, 10, 0, 10000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 40e6);
  c.OnReport(t + 20000, 10, 0, 10000);
  c.OnReport(t + 30000, 10, 0, 10000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 100e6) << "capped at max_bps";
  EXPECT_TRUE(c.slow_start());
}

TEST(RateController, AQueueCutsTheRateAndEndsSlowStart) {
  RateController c(Options());
  c.OnRttSample(10000);
  uint64_t t = 1000000;
  c.OnReport(t, 10, 0, 10000);  // 20 Mbit/s
  // 10 ms + max(4 ms, 5 ms) = 15 ms allowed; 16 ms is a queue.
  c.OnReport(t + 20000, 10, 0, 16000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 14e6);
  EXPECT_FALSE(c.slow_start());
  EXPECT_EQ(c.decreases(), 1u);
  // One cut per round, however many reports say so.
  c.OnReport(t + 21000, 10, 0, 30000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 14e6);
  // After slow start: additive growth, max(0.5 Mbit/s, 5 %).
  c.OnReport(t + 100000, 10, 0, 10000);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 14e6 + 0.7e6);
}

TEST(RateController, RandomLossBelowTheCeilingIsNotCongestion) {
  RateController c(Options());
  uint64_t t = 1000000;
  // 30 % loss, flat RTT: the codec predicts it; the rate keeps growing.
  for (int i = 0; i < 6; ++i) c.OnReport(t + static_cast<uint64_t>(i) * 20000, 7, 3, 10000);
  EXPECT_EQ(c.decreases(), 0u);
  EXPECT_GT(c.rate_bps(), 10e6);
  EXPECT_NEAR(c.smoothed_loss(), 0.3, 1e-9);
}

TEST(RateController, OverwhelmingLossIsCongestion) {
  RateController c(Options());
  uint64_t t = 1000000;
  for (int i = 0; i < 6; ++i) c.OnReport(t + static_cast<uint64_t>(i) * 20000, 2, 8, 0);
  EXPECT_GE(c.decreases(), 1u);
  EXPECT_LT(c.rate_bps(), 10e6);
  // Down to the floor, never below.
  for (int i = 6; i < 100; ++i) c.OnReport(t + static_cast<uint64_t>(i) * 20000, 0, 10, 0);
  EXPECT_DOUBLE_EQ(c.rate_bps(), 1e6);
}

TEST(RateController, TheMinimumAndSmoothedRtt) {
  RateController c(Options());
  c.OnRttSample(0);  // ignored
  EXPECT_EQ(c.min_rtt_us(), 0u);
  c.OnRttSample(8000);
  c.OnRttSample(16000);
  EXPECT_EQ(c.min_rtt_us(), 8000u);
  EXPECT_EQ(c.srtt_us(), (7 * 8000 + 16000) / 8u);
}

// A 20 Mbit/s path whose bottleneck drops rather than queues (a policer, a
// shallow tbf): the RTT never grows, so only the delivery rate can stop the
// rate. Each round the receiver measures min(rate, 20 Mbit/s).
double RunOnAPolicedPath(RateController& c, bool delivery_samples, int rounds, bool* ended_slow_start) {
  constexpr double kPath = 20e6;
  constexpr uint64_t kRound = 40000;
  c.OnRttSample(kRound);
  double highest = 0;
  uint64_t t = 1000000;
  for (int i = 0; i < rounds; ++i, t += kRound) {
    if (delivery_samples) c.OnDeliverySample(t, std::min(c.rate_bps(), kPath));
    c.OnReport(t, 10, 0, kRound);
    highest = std::max(highest, c.rate_bps());
  }
  *ended_slow_start = !c.slow_start();
  return highest;
}

TEST(RateController, TheDeliveryRateBoundsTheRateWhereNoQueueShows) {
  RateControllerOptions o;
  o.initial_bps = 16e6;
  o.max_bps = 400e6;
  bool ended = false;
  RateController blind(o);
  EXPECT_DOUBLE_EQ(RunOnAPolicedPath(blind, false, 12, &ended), 400e6) << "without delivery samples it runs away";
  RateController c(o);
  const double highest = RunOnAPolicedPath(c, true, 12, &ended);
  EXPECT_LE(highest, RateController::kStartupGain * 20e6) << "startup: never past twice the path";
  EXPECT_TRUE(ended) << "the delivery rate stopped growing: the pipe is full";
  EXPECT_LE(c.rate_bps(), RateController::kProbeGain * 20e6);
  EXPECT_GE(c.rate_bps(), 20e6);
  EXPECT_DOUBLE_EQ(c.btlbw_bps(), 20e6);
}

TEST(RateController, SlowStartGoesOnWhileTheDeliveryRateGrows) {
  RateControllerOptions o;
  o.initial_bps = 1e6;
  o.max_bps = 1e9;
  RateController c(o);
  c.OnRttSample(10000);
  uint64_t t = 1000000;
  for (int i = 0; i < 6; ++i, t += 10000) {
    c.OnDeliverySample(t, c.rate_bps());  // the path takes everything: app-limited samples
    c.OnReport(t, 10, 0, 10000);
    EXPECT_TRUE(c.slow_start()) << "round " << i;
  }
  EXPECT_DOUBLE_EQ(c.rate_bps(), 64e6);
}

TEST(RateController, DeliverySamplesAgeOutOfTheFilter) {
  RateController c(Options());
  c.OnRttSample(10000);
  c.OnDeliverySample(1000000, 80e6);
  c.OnDeliverySample(1005000, 30e6);
  EXPECT_DOUBLE_EQ(c.btlbw_bps(), 80e6);
  // Ten rounds (100 ms) later the 80 has gone.
  c.OnDeliverySample(1000000 + 10 * 10000 + 1, 20e6);
  EXPECT_DOUBLE_EQ(c.btlbw_bps(), 30e6);
  c.OnDeliverySample(1200000, 0);  // no sample
  EXPECT_DOUBLE_EQ(c.btlbw_bps(), 30e6);
}

}  // namespace
}  // namespace meshstream
