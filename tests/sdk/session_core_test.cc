// The client's session core (sdk/session_core.h) without sockets or threads:
// the real bytes of a codec-made artifact, as the server lays them out,
// through a seeded simulated network (tests/sdk/served_stream.h), to a core
// driven as sdk/session.cc drives it on a simulated clock.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

#include "codec/bitstream/format.h"
#include "tests/sdk/served_stream.h"

namespace meshstream::sdk_test {
namespace {

const ServedPrimitive& Sphere() {
  static const ServedPrimitive s = BuildServedSphere(3);
  return s;
}
const ServedPrimitive& SecondSphere() {
  static const ServedPrimitive s = BuildServedSphere(7, 9, 11, 80);
  return s;
}

SessionOptions Options() {
  SessionOptions o;
  o.asset = "sphere";
  return o;
}

struct Driven {
  std::unique_ptr<SimHost> host;
  Schedule schedule;
};

Driven Drive(const std::vector<const ServedPrimitive*>& primitives, const NetworkOptions& n, const SessionOptions& o,
          uint64_t poll_every_us = 1000, uint64_t udp_lag_us = 0, uint64_t first_poll_us = 0,
          bool stream_ends = true, uint64_t run_for_us = 60000000, uint64_t hello_rtt_us = 0) {
  Driven r;
  r.schedule = Serve(primitives, n);
  r.host = std::make_unique<SimHost>(o, n.start_us - 5000);
  r.host->udp.hello_rtt_us = hello_rtt_us;
  r.host->pending = r.schedule.arrivals;
  r.host->udp_lag_us = udp_lag_us;
  r.host->stream_end_after_last = stream_ends;
  if (first_poll_us != 0) r.host->now_us = first_poll_us;
  r.host->Run(poll_every_us, n.start_us + run_for_us);
  return r;
}

bool SameMesh(const QuantizedMesh& a, const QuantizedMesh& b) {
  return a.positions == b.positions && a.attributes == b.attributes && a.indices == b.indices;
}

// Events: kBaseReady, increasing kLevelReady, then kComplete (or kError).
void ExpectEventsInOrder(const std::vector<Event>& events, EventType last) {
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front().type, EventType::kBaseReady);
  int32_t level = 0;
  for (size_t i = 1; i + 1 < events.size(); ++i) {
    EXPECT_EQ(events[i].type, EventType::kLevelReady) << i;
    EXPECT_GT(events[i].level, level);
    level = events[i].level;
  }
  EXPECT_EQ(events.back().type, last) << events.back().status.ToString();
}

std::vector<const v1::ClientReport*> Reports(const SimHost& h) {
  std::vector<const v1::ClientReport*> out;
  for (const Outgoing& o : h.sent)
    if (o.message.has_report()) out.push_back(&o.message.report());
  return out;
}

NetworkOptions Lossless(uint64_t seed) {
  NetworkOptions n;
  n.model.seed = seed;
  n.model.reorder = 0.3;
  n.model.duplicate = 0.1;
  return n;
}

TEST(SessionCore, NoLossGivesTheExactMeshOverUdpWithReorderingDelayAndCopies) {
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    Driven r = Drive({&Sphere(), &SecondSphere()}, Lossless(seed), Options());
    SimHost& h = *r.host;
    ExpectEventsInOrder(h.events, EventType::kComplete);
    ASSERT_EQ(h.core.primitive_count(), 2u);
    EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
    EXPECT_TRUE(SameMesh(h.core.reader(1).Mesh(), SecondSphere().levels.back()));
    EXPECT_EQ(h.core.predicted_vertices(), 0u);
    EXPECT_EQ(h.core.stats().datagrams_lost, 0u);
    EXPECT_EQ(h.core.stats().transport, "udp");
    EXPECT_EQ(h.core.stats().end_reason, "complete");
    EXPECT_GT(h.core.stats().datagrams_duplicate, 0u);  // the copies
    ASSERT_TRUE(h.udp_started.has_value());
    EXPECT_EQ(h.udp_started->port, 7601);
    EXPECT_EQ(h.udp_started->session_id, 0x1122334455667788ull);
    EXPECT_TRUE(h.udp_stopped);
    // One report per refinement, nothing missing, then done.
    const auto reports = Reports(h);
    EXPECT_EQ(reports.size(), Sphere().stream.control.size() + SecondSphere().stream.control.size());
    for (const v1::ClientReport* rep : reports) {
      EXPECT_EQ(rep->missing_size(), 0);
      EXPECT_TRUE(rep->end_received());
    }
    ASSERT_FALSE(h.sent.empty());
    EXPECT_EQ(h.sent.back().message.done().reason(), "complete");
    EXPECT_TRUE(h.half_closed);
  }
}

