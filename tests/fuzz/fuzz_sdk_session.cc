// libFuzzer target for the SDK's session core (sdk/session_core.h), as a
// hostile server drives it: any sequence of ServerMessages and UDP
// datagrams, at any times, mixed with the real session of a small artifact.
// Whatever arrives, the core never crashes, hangs or grows without bound;
// its events keep their order (kBaseReady, increasing kLevelReady, one
// kComplete or kError, nothing after); every mesh it shows is well formed;
// and what it asks to send is well formed (reports of refinements in the
// session, at most one repair request, nothing after `done`).
//
// The artifact is the rippled sphere of tests/common/sphere.h with a Draco
// base (tests/sdk/served_stream.h), served over UDP without loss: its real
// arrivals (SessionStart, control blocks, DATA, StreamDatagrams,
// RefinementEnds, SessionEnd) are what the operations pick from.
//
// Input: byte 0 holds
//   bit 0     repair;
//   bit 1     the real SessionStart says TRANSPORT_GRPC (its datagrams still come as picked);
//   bits 2-3  straggler timeout: 1, 5, 50 or 200 ms;
//   bit 4     a byte budget of 4 KiB;
//   bit 5     a time budget of 300 ms.
// Then operations, each an opcode byte (mod 10) and its operands:
//   0  i: the real arrival number i (one byte, mod their count);
//   1  the next real arrival in order;
//   2  n, then n bytes: a ServerMessage parsed from them (dropped if they do not parse);
//   3  n, then n bytes, then p: a UDP DATA payload of those bytes with packet number p;
//   4  n, then n bytes: a StreamDatagram with those bytes;
//   5  i, p, x: real arrival i with byte p (two bytes, mod its size) of its
//      serialization (a message, re-parsed) or payload (a datagram) xor x;
//   6  d: the clock advances by d ms;
//   7  a poll at the current time, the way sdk/session.cc polls;
//   8  d: the UDP thread lags d ms (the arrival horizon);
//   9  s: the stream ends (s even: OK; odd: UNAVAILABLE).
// At the end the host polls on for 15 s of clock (the repair's wait).
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes seed inputs there.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "tests/fuzz/fuzz_input.h"
#include "tests/fuzz/sphere_stream.h"
#include "tests/sdk/served_stream.h"

namespace {

using meshstream::fuzz::Bug;
using meshstream::fuzz::Input;
using meshstream::sdk_test::Arrival;
using namespace meshstream::sdk;  // NOLINT
namespace v1 = meshstream::v1;
using meshstream::Status;

constexpr char kTarget[] = "fuzz_sdk_session";
constexpr size_t kMaxInputBytes = size_t{1} << 15;
enum Op : uint8_t { kReal, kNext, kMessage, kUdp, kStreamDatagram, kMutated, kClock, kPoll, kLag, kStreamEnd };

struct Served {
  meshstream::sdk_test::ServedPrimitive primitive;
  std::vector<Arrival> arrivals;  // in order, times relative to the first
  size_t refinements = 0;
};

const Served& TheSession() {
  static const Served s = [] {
    Served out;
    out.primitive = meshstream::sdk_test::BuildServedSphere(3, 8, 10, 64);
    meshstream::sdk_test::NetworkOptions n;
    n.start_us = 0;
    n.timing.reliable_latency_us = 1000;
    n.timing.unreliable_latency_us = 1000;
    out.arrivals = meshstream::sdk_test::Serve({&out.primitive}, n).arrivals;
    out.refinements = out.primitive.stream.control.size();
    return out;
  }();
  return s;
}

struct Host {
  explicit Host(const SessionOptions& o) : core(o, kOpened) {}
  static constexpr uint64_t kOpened = 1000000;
  SessionCore core;
  uint64_t now = kOpened;
  uint64_t lag = 0;
  // The driver's queues: what arrived and is not yet taken (datagrams wait for the lagging thread).
  std::vector<std::pair<uint64_t, v1::ServerMessage>> messages;
  std::vector<Arrival> datagrams;
  bool stream_ended = false, stream_end_taken = false;
  Status stream_status;
  // What the checks follow.
  bool terminal = false, base = false, done_sent = false;
  int32_t level = 0;
  int repairs = 0;

