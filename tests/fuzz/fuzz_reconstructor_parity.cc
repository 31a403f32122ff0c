// libFuzzer target for the stream reconstructor with parity
// (codec/loss/reconstructor.h, parity_recovery.h): the hold for announced
// parity (ExpectParity, parity_hold_us, StopHolding) and rebuilds from parity
// datagrams, whatever arrives in whatever order. It never crashes or hangs,
// never decodes past the stream, every level it hands over is well formed,
// and nothing stays held: once every control block is in, a Flush decodes
// everything (unless the session failed).
//
// The stream is the sphere stream of sphere_stream.h, sent once through the
// simulator with parity at 20 % loss (seed 1): its control events (with
// their parity_follows), data, END and parity datagrams are what the
// operations pick from. Input: byte 0 holds
//   bit 0     packing: 0 split, 1 bundled;
//   bits 1-3  window: 3 x value refinements;
//   bits 4-6  byte budget: 2048 << value;
//   bit 7     1: no hold (parity_hold_us 0); 0: 400 ms.
// Then operations, each an opcode byte (mod 8) and its operands:
//   0  the next control block (and ExpectParity when the sender announced it);
//   1  i: the sender's datagram number i (one byte: data, END and parity);
//   2  n, then n bytes: those bytes as a datagram;
//   3  d: the clock advances by d * 2 ms;
//   4  Poll at the current time;
//   5  Flush;
//   6  r: ExpectParity(r) for any refinement r (a hostile announcement);
//   7  StopHolding.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/loss/reconstructor.h"
#include "codec/loss/simulator.h"
#include "fec/reed_solomon.h"
#include "tests/fuzz/fuzz_input.h"
#include "tests/fuzz/sphere_stream.h"

namespace {

using meshstream::StreamReconstructor;
using meshstream::fuzz::Bug;
using meshstream::fuzz::SphereStream;

constexpr char kTarget[] = "fuzz_reconstructor_parity";
constexpr size_t kMaxInputBytes = size_t{1} << 16;
enum Op : uint8_t { kControl, kSent, kBytes, kClock, kPoll, kFlush, kExpect, kStop };

// What the sender sent of one packing: its datagrams (data, END, parity;
// owned copies), and per refinement whether its control announced parity.
struct Sent {
  std::vector<std::vector<uint8_t>> datagrams;
  std::vector<bool> parity_follows;
};

const Sent& SentOf(size_t packing) {
  static const std::vector<Sent> all = [] {
    std::vector<Sent> out(2);
    for (size_t p = 0; p < 2; ++p) {
      const auto& s = meshstream::fuzz::SphereStreams()[p].stream;
      meshstream::LossModel model;
      model.loss = 0.2;
      model.seed = 1;
      meshstream::SimulatedParity parity;
      parity.code = &meshstream::fec::DefaultErasureCode();
      parity.loss = 0.2;
      auto t = meshstream::SimulateTransmission(s, 0, s.control.size(), model, {}, {}, &parity);
      if (!t.ok()) Bug(kTarget, "the simulator fails: " + t.status().ToString());
      out[p].parity_follows.assign(s.control.size(), false);
      for (const auto& level : s.datagrams) out[p].datagrams.insert(out[p].datagrams.end(), level.begin(), level.end());
      for (const auto& e : t->end_datagrams) out[p].datagrams.push_back(e);
      for (const auto& d : t->parity_datagrams) out[p].datagrams.push_back(d);
      for (const auto& e : t->events) {
        if (e.kind == meshstream::ChannelEvent::Kind::kControl && e.parity_follows) out[p].parity_follows[e.refinement] = true;
      }
    }
    return out;
  }();
  return all[packing];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > kMaxInputBytes) return 0;
  const uint8_t select = data[0];
  const size_t packing = select & 1;
  const SphereStream& s = meshstream::fuzz::SphereStreams()[packing];
  const Sent& sent = SentOf(packing);
  const size_t levels = s.stream.control.size();

  meshstream::ReconstructorOptions options;
  options.window = 3 * ((select >> 1) & 7);
  options.max_buffered_bytes = size_t{2048} << ((select >> 4) & 7);
  options.parity_hold_us = (select & 0x80) ? 0 : 400000;
  options.erasure = &meshstream::fec::DefaultErasureCode();
  options.straggler_timeout_us = 100000;
  StreamReconstructor rec = meshstream::fuzz::SphereReconstructor(kTarget, s, options);

  meshstream::fuzz::Input in{data, size, 1};  // byte 0 was read above
  size_t controls = 0, applied = 0;
  uint64_t now = 0;
  bool failed = false;
  auto check = [&](const meshstream::Status& status) {
    if (rec.applied() < applied) Bug(kTarget, "applied went backwards");  // a decode again keeps it
    if (rec.applied() > levels) Bug(kTarget, "decoded past the stream");
    if (!status.ok()) failed = true;
    if (rec.applied() != applied) {
      applied = rec.applied();
      if (status.ok() && applied > 0) {
        meshstream::fuzz::CheckMesh(kTarget, rec.reader().Mesh(), s.expected[applied - 1].vertex_count());
      }
    }
  };
  auto offer = [&](const std::vector<uint8_t>& d) {
    const std::vector<uint8_t> copy = d;  // its own size, so ASan sees any over-read
    rec.OnDatagram(copy.data(), copy.size(), now);
  };
  while (!in.empty()) {
    switch (in.Byte() % 8) {
      case kControl: {
        if (controls >= levels) break;
        const meshstream::Status st =
            rec.OnControl(s.stream.control[controls].data(), s.stream.control[controls].size(), now);
        if (sent.parity_follows[controls]) rec.ExpectParity(static_cast<uint32_t>(controls));
        check(st);
        ++controls;
        break;
      }
      case kSent:
        offer(sent.datagrams[in.Byte() % sent.datagrams.size()]);
        break;
      case kBytes: {
        offer(in.Take(in.Byte()));
        break;
      }
      case kClock:
        now += uint64_t{in.Byte()} * 2000;
        break;
      case kPoll: {
        auto polled = rec.Poll(now);
        check(polled.status());
        break;
      }
      case kFlush: {
        const meshstream::Status st = rec.Flush();
        check(st);
        if (controls == levels && !failed && !rec.done()) Bug(kTarget, "a Flush left a refinement held");
        break;
      }
      case kExpect:
        rec.ExpectParity(in.Byte());
        break;
      case kStop:
        rec.StopHolding();
        break;
    }
  }
  return 0;
}
