// What a server sends for one session, made from a real artifact without
// services/: a mesh encoded by the codec (Draco base, the progressive
// stream), turned into the session's ServerMessages and DATA payloads as
// docs/spec/streaming-protocol.md ("Sessions") lays them out, and sent through a
// seeded simulated network (codec/loss/simulator.h's loss, reordering and
// duplicates, and its link timing) to a SessionCore driven the way
// sdk/session.cc drives it, on a simulated clock.
//
// Used by tests/sdk/ and tests/fuzz/fuzz_sdk_session.cc.
#ifndef MESHSTREAM_TESTS_SDK_SERVED_STREAM_H_
#define MESHSTREAM_TESTS_SDK_SERVED_STREAM_H_

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "codec/loss/simulator.h"
#include "codec/progressive/encoder.h"
#include "importers/draco_base_coder.h"
#include "importers/draco_codec.h"
#include "sdk/session_core.h"
#include "tests/common/sphere.h"

namespace meshstream::sdk_test {

using namespace meshstream::sdk;  // NOLINT: the test helpers speak the SDK

[[noreturn]] inline void Die(const std::string& what) {
  std::fprintf(stderr, "served stream: %s\n", what.c_str());
  std::abort();
}

// One primitive of the artifact.
struct ServedPrimitive {
  uint32_t stream_id = 0;
  ProgressiveStream stream;
  std::string base_bytes;  // Draco
  DracoAttributeIds ids;
  std::vector<QuantizedMesh> levels;  // [i]: after i refinements, decoded without loss
};

// The rippled sphere (tests/common/sphere.h) encoded with a Draco base,
// `packet_bytes` per datagram (small: several datagrams per refinement).
inline ServedPrimitive BuildServedSphere(uint32_t stream_id, int rings = 12, int segments = 16,
                                         uint32_t packet_bytes = 96) {
  ProgressiveEncodeOptions options;
  DracoAttributeIds ids;
  auto enc = EncodeProgressive(test_util::RippledSphere(rings, segments), options,
                               [&](const QuantizedMesh& base, int method) { return EncodeDracoBase(base, method, 7, &ids); });
  if (!enc.ok()) Die(enc.status().ToString());
  StreamWriteOptions wo;
  wo.packet_bytes = packet_bytes;
  wo.stream_id = stream_id;
  auto stream = WriteStream(enc.value(), options.quantization, wo);
  if (!stream.ok()) Die(stream.status().ToString());
  ServedPrimitive s;
  s.stream_id = stream_id;
  s.stream = std::move(stream).value();
  s.base_bytes.assign(enc->base_bytes.begin(), enc->base_bytes.end());
  s.ids = ids;
  auto reader = StreamReader::Create(s.stream.header.data(), s.stream.header.size(), stream_id);
  if (!reader.ok()) Die(reader.status().ToString());
  auto base = DecodeDracoBase(enc->base_bytes.data(), enc->base_bytes.size(), ids, reader->header().grids);
  if (!base.ok() || !reader->SetBase(std::move(base).value()).ok()) Die("base");
  s.levels.push_back(reader->Mesh());
  for (size_t i = 0; i < s.stream.control.size(); ++i) {
    if (!reader->BeginRefinement(s.stream.control[i].data(), s.stream.control[i].size()).ok()) Die("begin");
    for (const auto& d : s.stream.datagrams[i])
      if (!reader->OfferDatagram(d.data(), d.size())) Die("a real datagram was refused");
    if (!reader->FinishRefinement().ok()) Die("finish");
    s.levels.push_back(reader->Mesh());
  }
  return s;
}

inline std::string AsString(const std::vector<uint8_t>& b) { return std::string(b.begin(), b.end()); }

inline v1::PrimitiveStart StartOf(const ServedPrimitive& p, uint32_t mesh, uint32_t refinements) {
  v1::PrimitiveStart s;
  s.set_primitive(p.stream_id);
  s.set_mesh(mesh);
  s.set_mesh_primitive(0);
  s.set_header(AsString(p.stream.header));
  s.set_base_mesh(p.base_bytes);
  s.set_refinements(refinements);
  for (const auto& [name, id] : DracoAttributeNames(p.ids)) (*s.mutable_draco_attributes())[name] = id;
  return s;
}

inline v1::ServerMessage SessionStartMessage(const std::vector<const ServedPrimitive*>& primitives, bool udp,
                                             uint32_t refinements) {
  v1::ServerMessage m;
  v1::SessionStart& s = *m.mutable_session();
  s.set_session_id("0123456789abcdef");
  s.set_asset("sphere");
  s.set_version(1);
  uint32_t mesh = 0;
  for (const ServedPrimitive* p : primitives) {
    const uint32_t own = std::min<uint32_t>(refinements, static_cast<uint32_t>(p->stream.control.size()));
    *s.add_primitives() = StartOf(*p, mesh++, own);
  }
  s.set_transport(udp ? v1::TRANSPORT_UDP : v1::TRANSPORT_GRPC);
  if (udp) {
    s.mutable_udp()->set_port(7601);
    s.set_udp_session_id(0x1122334455667788ull);
    s.set_client_to_server_key(std::string(32, 'c'));
    s.set_server_to_client_key(std::string(32, 's'));
    s.set_max_datagram_bytes(1472);
  }
  return m;
}

// An arrival at the client: a message of the stream, or a UDP DATA payload.
struct Arrival {
  uint64_t at_us = 0;
  bool is_message = true;
  v1::ServerMessage message;
  std::vector<uint8_t> payload;  // UDP
  uint64_t packet_number = 0;
  // For the tests: the datagram's refinement and ordinal (-1: an END).
  uint32_t primitive = 0, refinement = 0;
  int64_t ordinal = -1;
};

struct NetworkOptions {
  LossModel model;               // loss, bursts, reordering, duplicates, seed
  LinkTiming timing;             // codec/loss/simulator.h's schedule
  bool udp = true;               // false: every datagram on the stream (TRANSPORT_GRPC)
  uint32_t refinements = 255;    // max_level: refinements per primitive in the session
  uint64_t start_us = 1000000;   // the SessionStart's arrival; refinement 0 starts then
  std::vector<uint32_t> reliable;  // refinements of the reliable cut (datagrams on the stream)
};

// Every arrival of a session, by arrival time (ties: the stream first),
// and what the network lost (primitive, refinement) -> ordinals.
struct Schedule {
  std::vector<Arrival> arrivals;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> lost;
};

// The session as the server sends it: SessionStart; per primitive and
// refinement its control block, its datagrams and END (UDP DATA numbered
// first_packet_number + k, or StreamDatagrams), RefinementEnd; SessionEnd.
// The UDP datagrams go through SimulateTransmission (loss, reordering,
// duplicates, timing); the stream is ordered and lossless, arriving
// reliable_latency_us after the sending.
inline Schedule Serve(const std::vector<const ServedPrimitive*>& primitives, const NetworkOptions& n) {
  Schedule out;
  Arrival start;
  start.at_us = n.start_us;
  start.message = SessionStartMessage(primitives, n.udp, n.refinements);
  out.arrivals.push_back(std::move(start));
  uint64_t packet_number = 0;
  uint64_t last_stream_us = n.start_us;
  for (size_t pi = 0; pi < primitives.size(); ++pi) {
    const ServedPrimitive& p = *primitives[pi];
    const size_t count = std::min<size_t>(n.refinements, p.stream.control.size());
    LossModel model = n.model;
    model.seed = n.model.seed * 31 + pi;
    std::vector<uint32_t> reliable = n.reliable;
    if (!n.udp) {  // over gRPC every refinement is on the stream
      reliable.clear();
      for (size_t r = 0; r < count; ++r) reliable.push_back(static_cast<uint32_t>(r));
    }
    auto t = SimulateTransmission(p.stream, p.stream_id, count, model, n.timing, reliable);
    if (!t.ok()) Die(t.status().ToString());
    // The first packet number of each refinement, and which datagram an event is.
    std::vector<uint64_t> first(count);
    for (size_t r = 0; r < count; ++r) {
      first[r] = packet_number;
      packet_number += p.stream.datagrams[r].size() + 1;
    }
    std::vector<std::vector<uint8_t>> delivered(count);
    for (size_t r = 0; r < count; ++r) delivered[r].assign(p.stream.datagrams[r].size(), 0);
    const uint64_t offset = n.start_us + (n.timing.refinement_interval_us * pi) / std::max<size_t>(1, primitives.size());
    for (const ChannelEvent& e : t->events) {
      Arrival a;
      a.at_us = offset + e.time_us;
      a.primitive = p.stream_id;
      if (e.kind == ChannelEvent::Kind::kControl) {
        const uint32_t r = e.refinement;
        const bool reliable = !n.udp || std::binary_search(n.reliable.begin(), n.reliable.end(), r);
        v1::ControlBlock& c = *a.message.mutable_control();
        c.set_primitive(p.stream_id);
        c.set_refinement(r);
        c.set_control(AsString(p.stream.control[r]));
        c.set_datagrams(static_cast<uint32_t>(p.stream.datagrams[r].size()));
        if (n.udp) c.set_first_packet_number(first[r]);
        c.set_reliable(reliable);
        a.refinement = r;
        out.arrivals.push_back(std::move(a));
        continue;
      }
      // Which datagram: by its address in the stream or among the ENDs.
      bool found = false;
      for (size_t r = 0; r < count && !found; ++r) {
        const auto& ds = p.stream.datagrams[r];
        for (size_t k = 0; k < ds.size(); ++k) {
          if (ds[k].data() != e.data) continue;
          a.refinement = static_cast<uint32_t>(r);
          a.ordinal = static_cast<int64_t>(k);
          delivered[r][k] = 1;
          found = true;
          break;
        }
        if (!found && t->end_datagrams[r].data() == e.data) {
          a.refinement = static_cast<uint32_t>(r);
          found = true;
        }
      }
      if (!found) Die("an event of no datagram");
      const bool reliable = !n.udp || std::binary_search(n.reliable.begin(), n.reliable.end(), a.refinement);
      if (reliable) {
        a.message.mutable_datagram()->set_payload(std::string(reinterpret_cast<const char*>(e.data), e.size));
      } else {
        a.is_message = false;
        a.payload.assign(e.data, e.data + e.size);
        a.packet_number = first[a.refinement] + (a.ordinal < 0 ? p.stream.datagrams[a.refinement].size()
                                                              : static_cast<uint64_t>(a.ordinal));
      }
      out.arrivals.push_back(std::move(a));
    }
    for (size_t r = 0; r < count; ++r) {
      // RefinementEnd: on the stream after the END datagram was sent.
      Arrival a;
      a.at_us = offset + r * n.timing.refinement_interval_us +
                (p.stream.datagrams[r].size() + 1) * n.timing.datagram_interval_us + n.timing.reliable_latency_us;
      a.primitive = p.stream_id;
      a.refinement = static_cast<uint32_t>(r);
      v1::RefinementEnd& e = *a.message.mutable_refinement_end();
      e.set_primitive(p.stream_id);
      e.set_refinement(static_cast<uint32_t>(r));
      e.set_datagrams_sent(static_cast<uint32_t>(p.stream.datagrams[r].size()));
      last_stream_us = std::max(last_stream_us, a.at_us);
      out.arrivals.push_back(std::move(a));
      for (size_t k = 0; k < delivered[r].size(); ++k)
        if (!delivered[r][k]) out.lost[{p.stream_id, static_cast<uint32_t>(r)}].push_back(static_cast<uint32_t>(k));
    }
  }
  Arrival end;
  end.at_us = last_stream_us + 1;
  end.message.mutable_end()->set_reason(n.refinements < 255 ? "max_level" : "complete");
  out.arrivals.push_back(std::move(end));
  std::stable_sort(out.arrivals.begin(), out.arrivals.end(), [](const Arrival& a, const Arrival& b) {
    if (a.at_us != b.at_us) return a.at_us < b.at_us;
    return a.is_message && !b.is_message;
  });
  // The stream is ordered: a control block, its StreamDatagrams and its
  // RefinementEnd keep the server's order (the sort is stable on equal times,
  // and the simulator's reliable events are in order).
  return out;
}

// The host and its driver, simulated: Poll as sdk/session.cc runs it, on a
// clock that the test moves. The UDP thread hands datagrams over
// `udp_lag_us` after they reached the socket (a starved thread), and the
// arrival horizon lags as much.
struct SimHost {
  SessionCore core;
  std::vector<Arrival> pending;  // not yet taken, by arrival time
  size_t next = 0;
  uint64_t now_us = 0;
  uint64_t udp_lag_us = 0;
  bool stream_end_after_last = false;  // the stream ends (OK) after its last message
  Status stream_end_status;
  bool stream_end_taken = false;
  std::vector<Event> events;
  std::vector<uint64_t> event_times;  // when each event was handed out
  UdpCounters udp;                  // what the UDP receiver would show (hello_rtt_us: the loss rules)
  std::vector<Outgoing> sent;       // what the client wrote on the stream, in order
  bool half_closed = false;
  std::optional<UdpStart> udp_started;
  bool udp_stopped = false;