TEST(SessionCore, OverGrpcEverythingIsExact) {
  NetworkOptions n = Lossless(5);
  n.udp = false;
  n.model.loss = 0.5;  // the stream never loses
  Driven r = Drive({&Sphere()}, n, Options());
  ExpectEventsInOrder(r.host->events, EventType::kComplete);
  EXPECT_TRUE(SameMesh(r.host->core.reader(0).Mesh(), Sphere().levels.back()));
  EXPECT_FALSE(r.host->udp_started.has_value());
  EXPECT_EQ(r.host->core.stats().transport, "grpc");
  EXPECT_EQ(r.host->core.stats().datagrams_lost, 0u);
}

// The views a host reads while the decoding goes on (SessionCore::TakeView):
// a view keeps the meshes of its event whatever is decoded after it; a
// primitive that did not change shares its arrays with the view before;
// arrays of views nobody holds any more are reused, not allocated anew.
TEST(SessionCore, AViewKeepsItsEventsMeshesSharesWhatDidNotChangeAndReusesOldArrays) {
  NetworkOptions n = Lossless(5);
  n.udp = false;
  SimHost h(Options(), n.start_us - 5000);
  h.pending = Serve({&Sphere(), &SecondSphere()}, n).arrivals;
  h.stream_end_after_last = true;
  ViewBuffers buffers;
  // Polls until the next event, at most one simulated minute.
  auto next_event = [&h]() -> std::optional<Event> {
    for (int i = 0; i < 60000; ++i, h.now_us += 1000) {
      if (auto e = h.PollOnce()) return e;
    }
    return std::nullopt;
  };
  auto e = next_event();
  ASSERT_TRUE(e && e->type == EventType::kBaseReady);
  SessionView base;
  h.core.TakeView(base, &buffers);
  ASSERT_EQ(base.primitives.size(), 2u);
  EXPECT_EQ(base.level_shown, 0);
  EXPECT_TRUE(SameMesh(*base.primitives[0].mesh, Sphere().levels[0]));
  EXPECT_TRUE(SameMesh(*base.primitives[1].mesh, SecondSphere().levels[0]));
  SessionView again = base;
  h.core.TakeView(again, &buffers);
  EXPECT_EQ(again.primitives[0].mesh, base.primitives[0].mesh) << "nothing changed: shared";
  EXPECT_EQ(ViewScene(again).meshes.size(), 2u);

  e = next_event();
  ASSERT_TRUE(e && e->type == EventType::kLevelReady);
  SessionView level = again;
  h.core.TakeView(level, &buffers);
  EXPECT_EQ(level.level_shown, e->level);
  EXPECT_NE(level.primitives[0].mesh, base.primitives[0].mesh);
  EXPECT_TRUE(SameMesh(*level.primitives[0].mesh, Sphere().levels[h.core.reader(0).applied()]));
  EXPECT_TRUE(SameMesh(*base.primitives[0].mesh, Sphere().levels[0])) << "the base's view stays the base";
  ASSERT_EQ(buffers.retired_meshes.size(), 2u);  // the base's arrays, still held by `base`

  // Once no view holds the base's arrays they are the next view's.
  const QuantizedMesh* old = base.primitives[0].mesh.get();
  buffers.Recycle();
  EXPECT_TRUE(buffers.spare_meshes.empty()) << "still held by the views base and again";
  base = SessionView{};
  again = SessionView{};
  buffers.Recycle();
  ASSERT_EQ(buffers.spare_meshes.size(), 2u);
  while ((e = next_event()) && e->type == EventType::kLevelReady) {
    SessionView later = level;
    h.core.TakeView(later, &buffers);
    EXPECT_TRUE(SameMesh(*later.primitives[0].mesh, Sphere().levels[h.core.reader(0).applied()]));
    const bool reused = later.primitives[0].mesh.get() == old || later.primitives[1].mesh.get() == old;
    EXPECT_TRUE(reused) << "a spare was there";
    break;
  }
}

// The delivery rate the client saw goes back in the reports of UDP
// refinements of two datagrams or more (the sender's bottleneck estimate:
// net/rate_controller.h); the stream's refinements carry none.
TEST(SessionCore, ReportsCarryTheDeliveryRateOfUdpRefinements) {
  for (const bool udp : {true, false}) {
    SCOPED_TRACE(udp ? "udp" : "grpc");
    NetworkOptions n = Lossless(8);
    n.udp = udp;
    Driven r = Drive({&Sphere()}, n, Options());
    size_t with_span = 0;
    for (const v1::ClientReport* report : Reports(*r.host)) {
      if (report->arrival_span_us() == 0) {
        EXPECT_EQ(report->span_bytes(), 0u);
        continue;
      }
      ++with_span;
      EXPECT_GT(report->span_bytes(), 0u);
      EXPECT_LT(report->span_bytes(), report->bytes_received()) << "the first datagram's bytes are not in the span";
    }
    if (udp) {
      EXPECT_GT(with_span, 0u);
    } else {
      EXPECT_EQ(with_span, 0u);
    }
  }
}

