// The seeded network simulator (codec/loss/simulator.h) on a synthetic
// stream: determinism, loss rates, burst lengths, reordering, duplication and
// argument checks. No mesh is needed: a ProgressiveStream is plain bytes.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "codec/loss/simulator.h"
#include "tests/common/test_datagram.h"

namespace meshstream {
namespace {

// `refinements` refinements of `per_refinement` datagrams each; every
// datagram's payload holds its refinement and index, so they all differ.
ProgressiveStream SyntheticStream(size_t refinements, size_t per_refinement) {
  return test_util::SyntheticStream(static_cast<uint32_t>(refinements), static_cast<uint32_t>(per_refinement),
                                    [](uint32_t r, uint32_t d) {
                                      ByteWriter w;
                                      w.U32(r * 100000 + d);
                                      return std::move(w.bytes());
                                    });
}

// (refinement, datagram index) of a data datagram event; (-1, -1) for an END.
std::pair<int64_t, int64_t> Identify(const ChannelEvent& e) {
  ByteReader r(e.data, e.size);
  auto h = DatagramHeader::Parse(r);
  EXPECT_TRUE(h.ok());
  if (!h.ok() || h->kind == DatagramKind::kEnd) return {-1, -1};
  return {h->refinement, h->offset};
}

bool SameEvents(const Transmission& a, const Transmission& b) {
  if (a.events.size() != b.events.size()) return false;
  for (size_t i = 0; i < a.events.size(); ++i) {
    const ChannelEvent &x = a.events[i], &y = b.events[i];
    if (x.kind != y.kind || x.time_us != y.time_us || x.refinement != y.refinement || x.size != y.size ||
        !std::equal(x.data, x.data + x.size, y.data))
      return false;
  }
  return true;
}

TEST(LossSimulator, SameSeedGivesSameEvents) {
  const ProgressiveStream s = SyntheticStream(6, 40);
  LossModel m;
  m.loss = 0.2;
  m.burst = 3;
  m.reorder = 0.3;
  m.duplicate = 0.1;
  m.seed = 42;
  auto a = SimulateTransmission(s, 0, 6, m);
  auto b = SimulateTransmission(s, 0, 6, m);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(SameEvents(a.value(), b.value()));
  m.seed = 43;
  auto c = SimulateTransmission(s, 0, 6, m);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(SameEvents(a.value(), c.value()));
}

TEST(LossSimulator, ZeroModelDeliversEverythingOnceInOrder) {
  const ProgressiveStream s = SyntheticStream(5, 30);
  LinkTiming timing;
  auto t = SimulateTransmission(s, 7, 5, LossModel{}, timing);
  ASSERT_TRUE(t.ok()) << t.status().ToString();
  EXPECT_EQ(t->stats.datagrams_sent, 150u);
  EXPECT_EQ(t->stats.datagrams_lost + t->stats.ends_lost + t->stats.duplicated + t->stats.reordered, 0u);
  EXPECT_EQ(t->stats.ends_sent, 5u);
  ASSERT_EQ(t->end_datagrams.size(), 5u);
  // Per refinement: its datagrams in order, then its END; controls in order.
  std::vector<int64_t> next(5, 0);
  std::vector<bool> ended(5, false);
  uint32_t controls = 0;
  uint64_t last = 0;
  for (const ChannelEvent& e : t->events) {
    EXPECT_GE(e.time_us, last);
    last = e.time_us;
    if (e.kind == ChannelEvent::Kind::kControl) {
      EXPECT_EQ(e.refinement, controls);
      EXPECT_EQ(e.time_us, controls * timing.refinement_interval_us + timing.reliable_latency_us);
      EXPECT_EQ(e.data, s.control[controls].data());
      ++controls;
      continue;
    }
    ByteReader r(e.data, e.size);
    auto h = DatagramHeader::Parse(r);
    ASSERT_TRUE(h.ok());
    if (h->kind == DatagramKind::kEnd) {
      EXPECT_EQ(h->stream, 7u);  // data datagrams keep the stream's own bytes
      EXPECT_EQ(next[h->refinement], 30);
      EXPECT_EQ(h->count, 30u);
      ended[h->refinement] = true;
    } else {
      EXPECT_EQ(h->offset, next[h->refinement]);
      EXPECT_FALSE(ended[h->refinement]);
      ++next[h->refinement];
    }
  }
  EXPECT_EQ(controls, 5u);
  for (bool e : ended) EXPECT_TRUE(e);
}

TEST(LossSimulator, SendsOnlyTheRefinementsAskedFor) {
  const ProgressiveStream s = SyntheticStream(4, 3);
  auto t = SimulateTransmission(s, 0, 2, LossModel{});
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->events.size(), 2u * (1 + 3 + 1));
  EXPECT_EQ(SimulateTransmission(s, 0, 5, LossModel{}).status().code(), StatusCode::kInvalidArgument);
}

TEST(LossSimulator, IndependentLossRateMatchesTheModel) {
  const ProgressiveStream s = SyntheticStream(100, 250);  // 25,000 datagrams
  LossModel m;
  m.loss = 0.12;
  m.seed = 9;
  auto t = SimulateTransmission(s, 0, 100, m);
  ASSERT_TRUE(t.ok());
  const double rate = double(t->stats.datagrams_lost) / double(t->stats.datagrams_sent);
  EXPECT_NEAR(rate, 0.12, 0.02);
  // What was not lost arrived exactly once.
  size_t delivered = 0;
  for (const ChannelEvent& e : t->events) delivered += e.kind == ChannelEvent::Kind::kDatagram && Identify(e).first >= 0;
  EXPECT_EQ(delivered, t->stats.datagrams_sent - t->stats.datagrams_lost);
}

// Loss runs measured on the send sequence (data and END datagrams alike).
struct Runs {
  double loss_rate = 0;
  double mean_run = 0;
};
Runs MeasureRuns(const ProgressiveStream& s, const Transmission& t) {
  std::map<std::pair<int64_t, int64_t>, bool> arrived;
  std::vector<bool> end_arrived(s.control.size(), false);
  for (const ChannelEvent& e : t.events) {
    if (e.kind != ChannelEvent::Kind::kDatagram) continue;
    const auto id = Identify(e);
    if (id.first >= 0) {
      arrived[id] = true;
    } else {
      ByteReader r(e.data, e.size);
      end_arrived[DatagramHeader::Parse(r)->refinement] = true;
    }
  }
  std::vector<bool> lost;
  for (size_t i = 0; i < s.control.size(); ++i) {
    for (size_t d = 0; d < s.datagrams[i].size(); ++d) lost.push_back(!arrived.count({int64_t(i), int64_t(d)}));
    lost.push_back(!end_arrived[i]);
  }
  size_t lost_count = 0, runs = 0;
  for (size_t i = 0; i < lost.size(); ++i) {
    lost_count += lost[i];
    runs += lost[i] && (i == 0 || !lost[i - 1]);
  }
  return {double(lost_count) / double(lost.size()), runs ? double(lost_count) / double(runs) : 0.0};
}

TEST(LossSimulator, BurstyLossHasTheModelsRateAndRunLength) {
  const ProgressiveStream s = SyntheticStream(200, 250);  // 50,200 datagrams with the ENDs
  for (double burst : {2.0, 4.0}) {
    LossModel m;
    m.loss = 0.12;
    m.burst = burst;
    m.seed = 17;
    auto t = SimulateTransmission(s, 0, 200, m);
    ASSERT_TRUE(t.ok());
    const Runs r = MeasureRuns(s, t.value());
    EXPECT_NEAR(r.loss_rate, 0.12, 0.02) << "burst " << burst;
    EXPECT_NEAR(r.mean_run, burst, 0.15 * burst) << "burst " << burst;
    EXPECT_EQ(t->stats.datagrams_lost + t->stats.ends_lost,
              static_cast<uint64_t>(std::llround(r.loss_rate * 50200)));
  }
  // Independent losses: runs average 1 / (1 - loss).
  LossModel m;
  m.loss = 0.12;
  m.seed = 17;
  auto t = SimulateTransmission(s, 0, 200, m);
  ASSERT_TRUE(t.ok());
  EXPECT_NEAR(MeasureRuns(s, t.value()).mean_run, 1 / 0.88, 0.1);
}

TEST(LossSimulator, HighLossWithShortBurstsKeepsTheRate) {
  const ProgressiveStream s = SyntheticStream(100, 200);
  LossModel m;
  m.loss = 0.8;  // above burst / (1 + burst): good runs cannot be shorter than one
  m.burst = 2;
  auto t = SimulateTransmission(s, 0, 100, m);
  ASSERT_TRUE(t.ok());
  EXPECT_NEAR(MeasureRuns(s, t.value()).loss_rate, 0.8, 0.02);
}

TEST(LossSimulator, FullLossDropsEverything) {
  const ProgressiveStream s = SyntheticStream(3, 10);
  for (double burst : {0.0, 5.0}) {
    LossModel m;
    m.loss = 1;
    m.burst = burst;
    m.duplicate = 1;
    auto t = SimulateTransmission(s, 0, 3, m);
    ASSERT_TRUE(t.ok());
    EXPECT_EQ(t->stats.datagrams_lost, 30u);
    EXPECT_EQ(t->stats.ends_lost, 3u);
    for (const ChannelEvent& e : t->events) EXPECT_EQ(e.kind, ChannelEvent::Kind::kControl);
  }
}

TEST(LossSimulator, DuplicatesAndReorderingMatchTheirFractions) {
  const ProgressiveStream s = SyntheticStream(100, 200);  // 20,000 datagrams
  LossModel m;
  m.reorder = 0.25;
  m.duplicate = 0.1;
  m.seed = 5;
  LinkTiming timing;
  timing.reorder_delay_us = 3000;
  auto t = SimulateTransmission(s, 0, 100, m, timing);
  ASSERT_TRUE(t.ok());
  const double sent = double(t->stats.datagrams_sent + t->stats.ends_sent);
  EXPECT_NEAR(t->stats.reordered / sent, 0.25, 0.02);
  EXPECT_NEAR(t->stats.duplicated / sent, 0.1, 0.02);
  EXPECT_EQ(t->stats.datagrams_lost, 0u);
  // Every datagram arrives at least once, copies exactly twice; arrival is
  // within the latency plus the reorder delay plus one datagram interval.
  std::map<std::pair<int64_t, int64_t>, int> copies;
  size_t out_of_order = 0;
  std::vector<int64_t> highest(100, -1);
  for (const ChannelEvent& e : t->events) {
    if (e.kind != ChannelEvent::Kind::kDatagram) continue;
    const auto id = Identify(e);
    if (id.first < 0) continue;
    ++copies[id];
    const uint64_t send = id.first * timing.refinement_interval_us + id.second * timing.datagram_interval_us;
    EXPECT_GE(e.time_us, send + timing.unreliable_latency_us);
    EXPECT_LE(e.time_us,
              send + timing.unreliable_latency_us + timing.reorder_delay_us + timing.datagram_interval_us);
    if (id.second < highest[id.first]) ++out_of_order;
    highest[id.first] = std::max(highest[id.first], id.second);
  }
  EXPECT_EQ(copies.size(), 20000u);
  size_t twice = 0;
  for (const auto& c : copies) {
    EXPECT_LE(c.second, 2);
    twice += c.second == 2;
  }
  EXPECT_GT(out_of_order, 0u);
  // ENDs are duplicated too, so data datagrams alone are a part of the count.
  EXPECT_LE(twice, t->stats.duplicated);
  EXPECT_GT(twice, t->stats.duplicated * 9 / 10);
}

TEST(LossSimulator, LossPatternDoesNotDependOnReorderOrDuplication) {
  const ProgressiveStream s = SyntheticStream(10, 50);
  LossModel m;
  m.loss = 0.3;
  m.burst = 2;
  m.seed = 77;
  auto plain = SimulateTransmission(s, 0, 10, m);
  m.reorder = 0.5;
  m.duplicate = 0.5;
  auto shaken = SimulateTransmission(s, 0, 10, m);
  ASSERT_TRUE(plain.ok() && shaken.ok());
  EXPECT_EQ(plain->stats.datagrams_lost, shaken->stats.datagrams_lost);
  EXPECT_EQ(MeasureRuns(s, plain.value()).loss_rate, MeasureRuns(s, shaken.value()).loss_rate);
}

TEST(LossSimulator, EventsSurviveAMove) {
  const ProgressiveStream s = SyntheticStream(2, 2);
  auto t = SimulateTransmission(s, 0, 2, LossModel{});
  ASSERT_TRUE(t.ok());
  Transmission moved = std::move(t).value();
  size_t ends = 0;
  for (const ChannelEvent& e : moved.events)
    for (const auto& end : moved.end_datagrams) ends += e.data == end.data();
  EXPECT_EQ(ends, 2u);
}

TEST(LossSimulator, ValidateNamesTheBadField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    LossModel model;
    const char* field;
  };
  std::vector<Case> cases;
  auto add = [&](double LossModel::*field, double value, const char* name) {
    LossModel m;
    m.*field = value;
    cases.push_back({m, name});
  };
  add(&LossModel::loss, -0.1, "loss");
  add(&LossModel::loss, 1.5, "loss");
  add(&LossModel::loss, nan, "loss");
  add(&LossModel::burst, -1, "burst");
  add(&LossModel::burst, nan, "burst");
  add(&LossModel::burst, inf, "burst");
  add(&LossModel::reorder, 2, "reorder");
  add(&LossModel::reorder, nan, "reorder");
  add(&LossModel::duplicate, -0.5, "duplicate");
  add(&LossModel::duplicate, nan, "duplicate");
  const ProgressiveStream s = SyntheticStream(1, 1);
  for (const Case& c : cases) {
    const Status st = c.model.Validate();
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument) << c.field;
    EXPECT_NE(st.message().find(c.field), std::string::npos) << st.message();
    EXPECT_EQ(SimulateTransmission(s, 0, 1, c.model).status().code(), StatusCode::kInvalidArgument);
  }
  LossModel edge;
  edge.loss = 1;
  edge.reorder = 1;
  edge.duplicate = 0;
  edge.burst = 1;
  EXPECT_TRUE(edge.Validate().ok());
}