  SimHost(const SessionOptions& o, uint64_t opened_us) : core(o, opened_us), now_us(opened_us) {}

  void Apply() {
    if (auto u = core.TakeUdpStart()) udp_started = *u;
    if (core.TakeUdpStop()) udp_stopped = true;
    for (Outgoing& o : core.TakeOutgoing()) {
      StampHold(o, now_us);
      sent.push_back(std::move(o));
      if (sent.back().half_close) half_closed = true;
    }
  }

  uint64_t LastMessageUs() const {
    uint64_t last = 0;
    for (const Arrival& a : pending)
      if (a.is_message) last = std::max(last, a.at_us);
    return last;
  }

  // Takes what has arrived by now (datagrams only once the lagging UDP
  // thread has handed them over).
  void Take() {
    const uint64_t horizon = now_us > udp_lag_us ? now_us - udp_lag_us : 0;
    core.SetArrivalHorizon(horizon);
    // Each channel in its own order: messages by arrival, datagrams by
    // arrival; a datagram is taken once the UDP thread got to it.
    std::vector<Arrival> rest;
    for (size_t i = next; i < pending.size(); ++i) {
      Arrival& a = pending[i];
      const bool taken = a.is_message ? a.at_us <= now_us : a.at_us <= horizon;
      if (!taken) {
        rest.push_back(std::move(a));
        continue;
      }
      if (a.is_message) {
        core.TakeMessage(std::move(a.message), a.at_us);
      } else {
        core.TakeDatagram(std::move(a.payload), a.packet_number, a.at_us);
      }
    }
    pending = std::move(rest);
    next = 0;
    if (stream_end_after_last && !stream_end_taken && (pending.empty() || std::none_of(pending.begin(), pending.end(), [](const Arrival& a) { return a.is_message; }))) {
      stream_end_taken = true;
      core.TakeStreamEnd(stream_end_status);
    }
  }

  // One Poll(0) of the host at `now_us`: at most one event.
  std::optional<Event> PollOnce() {
    for (int round = 0; round < 2; ++round) {
      if (auto e = core.NextEvent()) {
        events.push_back(*e);
        event_times.push_back(now_us);
        return e;
      }
      if (core.over()) return std::nullopt;
      core.SetUdpCounters(udp);
      core.CheckEnd(now_us);
      Apply();
      if (core.has_event()) continue;
      Take();
      core.HandleArrivals(now_us);
      Apply();
      if (!core.has_event()) return std::nullopt;
    }
    if (auto e = core.NextEvent()) {
      events.push_back(*e);
      event_times.push_back(now_us);
      return e;
    }
    return std::nullopt;
  }

  // The host polls every `interval_us` (draining every event at each poll)
  // until the session is over or `until_us`.
  void Run(uint64_t interval_us, uint64_t until_us) {
    while (now_us <= until_us) {
      while (PollOnce()) {
      }
      if (core.over() && !core.has_event()) return;
      now_us += interval_us;
    }
  }
};

}  // namespace meshstream::sdk_test

#endif  // MESHSTREAM_TESTS_SDK_SERVED_STREAM_H_