TEST(SessionCore, UnderLossTheMeshIsPredictedAndTheReportsNameWhatWasLost) {
  for (uint64_t seed = 11; seed <= 14; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    NetworkOptions n = Lossless(seed);
    n.model.loss = 0.15;
    n.model.burst = seed % 2 == 0 ? 3 : 0;
    Driven r = Drive({&Sphere()}, n, Options());
    SimHost& h = *r.host;
    ExpectEventsInOrder(h.events, EventType::kComplete);
    const QuantizedMesh mesh = h.core.reader(0).Mesh();
    EXPECT_EQ(mesh.vertex_count(), Sphere().levels.back().vertex_count());
    size_t lost = 0;
    for (const auto& [key, ordinals] : r.schedule.lost) lost += ordinals.size();
    ASSERT_GT(lost, 0u);
    EXPECT_EQ(h.core.stats().datagrams_lost, lost);
    EXPECT_GT(h.core.predicted_vertices(), 0u);
    // Every report's missing list is exactly what the network dropped.
    for (const v1::ClientReport* rep : Reports(h)) {
      const auto it = r.schedule.lost.find({rep->primitive(), rep->refinement()});
      const std::vector<uint32_t> expected = it == r.schedule.lost.end() ? std::vector<uint32_t>() : it->second;
      EXPECT_EQ(std::vector<uint32_t>(rep->missing().begin(), rep->missing().end()), expected)
          << "refinement " << rep->refinement();
    }
  }
}

TEST(SessionCore, TheSameSeedGivesTheSameSession) {
  NetworkOptions n = Lossless(21);
  n.model.loss = 0.2;
  Driven a = Drive({&Sphere()}, n, Options());
  Driven b = Drive({&Sphere()}, n, Options());
  ASSERT_EQ(a.host->sent.size(), b.host->sent.size());
  for (size_t i = 0; i < a.host->sent.size(); ++i) {
    EXPECT_EQ(a.host->sent[i].message.SerializeAsString(), b.host->sent[i].message.SerializeAsString()) << i;
  }
  EXPECT_TRUE(SameMesh(a.host->core.reader(0).Mesh(), b.host->core.reader(0).Mesh()));
}

// Commit 186bb1d, first cause: a poll stops at the first event and leaves
// its other arrivals in the inbox; the stream's end must not flush the
// refinements whose datagrams wait there. A host that polls once, long after
// everything arrived (the UDP path slower than the stream, so the last
// refinements' datagrams come after SessionEnd), must lose nothing.
TEST(SessionCore, APollerThatPollsLateLosesNothingThatArrived) {
  NetworkOptions n = Lossless(31);
  n.model.reorder = 0;
  n.model.duplicate = 0;
  n.timing.reliable_latency_us = 2000;
  // Datagrams trail the stream's end (but within the straggler timeout of
  // their refinement's RefinementEnd: a fast poller loses nothing either).
  n.timing.unreliable_latency_us = 30000;
  // The first poll comes 5 s after the session's end: every window is long past.
  Driven r = Drive({&Sphere()}, n, Options(), 1000, 0, n.start_us + 5000000);
  SimHost& h = *r.host;
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
  EXPECT_EQ(h.core.predicted_vertices(), 0u);
  EXPECT_EQ(h.core.stats().datagrams_lost, 0u);
}

// Commit 186bb1d, second cause: a UDP thread kept off the CPU hands the
// datagrams over late; stragglers are timed by the arrival horizon, not the
// host's clock, so what reached the socket is never counted lost.
TEST(SessionCore, AStarvedUdpThreadLosesNothingThatArrived) {
  NetworkOptions n = Lossless(32);
  Driven r = Drive({&Sphere()}, n, Options(), 2000, /*udp_lag_us=*/400000);
  SimHost& h = *r.host;
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
  EXPECT_EQ(h.core.stats().datagrams_lost, 0u);
}

TEST(SessionCore, ASlowPollerUnderLossStillDecodesWhatArrived) {
  NetworkOptions n = Lossless(33);
  n.model.loss = 0.1;
  Driven slow = Drive({&Sphere()}, n, Options(), 250000);
  Driven fast = Drive({&Sphere()}, n, Options(), 1000);
  ExpectEventsInOrder(slow.host->events, EventType::kComplete);
  // The same datagrams arrived: the same predicted mesh whatever the poll rate.
  EXPECT_TRUE(SameMesh(slow.host->core.reader(0).Mesh(), fast.host->core.reader(0).Mesh()));
  EXPECT_EQ(slow.host->core.stats().datagrams_lost, fast.host->core.stats().datagrams_lost);
}