  void Check(const Event& e) {
    if (terminal) Bug(kTarget, "an event after the session ended");
    switch (e.type) {
      case EventType::kBaseReady:
        if (base) Bug(kTarget, "a second kBaseReady");
        base = true;
        break;
      case EventType::kLevelReady:
        if (!base || e.level <= level) Bug(kTarget, "kLevelReady out of order");
        level = e.level;
        break;
      case EventType::kComplete:
        if (!base || e.level < level) Bug(kTarget, "kComplete out of order");
        terminal = true;
        break;
      case EventType::kError:
        if (e.status.ok()) Bug(kTarget, "kError without a status");
        terminal = true;
        break;
      default: Bug(kTarget, "an event of no type");
    }
    if (core.level_shown() > core.levels()) Bug(kTarget, "a level beyond the session");
    for (size_t p = 0; p < core.primitive_count(); ++p) {
      const meshstream::QuantizedMesh m = core.reader(p).Mesh();
      const size_t n = m.vertex_count();
      if (m.indices.size() % 3 != 0) Bug(kTarget, "indices are not triangles");
      for (uint32_t i : m.indices)
        if (i >= n) Bug(kTarget, "a triangle refers to a missing vertex");
    }
  }

  void Apply() {
    (void)core.TakeUdpStart();
    (void)core.TakeUdpStop();
    for (Outgoing& o : core.TakeOutgoing()) {
      if (done_sent) Bug(kTarget, "a message after done");
      StampHold(o, now);
      if (o.message.has_done()) done_sent = true;
      if (o.message.has_repair() && ++repairs > 1) Bug(kTarget, "a second repair request");
      if (o.message.has_report() && static_cast<int64_t>(o.message.report().refinement()) >= core.levels())
        Bug(kTarget, "a report of a refinement not in the session");
      if (o.half_close && !o.message.has_done()) Bug(kTarget, "a half-close without done");
    }
  }

  void Take() {
    const uint64_t horizon = now > lag ? now - lag : 0;
    core.SetArrivalHorizon(horizon);
    for (auto& [at, m] : messages) core.TakeMessage(std::move(m), at);
    messages.clear();
    std::vector<Arrival> rest;
    for (Arrival& a : datagrams) {
      if (a.at_us <= horizon) {
        core.TakeDatagram(std::move(a.payload), a.packet_number, a.at_us);
      } else {
        rest.push_back(std::move(a));
      }
    }
    datagrams = std::move(rest);
    if (stream_ended && !stream_end_taken) {
      stream_end_taken = true;
      core.TakeStreamEnd(stream_status);
    }
  }

  // Poll(0) until it returns nothing, as a host does each frame.
  void Poll() {
    for (int guard = 0; guard < 100000; ++guard) {
      if (auto e = core.NextEvent()) {
        Check(*e);
        continue;
      }
      if (core.over()) return;
      core.CheckEnd(now);
      Apply();
      if (core.has_event()) continue;
      Take();
      core.HandleArrivals(now);
      Apply();
      if (!core.has_event()) return;
    }
    Bug(kTarget, "a poll that never ends");
  }

