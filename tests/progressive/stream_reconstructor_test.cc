// The stream reconstructor (codec/loss/reconstructor.h) on a real stream
// (fandisk, tests/common/real_stream.h): reordering and duplicates change
// nothing, the readiness rule (both ENDs and every datagram, or the
// straggler timeout), late, malformed and foreign datagrams, and the memory
// bounds. Nothing here loses a data datagram (see lossy_decode_test.cc).
#include <gtest/gtest.h>

#include "codec/loss/simulator.h"
#include "codec/loss/reconstructor.h"
#include "tests/common/real_stream.h"

namespace meshstream {
namespace {

using test_util::Fandisk;
using test_util::kRealStreamId;
using test_util::RealStream;

StreamReconstructor Make(const ReconstructorOptions& options = {}) {
  const RealStream& s = Fandisk();
  auto rec = StreamReconstructor::Create(s.stream.header.data(), s.stream.header.size(), kRealStreamId, options);
  EXPECT_TRUE(rec.ok()) << rec.status().ToString();
  EXPECT_TRUE(rec->SetBase(s.base).ok());
  return std::move(rec).value();
}

void ExpectLevel(const StreamReconstructor& rec, size_t level) {
  const QuantizedMesh mesh = rec.reader().Mesh();
  const QuantizedMesh& want = Fandisk().levels[level];
  EXPECT_EQ(rec.applied(), level);
  EXPECT_EQ(mesh.positions, want.positions) << "level " << level;
  EXPECT_EQ(mesh.attributes, want.attributes) << "level " << level;
  EXPECT_EQ(mesh.indices, want.indices) << "level " << level;
}

void SendData(StreamReconstructor& rec, size_t refinement, uint64_t now) {
  for (const auto& d : Fandisk().stream.datagrams[refinement]) rec.OnDatagram(d.data(), d.size(), now);
}
void SendEnd(StreamReconstructor& rec, size_t refinement, uint64_t now) {
  const auto end = MakeEndDatagram(kRealStreamId, static_cast<uint32_t>(refinement),
                                   static_cast<uint32_t>(Fandisk().stream.datagrams[refinement].size()));
  rec.OnDatagram(end.data(), end.size(), now);
}
Status SendControl(StreamReconstructor& rec, size_t refinement, uint64_t now) {
  const auto& c = Fandisk().stream.control[refinement];
  return rec.OnControl(c.data(), c.size(), now);
}

// A datagram with its header re-serialized after `edit`, payload kept.
std::vector<uint8_t> Rewrite(const std::vector<uint8_t>& d, void (*edit)(DatagramHeader&)) {
  ByteReader r(d.data(), d.size());
  DatagramHeader h = DatagramHeader::Parse(r).value();
  edit(h);
  ByteWriter w;
  h.Serialize(w);
  std::vector<uint8_t> out = std::move(w.bytes());
  out.insert(out.end(), d.begin() + r.position(), d.end());
  return out;
}

TEST(StreamReconstructor, TheStreamHasSeveralDatagramsPerRefinement) {
  const RealStream& s = Fandisk();
  ASSERT_GE(s.stream.control.size(), 4u);
  size_t most = 0;
  for (const auto& level : s.stream.datagrams) most = std::max(most, level.size());
  EXPECT_GE(most, 4u);
}

TEST(StreamReconstructor, ReorderingAndDuplicatesGiveTheLosslessMesh) {
  const RealStream& s = Fandisk();
  LossModel model;
  model.reorder = 0.8;
  model.duplicate = 0.5;
  model.seed = 11;
  LinkTiming timing;
  timing.reorder_delay_us = 60000;  // datagrams overtake whole refinements
  auto sent = SimulateTransmission(s.stream, kRealStreamId, s.stream.control.size(), model, timing);
  ASSERT_TRUE(sent.ok());
  ASSERT_GT(sent->stats.reordered, 0u);
  ASSERT_GT(sent->stats.duplicated, 0u);
  StreamReconstructor rec = Make();
  for (const ChannelEvent& e : sent->events) {
    if (e.kind == ChannelEvent::Kind::kControl) ASSERT_TRUE(rec.OnControl(e.data, e.size, e.time_us).ok());
    else rec.OnDatagram(e.data, e.size, e.time_us);
    ASSERT_TRUE(rec.Poll(e.time_us).ok());
  }
  EXPECT_TRUE(rec.done());
  ASSERT_TRUE(rec.Flush().ok());
  ExpectLevel(rec, s.stream.control.size());
  const ReconstructorStats& st = rec.stats();
  EXPECT_EQ(st.finished_complete, s.stream.control.size());
  EXPECT_EQ(st.finished_timeout, 0u);
  EXPECT_EQ(st.rejected + st.overflow, 0u);
  EXPECT_EQ(st.datagrams + st.ends, sent->events.size() - s.stream.control.size());
  EXPECT_EQ(st.accepted, s.stream.datagram_count());
  // A copy that arrives after its refinement was decoded is late.
  EXPECT_EQ(st.accepted + st.duplicates + st.late, st.datagrams);
  EXPECT_GE(st.ends, s.stream.control.size());
}

TEST(StreamReconstructor, DatagramsBeforeTheirControlAreBufferedAndUsed) {
  StreamReconstructor rec = Make();
  for (size_t i : {1, 0}) {
    SendData(rec, i, 0);
    SendEnd(rec, i, 0);
  }
  EXPECT_EQ(rec.stats().accepted, 0u);  // nothing begun yet: buffered
  ASSERT_EQ(rec.Poll(5).value(), 0u);
  ASSERT_TRUE(SendControl(rec, 0, 10).ok());
  ASSERT_TRUE(SendControl(rec, 1, 10).ok());
  EXPECT_EQ(rec.Poll(10).value(), 2u);
  ExpectLevel(rec, 2);
  EXPECT_EQ(rec.stats().finished_complete, 2u);
  EXPECT_EQ(rec.stats().accepted, Fandisk().stream.datagrams[0].size() + Fandisk().stream.datagrams[1].size());
}

TEST(StreamReconstructor, BothEndsAndAllDatagramsFinishAtOnce) {
  StreamReconstructor rec = Make();
  ASSERT_TRUE(SendControl(rec, 0, 0).ok());
  const auto& data = Fandisk().stream.datagrams[0];
  for (size_t d = 1; d < data.size(); ++d) rec.OnDatagram(data[d].data(), data[d].size(), 0);
  SendEnd(rec, 0, 0);
  EXPECT_EQ(rec.Poll(0).value(), 0u);  // one datagram is missing: wait
  rec.OnDatagram(data[0].data(), data[0].size(), 1);
  EXPECT_EQ(rec.Poll(1).value(), 1u);
  EXPECT_EQ(rec.stats().finished_complete, 1u);
  ExpectLevel(rec, 1);
}

TEST(StreamReconstructor, ALostEndWaitsForTheStragglerTimeout) {
  ReconstructorOptions options;
  options.straggler_timeout_us = 50000;
  StreamReconstructor rec = Make(options);
  ASSERT_TRUE(SendControl(rec, 0, 1000).ok());
  SendData(rec, 0, 1000);
  EXPECT_EQ(rec.Poll(1000).value(), 0u);
  EXPECT_EQ(rec.Poll(1000 + 50000 - 1).value(), 0u);
  EXPECT_EQ(rec.applied(), 0u);
  EXPECT_EQ(rec.Poll(1000 + 50000).value(), 1u);
  EXPECT_EQ(rec.stats().finished_timeout, 1u);
  EXPECT_EQ(rec.stats().finished_complete, 0u);
  ExpectLevel(rec, 1);
}

TEST(StreamReconstructor, AnEndWithoutControlWaits) {
  StreamReconstructor rec = Make();
  SendData(rec, 0, 0);
  SendEnd(rec, 0, 0);
  EXPECT_EQ(rec.Poll(1000000000).value(), 0u);  // the reliable channel has not signalled
  EXPECT_TRUE(rec.Flush().ok());
  EXPECT_EQ(rec.applied(), 0u);
}

TEST(StreamReconstructor, LateDatagramsAreCountedAndDropped) {
  StreamReconstructor rec = Make();
  ASSERT_TRUE(SendControl(rec, 0, 0).ok());
  SendData(rec, 0, 0);
  SendEnd(rec, 0, 0);
  ASSERT_EQ(rec.Poll(0).value(), 1u);
  SendData(rec, 0, 5);
  EXPECT_EQ(rec.stats().late, Fandisk().stream.datagrams[0].size());
  EXPECT_EQ(rec.reader().stats().rejected, 0u);  // never reached the reader
}

TEST(StreamReconstructor, DuplicatesAreDroppedAndCounted) {
  StreamReconstructor rec = Make();
  SendData(rec, 0, 0);  // buffered
  SendData(rec, 0, 0);  // byte-identical copies
  ASSERT_TRUE(SendControl(rec, 0, 0).ok());
  SendData(rec, 0, 1);  // copies of what the reader has
  const size_t n = Fandisk().stream.datagrams[0].size();
  EXPECT_EQ(rec.stats().duplicates, 2 * n);
  EXPECT_EQ(rec.stats().accepted, n);
  SendEnd(rec, 0, 1);
  SendEnd(rec, 0, 1);
  EXPECT_EQ(rec.stats().ends, 2u);
  EXPECT_EQ(rec.Poll(1).value(), 1u);
  ExpectLevel(rec, 1);
}

TEST(StreamReconstructor, MalformedAndForeignDatagramsAreRejected) {
  const RealStream& s = Fandisk();
  StreamReconstructor rec = Make();
  const std::vector<uint8_t> real = s.stream.datagrams[1][0];
  std::vector<std::vector<uint8_t>> hostile = {
      {},
      {0x4D},
      {0x00, 1, 1, 3, 1, 1, 0, 1},                          // bad magic
      std::vector<uint8_t>(real.begin(), real.begin() + 4),  // truncated header
      Rewrite(real, [](DatagramHeader& h) { h.stream = kRealStreamId + 1; }),
      Rewrite(real, [](DatagramHeader& h) { h.refinement = 250; }),
      Rewrite(real, [](DatagramHeader& h) { h.count = 1000000; }),
      Rewrite(real, [](DatagramHeader& h) { h.kind = DatagramKind::kBundled; }),  // wrong packing
      MakeEndDatagram(kRealStreamId + 1, 0, 1),
      MakeEndDatagram(kRealStreamId, 0, 100000),  // more datagrams than two per split
  };
  for (const auto& d : hostile) rec.OnDatagram(d.data(), d.size(), 0);
  EXPECT_EQ(rec.stats().rejected, hostile.size());
  EXPECT_EQ(rec.stats().overflow + rec.stats().late + rec.stats().accepted, 0u);
  // A well-formed header with a payload that does not decode: the reader drops it.
  ASSERT_TRUE(SendControl(rec, 0, 0).ok());
  std::vector<uint8_t> garbage = s.stream.datagrams[0][0];
  garbage.resize(garbage.size() / 3);
  rec.OnDatagram(garbage.data(), garbage.size(), 0);
  // Whatever it did, the real data still decodes exactly.
  SendData(rec, 0, 0);
  SendEnd(rec, 0, 0);
  ASSERT_TRUE(SendControl(rec, 1, 0).ok());
  SendData(rec, 1, 0);
  SendEnd(rec, 1, 0);
  EXPECT_EQ(rec.Poll(0).value(), 2u);
  ExpectLevel(rec, 2);
}

TEST(StreamReconstructor, BeyondTheWindowIsOverflow) {
  ReconstructorOptions options;
  options.window = 1;
  StreamReconstructor rec = Make(options);
  SendData(rec, 1, 0);  // inside the window
  SendData(rec, 2, 0);  // beyond it
  EXPECT_EQ(rec.stats().overflow, Fandisk().stream.datagrams[2].size());
  for (size_t i : {0, 1}) {
    ASSERT_TRUE(SendControl(rec, i, 0).ok());
    if (i == 0) SendData(rec, 0, 0);
    SendEnd(rec, i, 0);
  }
  EXPECT_EQ(rec.Poll(0).value(), 2u);  // refinement 1 used its buffered datagrams
  ExpectLevel(rec, 2);
}

TEST(StreamReconstructor, TheByteBudgetBoundsWhatIsBuffered) {
  ReconstructorOptions options;
  options.max_buffered_bytes = 4096;
  StreamReconstructor rec = Make(options);
  // Thousands of distinct datagrams with a valid header for refinement 1.
  const std::vector<uint8_t> real = Fandisk().stream.datagrams[1][0];
  const size_t sent = 5000;
  for (size_t i = 0; i < sent; ++i) {
    std::vector<uint8_t> d = real;
    d.push_back(static_cast<uint8_t>(i));
    d.push_back(static_cast<uint8_t>(i >> 8));
    rec.OnDatagram(d.data(), d.size(), 0);
  }
  const uint64_t stored = sent - rec.stats().overflow;
  EXPECT_GT(rec.stats().overflow, 0u);
  EXPECT_LE(stored * (real.size() + 2), options.max_buffered_bytes);
  EXPECT_GT(stored, 0u);
  // Finishing refinements releases the budget: the real data of refinement 0 fits again.
  ASSERT_TRUE(SendControl(rec, 0, 0).ok());
  SendData(rec, 0, 0);
  SendEnd(rec, 0, 0);
  const uint64_t overflow = rec.stats().overflow;
  EXPECT_EQ(rec.Poll(0).value(), 1u);  // refinement 0 needed no buffer beyond the budget
  EXPECT_EQ(rec.stats().overflow, overflow);
}

TEST(StreamReconstructor, ControlPastTheEndIsAnError) {
  const RealStream& s = Fandisk();
  StreamReconstructor rec = Make();
  for (size_t i = 0; i < s.stream.control.size(); ++i) ASSERT_TRUE(SendControl(rec, i, 0).ok());
  const Status past = rec.OnControl(s.stream.control[0].data(), s.stream.control[0].size(), 0);
  EXPECT_EQ(past.code(), StatusCode::kInvalidInput) << past.ToString();
}

TEST(StreamReconstructor, ControlBeforeTheBaseIsAnError) {
  const RealStream& s = Fandisk();
  auto rec = StreamReconstructor::Create(s.stream.header.data(), s.stream.header.size(), kRealStreamId);
  ASSERT_TRUE(rec.ok());
  EXPECT_EQ(SendControl(rec.value(), 0, 0).code(), StatusCode::kInvalidArgument);
}

TEST(StreamReconstructor, LodLimitsTheRefinementsDecoded) {
  ReconstructorOptions options;
  options.lod = 2;
  StreamReconstructor rec = Make(options);
  for (size_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(SendControl(rec, i, 0).ok());
    SendData(rec, i, 0);
    SendEnd(rec, i, 0);
  }
  EXPECT_EQ(rec.Poll(0).value(), 2u);
  EXPECT_TRUE(rec.done());
  EXPECT_TRUE(rec.Flush().ok());
  ExpectLevel(rec, 2);
  EXPECT_EQ(rec.stats().late, Fandisk().stream.datagrams[2].size() + Fandisk().stream.datagrams[3].size());
}

TEST(StreamReconstructor, FlushFinishesWhatHasAControl) {
  StreamReconstructor rec = Make();
  for (size_t i = 0; i < 3; ++i) {
    SendData(rec, i, 0);
    if (i < 2) {
      ASSERT_TRUE(SendControl(rec, i, 0).ok());
    }
  }
  EXPECT_EQ(rec.Poll(0).value(), 0u);  // no END arrived and no time has passed
  ASSERT_TRUE(rec.Flush().ok());
  ExpectLevel(rec, 2);
  EXPECT_EQ(rec.stats().finished_timeout, 2u);
}

TEST(StreamReconstructor, IsMovable) {
  StreamReconstructor a = Make();
  ASSERT_TRUE(SendControl(a, 0, 0).ok());
  SendData(a, 0, 0);
  SendEnd(a, 0, 0);
  StreamReconstructor b = std::move(a);
  EXPECT_EQ(b.Poll(0).value(), 1u);
  ExpectLevel(b, 1);
}

}  // namespace
}  // namespace meshstream