// Loss detection by packet numbers: with an RTT sample (the HELLO's) a UDP
// refinement that lost a datagram is decoded once three later packet numbers
// or an eighth of the round trip after a later datagram have passed, not the
// straggler timeout after its END; the same datagrams make the same mesh.
TEST(SessionCore, ALostDatagramIsDeclaredByLaterPacketNumbersNotAfterAFixedWait) {
  double saved_ms = 0;
  for (uint64_t seed = 51; seed <= 56; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    NetworkOptions n = Lossless(seed);
    n.model.reorder = 0;
    n.model.duplicate = 0;
    n.model.loss = 0.3;
    Driven fixed = Drive({&Sphere()}, n, Options());
    Driven rules = Drive({&Sphere()}, n, Options(), 1000, 0, 0, true, 60000000, /*hello_rtt_us=*/40000);
    ExpectEventsInOrder(rules.host->events, EventType::kComplete);
    EXPECT_TRUE(SameMesh(fixed.host->core.reader(0).Mesh(), rules.host->core.reader(0).Mesh()));
    EXPECT_EQ(fixed.host->core.stats().datagrams_lost, rules.host->core.stats().datagrams_lost);
    EXPECT_EQ(fixed.host->core.stats().losses_declared, 0u) << "without an RTT sample, the straggler timeout";
    EXPECT_GT(rules.host->core.stats().losses_declared, 0u);
    EXPECT_EQ(rules.host->core.stats().losses_spurious, 0u);
    EXPECT_EQ(rules.host->core.stats().reorder_window_ms, 5.0);
    const double a = fixed.host->core.stats().time_to_full_ms, b = rules.host->core.stats().time_to_full_ms;
    EXPECT_LE(b, a) << "never later";
    saved_ms = std::max(saved_ms, a - b);
  }
  EXPECT_GE(saved_ms, 30.0) << "a lossy last refinement no longer waits 50 ms";
}

// Reordering beyond the rules (datagrams up to 5 ms late, at a 0.1 ms
// spacing, against a 1 ms window): a datagram declared lost that comes after
// all stops the packet rule and doubles the window, so the session adapts
// after a few mistakes instead of predicting what arrives late forever.
TEST(SessionCore, ReorderingBeyondTheRulesGrowsTheWindow) {
  NetworkOptions n = Lossless(61);
  n.model.duplicate = 0;
  n.model.reorder = 0.3;
  n.timing.reliable_latency_us = 2000;  // the control blocks come first: the rules watch every datagram
  Driven r = Drive({&Sphere(), &SecondSphere()}, n, Options(), 1000, 0, 0, true, 60000000, /*hello_rtt_us=*/8000);
  SimHost& h = *r.host;
  ExpectEventsInOrder(h.events, EventType::kComplete);
  const SessionStats& s = h.core.stats();
  EXPECT_GT(s.losses_spurious, 0u);
  EXPECT_LE(s.losses_spurious, 6u) << "the window grew instead";
  EXPECT_GE(s.reorder_window_ms, 4.0) << "from 1 ms, doubled";
  EXPECT_LE(s.reorder_window_ms, 50.0) << "never beyond the straggler timeout";
  EXPECT_EQ(h.core.primitive_count(), 2u);
}

TEST(SessionCore, TheRepairAsksForExactlyWhatWasLostAndGivesTheExactMesh) {
  NetworkOptions n = Lossless(41);
  n.model.loss = 0.2;
  SessionOptions o = Options();
  o.repair = true;
  Driven r = Drive({&Sphere()}, n, o, 1000, 0, 0, /*stream_ends=*/false, /*run_for_us=*/2000000);
  SimHost& h = *r.host;
  // The session waits for the repair: no kComplete yet.
  ASSERT_FALSE(h.events.empty());
  EXPECT_NE(h.events.back().type, EventType::kComplete);
  EXPECT_TRUE(h.core.repair_asked());
  EXPECT_EQ(h.core.phase(), SessionPhase::kRepairing);
  const v1::RepairRequest* request = nullptr;
  for (const Outgoing& out : h.sent)
    if (out.message.has_repair()) request = &out.message.repair();
  ASSERT_NE(request, nullptr);
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> asked;
  for (const v1::RepairItem& item : request->items())
    asked[{item.primitive(), item.refinement()}].assign(item.datagrams().begin(), item.datagrams().end());
  EXPECT_EQ(asked, r.schedule.lost);
  // The server sends each, then RepairEnd.
  uint64_t at = h.now_us + 3000;
  for (const auto& [key, ordinals] : asked) {
    for (uint32_t k : ordinals) {
      Arrival a;
      a.at_us = at;
      a.message.mutable_datagram()->set_payload(AsString(Sphere().stream.datagrams[key.second][k]));
      h.pending.push_back(std::move(a));
    }
  }
  Arrival end;
  end.at_us = at;
  end.message.mutable_repair_end()->set_datagrams(1);
  h.pending.push_back(std::move(end));
  h.Run(1000, h.now_us + 1000000);
  ASSERT_EQ(h.events.back().type, EventType::kComplete) << h.events.back().status.ToString();
  EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
  EXPECT_EQ(h.core.predicted_vertices(), 0u);
  EXPECT_GT(h.core.stats().repaired_datagrams, 0u);
  EXPECT_TRUE(h.core.stats().repair_error.empty());
  EXPECT_EQ(h.core.phase(), SessionPhase::kOver);
}