TEST(LossSimulator, HostileTimingIsRefused) {
  const ProgressiveStream s = SyntheticStream(3, 2);
  LinkTiming timing;
  timing.refinement_interval_us = UINT64_MAX / 2;
  EXPECT_EQ(SimulateTransmission(s, 0, 3, LossModel{}, timing).status().code(), StatusCode::kInvalidArgument);
}

// The reliable cut: its refinements' datagrams and ENDs all arrive (on the
// reliable channel's latency), and the other refinements see exactly the
// loss pattern they see without a cut, for the same seed.
TEST(LossSimulator, ReliableRefinementsArriveAndLeaveTheOthersPatternAlone) {
  const ProgressiveStream s = SyntheticStream(6, 40);
  LossModel m;
  m.loss = 0.3;
  m.seed = 5;
  LinkTiming timing;
  auto plain = SimulateTransmission(s, 0, 6, m, timing);
  auto cut = SimulateTransmission(s, 0, 6, m, timing, {1, 4});
  ASSERT_TRUE(plain.ok() && cut.ok());
  std::map<const uint8_t*, int> in_plain, in_cut;
  for (const ChannelEvent& e : plain->events) {
    if (e.kind == ChannelEvent::Kind::kDatagram) ++in_plain[e.data];
  }
  for (const ChannelEvent& e : cut->events) {
    if (e.kind == ChannelEvent::Kind::kDatagram) ++in_cut[e.data];
  }
  for (size_t i = 0; i < 6; ++i) {
    for (const auto& d : s.datagrams[i]) {
      if (i == 1 || i == 4) {
        EXPECT_EQ(in_cut[d.data()], 1) << "refinement " << i << " is in the cut: never lost";
      } else {
        EXPECT_EQ(in_cut[d.data()], in_plain[d.data()]) << "refinement " << i << ": the same pattern";
      }
    }
  }
  EXPECT_EQ(cut->stats.reliable_datagrams, 80u);
  EXPECT_EQ(cut->stats.reliable_bytes, 80 * s.datagrams[1][0].size());
  EXPECT_LT(cut->stats.datagrams_lost, plain->stats.datagrams_lost);
  // On the reliable channel's latency, after its control block.
  for (const ChannelEvent& e : cut->events) {
    if (e.kind == ChannelEvent::Kind::kDatagram && e.data == s.datagrams[4][0].data()) {
      EXPECT_EQ(e.time_us, 4 * timing.refinement_interval_us + timing.reliable_latency_us);
    }
  }
  EXPECT_FALSE(SimulateTransmission(s, 0, 6, m, timing, {4, 1}).ok()) << "out of order";
  EXPECT_FALSE(SimulateTransmission(s, 0, 6, m, timing, {6}).ok()) << "out of range";
}

}  // namespace
}  // namespace meshstream