  void Arrive(const Arrival& a) {
    if (a.is_message) {
      messages.emplace_back(now, a.message);
    } else {
      Arrival d = a;
      d.at_us = now;
      datagrams.push_back(std::move(d));
    }
  }
};

void WriteSeeds() {
  const char* dir = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (!dir) return;
  const size_t count = TheSession().arrivals.size();
  auto in_order = [&](uint8_t flags, size_t skip_every, bool polls) {
    std::vector<uint8_t> s = {flags};
    for (size_t i = 0; i < count; ++i) {
      if (skip_every != 0 && i % skip_every == skip_every - 1 && !TheSession().arrivals[i].is_message) {
        s.insert(s.end(), {kReal, static_cast<uint8_t>((i + 1) % count)});  // a copy instead of the datagram
        continue;
      }
      s.push_back(kNext);
      if (polls) s.insert(s.end(), {kClock, 1, kPoll});
    }
    s.push_back(kPoll);
    return s;
  };
  meshstream::fuzz::WriteSeed(dir, "in-order-udp", in_order(2 << 2, 0, true));
  meshstream::fuzz::WriteSeed(dir, "in-order-grpc", in_order(2 | (2 << 2), 0, true));
  meshstream::fuzz::WriteSeed(dir, "lossy-repair", in_order(1 | (2 << 2), 3, true));
  meshstream::fuzz::WriteSeed(dir, "late-poller", in_order(1 << 2, 0, false));
  meshstream::fuzz::WriteSeed(dir, "byte-budget", in_order(0x10 | (2 << 2), 0, true));
  std::vector<uint8_t> lag = {3 << 2, kLag, 200};
  for (size_t i = 0; i < count; ++i) lag.insert(lag.end(), {kNext, kClock, 3, kPoll});
  meshstream::fuzz::WriteSeed(dir, "starved-udp-thread", lag);
  std::vector<uint8_t> hostile = {2 << 2, kNext, kPoll, kMutated, 3, 0, 5, 0x40, kMessage, 4, 0x1a, 0x02, 0x08, 0x63,
                                  kUdp, 6, 0x4d, 2, 3, 3, 0, 9, 7, kStreamEnd, 1, kPoll};
  meshstream::fuzz::WriteSeed(dir, "hostile-mix", hostile);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  if (size == 0 || size > kMaxInputBytes) return 0;
  const Served& served = TheSession();
  Input in{data, size};
  const uint8_t flags = in.Byte();
  SessionOptions o;
  o.asset = "sphere";
  o.repair = (flags & 1) != 0;
  static const int32_t kTimeouts[] = {1, 5, 50, 200};
  o.straggler_timeout_ms = kTimeouts[(flags >> 2) & 3];
  if (flags & 0x10) o.byte_budget = 4096;
  if (flags & 0x20) o.time_budget_ms = 300;
  if (o.repair) o.byte_budget = o.time_budget_ms = 0;  // not with a budget (Session::Open's rule)
  Host host(o);
  const size_t count = served.arrivals.size();
  size_t cursor = 0;
  auto real = [&](size_t i) {
    Arrival a = served.arrivals[i % count];
    if (i % count == 0 && (flags & 2) && a.is_message && a.message.has_session()) {
      a.message.mutable_session()->set_transport(v1::TRANSPORT_GRPC);
    }
    return a;
  };
  while (!in.empty()) {
    switch (in.Byte() % 10) {
      case kReal: host.Arrive(real(in.Byte())); break;
      case kNext: host.Arrive(real(cursor++)); break;
      case kMessage: {
        Arrival a;
        const std::string bytes = in.Bytes(in.Byte());
        if (a.message.ParseFromString(bytes)) host.Arrive(a);
        break;
      }
      case kUdp: {
        Arrival a;
        a.is_message = false;
        const std::string bytes = in.Bytes(in.Byte());
        a.payload.assign(bytes.begin(), bytes.end());
        a.packet_number = in.Byte();
        host.Arrive(a);
        break;
      }
      case kStreamDatagram: {
        Arrival a;
        a.message.mutable_datagram()->set_payload(in.Bytes(in.Byte()));
        host.Arrive(a);
        break;
      }
      case kMutated: {
        Arrival a = real(in.Byte());
        const size_t p = size_t{in.Byte()} | size_t{in.Byte()} << 8;
        const uint8_t x = in.Byte();
        if (a.is_message) {
          std::string bytes = a.message.SerializeAsString();
          if (!bytes.empty()) bytes[p % bytes.size()] = static_cast<char>(bytes[p % bytes.size()] ^ x);
          v1::ServerMessage m;
          if (!m.ParseFromString(bytes)) break;
          a.message = std::move(m);
        } else if (!a.payload.empty()) {
          a.payload[p % a.payload.size()] ^= x;
        }
        host.Arrive(a);
        break;
      }
      case kClock: host.now += uint64_t{in.Byte()} * 1000; break;
      case kPoll: host.Poll(); break;
      case kLag: host.lag = uint64_t{in.Byte()} * 1000; break;
      case kStreamEnd: {
        const uint8_t s = in.Byte();
        if (!host.stream_ended) {
          host.stream_ended = true;
          host.stream_status = s % 2 == 0 ? Status::Ok() : meshstream::Unavailable("the server went away");
        }
        break;
      }
    }
  }
  // The host polls on: every window, the repair's wait, runs out.
  host.lag = 0;
  for (int i = 0; i < 16 && !(host.core.over() && !host.core.has_event()); ++i) {
    host.Poll();
    host.now += 1000000;
  }
  host.Poll();
  if (host.core.over() && !host.terminal) Bug(kTarget, "over without kComplete or kError");
  return 0;
}