TEST(SessionCore, ARepairThatNeverComesKeepsThePredictedMesh) {
  NetworkOptions n = Lossless(42);
  n.model.loss = 0.2;
  SessionOptions o = Options();
  o.repair = true;
  Driven r = Drive({&Sphere()}, n, o, 1000, 0, 0, /*stream_ends=*/false);
  SimHost& h = *r.host;
  h.Run(100000, h.now_us + SessionCore::kRepairWaitUs + 1000000);
  ASSERT_EQ(h.events.back().type, EventType::kComplete);
  EXPECT_EQ(h.core.stats().repair_error, "no repair within 10 s");
  EXPECT_GT(h.core.predicted_vertices(), 0u);
}

TEST(SessionCore, ACallThatEndsBeforeTheRepairKeepsThePredictedMesh) {
  NetworkOptions n = Lossless(43);
  n.model.loss = 0.2;
  SessionOptions o = Options();
  o.repair = true;
  Driven r = Drive({&Sphere()}, n, o, 1000, 0, 0, /*stream_ends=*/true, /*run_for_us=*/2000000);
  SimHost& h = *r.host;
  ASSERT_EQ(h.events.back().type, EventType::kComplete);
  EXPECT_TRUE(h.core.repair_asked());
  EXPECT_EQ(h.core.stats().repair_error, "the server ended the session before the repair");
  EXPECT_GT(h.core.predicted_vertices(), 0u);
}

TEST(SessionCore, AByteBudgetStopsTheSessionAtTheLevelReached) {
  SessionOptions o = Options();
  o.byte_budget = Sphere().base_bytes.size() + Sphere().stream.header.size() + 600;
  Driven r = Drive({&Sphere()}, Lossless(51), o);
  SimHost& h = *r.host;
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_EQ(h.core.stats().end_reason, "byte_budget");
  EXPECT_EQ(h.core.end_reason(), EndReason::kByteBudget);
  EXPECT_LT(h.core.level_shown(), static_cast<int32_t>(Sphere().stream.control.size()));
  bool done = false;
  for (const Outgoing& out : h.sent)
    if (out.message.has_done()) done = out.message.done().reason() == "byte_budget";
  EXPECT_TRUE(done);
  EXPECT_TRUE(h.half_closed);
}

TEST(SessionCore, ATimeBudgetStopsTheSessionOnTheCallersClock) {
  SessionOptions o = Options();
  o.time_budget_ms = 40;  // opened 5 ms before the start: a refinement or two
  Driven r = Drive({&Sphere()}, Lossless(52), o);
  SimHost& h = *r.host;
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_EQ(h.core.end_reason(), EndReason::kTimeBudget);
  EXPECT_EQ(h.core.stats().end_reason, "time_budget");
  EXPECT_LT(h.core.level_shown(), static_cast<int32_t>(Sphere().stream.control.size()));
}

TEST(SessionCore, MaxLevelEndsAtThatLevel) {
  NetworkOptions n = Lossless(53);
  n.refinements = 2;
  Driven r = Drive({&Sphere()}, n, Options());
  ExpectEventsInOrder(r.host->events, EventType::kComplete);
  EXPECT_EQ(r.host->core.level_shown(), 2);
  EXPECT_TRUE(SameMesh(r.host->core.reader(0).Mesh(), Sphere().levels[2]));
}

