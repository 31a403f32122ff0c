// The one seeded link model (codec/loss/link_model.h) that the UDP relay and
// the session cores' simulated network draw from: the same seed gives the
// same fates; the long-run shares match the model's parameters (fixed seeds,
// so each verdict is the same every run); bursts are bursts.
#include "codec/loss/link_model.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace meshstream {
namespace {

std::vector<int> Copies(SimulatedLink link, int n) {
  std::vector<int> out;
  for (int i = 0; i < n; ++i) out.push_back(link.Next().copies);
  return out;
}

// The share of `n` datagrams lost and the mean length of a run of losses.
struct LossRuns {
  double share = 0;
  double mean_run = 0;
};
LossRuns Runs(SimulatedLink link, int n) {
  int lost = 0, runs = 0;
  bool previous = false;
  for (int i = 0; i < n; ++i) {
    const bool l = link.Next().copies == 0;
    lost += l;
    if (l && !previous) ++runs;
    previous = l;
  }
  return {static_cast<double>(lost) / n, runs == 0 ? 0.0 : static_cast<double>(lost) / runs};
}

TEST(LinkModel, TheSameSeedGivesTheSameFates) {
  LinkModel m = LinkModel::Bursts(0.2, 4, 9);
  m.duplicate = 0.1;
  m.jitter_us = 5000;
  SimulatedLink a(m), b(m);
  for (int i = 0; i < 10000; ++i) {
    const DatagramFate x = a.Next(), y = b.Next();
    ASSERT_EQ(x.copies, y.copies) << i;
    ASSERT_EQ(x.delay_us[0], y.delay_us[0]) << i;
    ASSERT_EQ(x.delay_us[1], y.delay_us[1]) << i;
  }
  EXPECT_NE(Copies(SimulatedLink(m, 9), 2000), Copies(SimulatedLink(m, 10), 2000));
}

TEST(LinkModel, IndependentLossHasItsMean) {
  EXPECT_NEAR(Runs(SimulatedLink(LinkModel::Loss(0.3, 7)), 100000).share, 0.3, 0.01);
  // No loss: every datagram once, at the link's delay.
  LinkModel clean;
  clean.delay_us = 20000;
  SimulatedLink none(clean);
  for (int i = 0; i < 1000; ++i) {
    const DatagramFate f = none.Next();
    ASSERT_EQ(f.copies, 1);
    ASSERT_EQ(f.delay_us[0], 20000u);
  }
}

TEST(LinkModel, BurstsHaveTheirMeanAndLength) {
  const LinkModel m = LinkModel::Bursts(0.12, 4, 3);
  EXPECT_NEAR(m.mean_loss(), 0.12, 1e-12);
  const LossRuns bursts = Runs(SimulatedLink(m), 200000);
  EXPECT_NEAR(bursts.share, 0.12, 0.01);
  EXPECT_NEAR(bursts.mean_run, 4.0, 0.3);
  // The same mean, independent: runs of about 1 / (1 - p).
  EXPECT_LT(Runs(SimulatedLink(LinkModel::Loss(0.12, 3)), 200000).mean_run, 1.3);
}

TEST(LinkModel, DuplicatesJitterAndReorder) {
  LinkModel m;
  m.duplicate = 0.25;
  m.delay_us = 10000;
  m.jitter_us = 4000;
  m.reorder = 0.1;
  m.reorder_us = 50000;
  m.seed = 5;
  SimulatedLink link(m);
  int twice = 0, held = 0, copies = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const DatagramFate f = link.Next();
    ASSERT_GE(f.copies, 1);
    twice += f.copies == 2;
    for (int c = 0; c < f.copies; ++c) {
      ++copies;
      const uint64_t d = f.delay_us[c];
      if (d >= 50000) {
        ++held;
        ASSERT_LT(d, 10000u + 4000u + 50000u);
      } else {
        ASSERT_GE(d, 10000u);
        ASSERT_LT(d, 14000u);
      }
    }
  }
  EXPECT_NEAR(static_cast<double>(twice) / n, 0.25, 0.01);
  EXPECT_NEAR(static_cast<double>(held) / copies, 0.1, 0.01);
}

TEST(LinkModel, ValidateNamesTheFieldOutOfRange) {
  EXPECT_TRUE(LinkModel::Loss(0.5).Validate().ok());
  EXPECT_TRUE(LinkModel::Bursts(0.2, 3).Validate().ok());
  LinkModel m;
  m.duplicate = 1.5;
  const Status s = m.Validate();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("duplicate"), std::string::npos) << s.ToString();
  m = LinkModel::Loss(-0.1);
  EXPECT_NE(m.Validate().message().find("loss"), std::string::npos);
  m = LinkModel();
  m.p_bad = 0.1;
  m.p_good = 0;
  EXPECT_EQ(m.Validate().code(), StatusCode::kInvalidArgument);
  // A burst length of 1 or less is independent loss.
  EXPECT_EQ(LinkModel::Bursts(0.2, 1).p_bad, 0);
  EXPECT_EQ(LinkModel::Bursts(0.2, 1).loss, 0.2);
}

}  // namespace
}  // namespace meshstream