// The scene's levels (PrimitiveStart.level_refinements): a primitive runs
// as far ahead as its count at the next level lets it, and a level is shown
// once every primitive has its count there.
TEST(SessionCore, AScenesLevelsAreTheServersCountsPerPrimitive) {
  NetworkOptions n = Lossless(57);
  Schedule s = Serve({&Sphere(), &SecondSphere()}, n);
  v1::SessionStart& start = *s.arrivals[0].message.mutable_session();
  ASSERT_EQ(start.primitives_size(), 2);
  const uint32_t r0 = start.primitives(0).refinements(), r1 = start.primitives(1).refinements();
  ASSERT_GT(r0, 1u);
  ASSERT_GT(r1, 1u);
  // The one with more refinements paces the levels; the other has all of
  // its refinements at level 1 (a part whose errors are larger everywhere).
  const int big = r1 >= r0 ? 1 : 0, small = 1 - big;
  const uint32_t levels = std::max(r0, r1), all_small = std::min(r0, r1);
  for (uint32_t level = 1; level <= levels; ++level) {
    start.mutable_primitives(big)->add_level_refinements(level);
    start.mutable_primitives(small)->add_level_refinements(all_small);
  }
  // The small primitive's data first (as the server's scene order sends a
  // part with larger errors), everything else 2 s later.
  auto primitive_of = [](const Arrival& a) -> int64_t {
    if (!a.is_message) {
      auto d = ParsedDatagram::Parse(a.payload.data(), a.payload.size());
      return d.ok() ? int64_t{d->header().stream} : -1;
    }
    if (a.message.has_control()) return a.message.control().primitive();
    if (a.message.has_refinement_end()) return a.message.refinement_end().primitive();
    if (a.message.has_datagram()) {
      const std::string& bytes = a.message.datagram().payload();
      auto d = ParsedDatagram::Parse(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
      return d.ok() ? int64_t{d->header().stream} : -1;
    }
    return -1;
  };
  for (size_t i = 1; i < s.arrivals.size(); ++i) {
    if (primitive_of(s.arrivals[i]) != start.primitives(small).primitive()) s.arrivals[i].at_us += 2000000;
  }
  std::stable_sort(s.arrivals.begin(), s.arrivals.end(),
                   [](const Arrival& a, const Arrival& b) { return a.at_us < b.at_us; });
  SimHost h(Options(), n.start_us - 1000);
  h.pending = s.arrivals;
  h.stream_end_after_last = true;
  bool small_ran_ahead = false, started = false;
  int32_t shown = 0;
  while (h.now_us <= n.start_us + 60000000) {
    while (auto e = h.PollOnce()) {
      started = started || e->type == EventType::kBaseReady;
      if (e->type != EventType::kLevelReady) continue;
      // At an event, every primitive has at least its count of that level.
      shown = e->level;
      EXPECT_GE(h.core.reader(big).applied(), static_cast<size_t>(e->level)) << e->level;
      EXPECT_EQ(h.core.reader(small).applied(), all_small) << e->level;
    }
    if (started && h.core.reader(small).applied() == all_small && h.core.reader(big).applied() < 2) {
      small_ran_ahead = true;
    }
    if (h.core.over() && !h.core.has_event()) break;
    h.now_us += 1000;
  }
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_TRUE(small_ran_ahead) << "the small primitive is not held to one refinement per level";
  EXPECT_EQ(shown, static_cast<int32_t>(levels));
  EXPECT_EQ(h.core.level_shown(), static_cast<int32_t>(levels));
  EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
  EXPECT_TRUE(SameMesh(h.core.reader(1).Mesh(), SecondSphere().levels.back()));
}

TEST(SessionCore, ATransportChangeStopsUdpAndTheSessionGoesOnOverTheStream) {
  NetworkOptions n = Lossless(54);
  n.udp = false;
  Schedule s = Serve({&Sphere()}, n);
  // The server started UDP, then fell back before the first refinement.
  s.arrivals[0].message = SessionStartMessage({&Sphere()}, true, 255);
  Arrival change;
  change.at_us = s.arrivals[0].at_us;
  change.message.mutable_transport_change()->set_transport(v1::TRANSPORT_GRPC);
  change.message.mutable_transport_change()->set_reason("no HELLO");
  s.arrivals.insert(s.arrivals.begin() + 1, change);
  SimHost h(Options(), n.start_us - 1000);
  h.pending = s.arrivals;
  h.Run(1000, n.start_us + 10000000);
  ExpectEventsInOrder(h.events, EventType::kComplete);
  EXPECT_TRUE(h.udp_started.has_value());
  EXPECT_TRUE(h.udp_stopped);
  EXPECT_EQ(h.core.stats().transport, "grpc");
  EXPECT_EQ(h.core.stats().fallback_reason, "no HELLO");
  EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
}

// Bad server messages: each either ends the session with the error named in
// sdk/session.h, or is dropped and counted.
struct Hostile {
  std::string name;
  std::function<void(Schedule&)> change;
  bool fatal;
  StatusCode code;
};

TEST(SessionCore, BadServerMessagesEndTheSessionOrAreDroppedAndCounted) {
  auto at = [](Schedule& s, size_t i) -> v1::ServerMessage& { return s.arrivals[i].message; };
  auto first_of = [](Schedule& s, v1::ServerMessage::KindCase k) -> v1::ServerMessage& {
    for (Arrival& a : s.arrivals)
      if (a.is_message && a.message.kind_case() == k) return a.message;
    Die("no such message");
  };
  auto add = [](Schedule& s, v1::ServerMessage m, size_t before) {
    Arrival a;
    a.at_us = s.arrivals[before].at_us;
    a.message = std::move(m);
    s.arrivals.insert(s.arrivals.begin() + before, std::move(a));
  };
  auto add_udp = [](Schedule& s, std::vector<uint8_t> payload, size_t before) {
    Arrival a;
    a.at_us = s.arrivals[before].at_us;
    a.is_message = false;
    a.payload = std::move(payload);
    a.packet_number = 1u << 30;
    s.arrivals.insert(s.arrivals.begin() + before, std::move(a));
  };
  const std::vector<Hostile> cases = {
      {"a second SessionStart", [&](Schedule& s) { add(s, at(s, 0), 2); }, true, StatusCode::kInvalidInput},
      {"level counts that fall",
       [&](Schedule& s) {
         v1::PrimitiveStart& p = *at(s, 0).mutable_session()->mutable_primitives(0);
         p.add_level_refinements(2);
         p.add_level_refinements(1);
       },
       true, StatusCode::kInvalidInput},
      {"level counts whose last is not every refinement",
       [&](Schedule& s) { at(s, 0).mutable_session()->mutable_primitives(0)->add_level_refinements(1); }, true,
       StatusCode::kInvalidInput},
      {"a control block for an unknown primitive",
       [&](Schedule& s) { first_of(s, v1::ServerMessage::kControl).mutable_control()->set_primitive(99); }, true,
       StatusCode::kInvalidInput},
      {"a control block twice",
       [&](Schedule& s) {
         v1::ServerMessage c = first_of(s, v1::ServerMessage::kControl);
         add(s, c, 3);
       },
       true, StatusCode::kInvalidInput},
      {"a control block past the session's refinements",
       [&](Schedule& s) { first_of(s, v1::ServerMessage::kControl).mutable_control()->set_refinement(200); }, true,
       StatusCode::kInvalidInput},
      {"a control block announcing more datagrams than two per split",
       [&](Schedule& s) { first_of(s, v1::ServerMessage::kControl).mutable_control()->set_datagrams(4000000000u); },
       true, StatusCode::kInvalidInput},
      {"a corrupt control block",
       [&](Schedule& s) { first_of(s, v1::ServerMessage::kControl).mutable_control()->set_control("\xff\xff\xff"); },
       true, StatusCode::kInvalidInput},
      {"a RefinementEnd past the session's refinements",
       [&](Schedule& s) { first_of(s, v1::ServerMessage::kRefinementEnd).mutable_refinement_end()->set_refinement(250); },
       true, StatusCode::kInvalidInput},
      {"a RepairEnd never asked for",
       [&](Schedule& s) {
         v1::ServerMessage m;
         m.mutable_repair_end();
         add(s, m, 2);
       },
       true, StatusCode::kInvalidInput},
      {"UDP keys of the wrong size",
       [&](Schedule& s) { at(s, 0).mutable_session()->set_client_to_server_key("short"); }, true,
       StatusCode::kInvalidInput},
      {"no UDP port", [&](Schedule& s) { at(s, 0).mutable_session()->mutable_udp()->set_port(70000); }, true,
       StatusCode::kInvalidInput},
      {"a base mesh that is not Draco",
       [&](Schedule& s) { at(s, 0).mutable_session()->mutable_primitives(0)->set_base_mesh("not draco"); }, true,
       StatusCode::kInvalidInput},
      {"a stream header that is not one",
       [&](Schedule& s) { at(s, 0).mutable_session()->mutable_primitives(0)->set_header("MSxx"); }, true,
       StatusCode::kUnsupported},
      {"more refinements than the header has",
       [&](Schedule& s) { at(s, 0).mutable_session()->mutable_primitives(0)->set_refinements(250); }, true,
       StatusCode::kInvalidInput},
      {"a primitive announced twice",
       [&](Schedule& s) {
         v1::PrimitiveStart p = at(s, 0).session().primitives(0);
         *at(s, 0).mutable_session()->add_primitives() = p;
       },
       true, StatusCode::kInvalidInput},
      {"no POSITION",
       [&](Schedule& s) { at(s, 0).mutable_session()->mutable_primitives(0)->mutable_draco_attributes()->erase("POSITION"); },
       true, StatusCode::kInvalidInput},
      {"a scene that is not a glb",
       [&](Schedule& s) { at(s, 0).mutable_session()->set_scene_glb("glTF but not"); }, true, StatusCode::kInvalidInput},
      {"garbage on UDP", [&](Schedule& s) { add_udp(s, {0x4D, 9, 9, 9}, 3); }, false, StatusCode::kOk},
      {"a datagram of an unknown stream on UDP",
       [&](Schedule& s) { add_udp(s, MakeEndDatagram(77, 0, 1), 3); }, false, StatusCode::kOk},
      {"an END announcing too many datagrams",
       [&](Schedule& s) { add_udp(s, MakeEndDatagram(3, 1, 100000), 3); }, false, StatusCode::kOk},
      {"garbage on the stream",
       [&](Schedule& s) {
         v1::ServerMessage m;
         m.mutable_datagram()->set_payload("\x4d\x02\x00garbage");
         add(s, m, 3);
       },
       false, StatusCode::kOk},
      {"a datagram before the SessionStart",
       [&](Schedule& s) {
         v1::ServerMessage m;
         m.mutable_datagram()->set_payload(AsString(Sphere().stream.datagrams[0][0]));
         Arrival a;
         a.at_us = s.arrivals[0].at_us;
         a.message = m;
         s.arrivals.insert(s.arrivals.begin(), a);
       },
       false, StatusCode::kOk},
      {"a second SessionEnd", [&](Schedule& s) { add(s, s.arrivals.back().message, s.arrivals.size() - 1); }, false,
       StatusCode::kOk},
      {"an unset message", [&](Schedule& s) { add(s, v1::ServerMessage(), 2); }, false, StatusCode::kOk},
  };
  for (const Hostile& c : cases) {
    SCOPED_TRACE(c.name);
    NetworkOptions n;
    n.model.seed = 61;
    Schedule s = Serve({&Sphere()}, n);
    c.change(s);
    SimHost h(Options(), n.start_us - 1000);
    h.pending = s.arrivals;
    h.stream_end_after_last = true;
    h.Run(1000, n.start_us + 10000000);
    ASSERT_FALSE(h.events.empty());
    if (c.fatal) {
      EXPECT_EQ(h.events.back().type, EventType::kError);
      EXPECT_EQ(h.events.back().status.code(), c.code) << h.events.back().status.ToString();
      EXPECT_TRUE(h.core.over());
    } else {
      ExpectEventsInOrder(h.events, EventType::kComplete);
      EXPECT_TRUE(SameMesh(h.core.reader(0).Mesh(), Sphere().levels.back()));
      const SessionStats& st = h.core.stats();
      if (c.name.find("SessionEnd") == std::string::npos && c.name.find("unset") == std::string::npos) {
        EXPECT_GE(st.datagrams_rejected, 1u);
      }
    }
  }
}

TEST(SessionCore, AStreamThatEndsBeforeSessionEndIsAnError) {
  NetworkOptions n;
  n.model.seed = 71;
  Schedule s = Serve({&Sphere()}, n);
  s.arrivals.pop_back();  // no SessionEnd
  SimHost h(Options(), n.start_us - 1000);
  h.pending = s.arrivals;
  h.stream_end_after_last = true;
  h.Run(1000, n.start_us + 10000000);
  ASSERT_EQ(h.events.back().type, EventType::kError);
  EXPECT_EQ(h.events.back().status.code(), StatusCode::kUnavailable);
  // With the call's own status, that one.
  SimHost g(Options(), n.start_us - 1000);
  g.pending = s.arrivals;
  g.stream_end_after_last = true;
  g.stream_end_status = PermissionDenied("token revoked");
  g.Run(1000, n.start_us + 10000000);
  ASSERT_EQ(g.events.back().type, EventType::kError);
  EXPECT_EQ(g.events.back().status.code(), StatusCode::kPermissionDenied);
}

TEST(SessionCore, ASecondSessionEndCannotPostponeTheEnd) {
  // A server that repeats SessionEnd long after: the stragglers' window
  // counts from the first, so a hole is predicted on time.
  NetworkOptions n;
  n.model.seed = 72;
  n.model.loss = 0.3;
  Schedule s = Serve({&Sphere()}, n);
  Arrival again = s.arrivals.back();
  again.at_us += 3000000;
  s.arrivals.push_back(again);
  SimHost h(Options(), n.start_us - 1000);
  h.pending = s.arrivals;
  h.Run(1000, s.arrivals.back().at_us - 1000000);
  ASSERT_FALSE(h.events.empty());
  EXPECT_EQ(h.events.back().type, EventType::kComplete);
}

TEST(ParsedDatagram, TheHeaderIsReadOnceAndTheReconstructorTakesItParsed) {
  const auto& d = Sphere().stream.datagrams[0][0];
  auto parsed = ParsedDatagram::Parse(d.data(), d.size());
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed->header().stream, 3u);
  EXPECT_EQ(parsed->header().refinement, 0u);
  EXPECT_EQ(parsed->size(), d.size());
  EXPECT_EQ(parsed->payload() + parsed->payload_size(), d.data() + d.size());
  EXPECT_GT(parsed->payload_size(), 0u);
  // A buffered copy: the same view over the copy.
  std::vector<uint8_t> copy = d;
  const ParsedDatagram over = parsed->Over(copy.data());
  EXPECT_EQ(over.data(), copy.data());
  EXPECT_EQ(over.payload_size(), parsed->payload_size());
  EXPECT_FALSE(ParsedDatagram::Parse(d.data(), 3).ok());
}

TEST(EndDatagram, OneFormFromTheStreamHeader) {
  const auto& header = Sphere().stream.header;
  // The version is the header's first byte.
  EXPECT_EQ(MakeStreamEndDatagram(header.data(), header.size(), 3, 2, 5), MakeEndDatagram(3, 2, 5, header[0]));
  std::vector<uint8_t> v1_header = header;
  v1_header[0] = 1;
  const auto end = MakeStreamEndDatagram(v1_header.data(), v1_header.size(), 3, 2, 5);
  auto parsed = ParsedDatagram::Parse(end.data(), end.size());
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed->header().version, 1);
  EXPECT_EQ(parsed->header().kind, DatagramKind::kEnd);
  EXPECT_EQ(parsed->header().count, 5u);
  EXPECT_EQ(MakeStreamEndDatagram(nullptr, 0, 3, 2, 5), MakeEndDatagram(3, 2, 5, kStreamVersion));
}

}  // namespace
}  // namespace meshstream::sdk_test
