// libFuzzer target for the stream reconstructor (docs/design/design.md, "Prediction" and "Hostile input"):
// whatever arrives on either channel, in whatever order and at whatever
// time, the reconstructor never crashes or hangs, never decodes past the
// stream, and every level it hands over is well formed; when only the
// sender's bytes arrived and every refinement was complete, the mesh is the
// real one. After an error (the session is over) nothing more is decoded.
//
// The stream is the sphere stream of sphere_stream.h. Input: byte 0 holds
//   bit 0     packing: 0 split, 1 bundled;
//   bits 1-3  window (0..7 refinements);
//   bits 4-6  byte budget: 512 << value;
//   bit 7     1: lod 2; 0: every refinement.
// Then a sequence of operations, each an opcode byte (mod 8) and its operands:
//   0  the next control block, at the current time;
//   1  i: the real datagram number i (one byte) of the stream's datagrams
//      and END datagrams, all refinements in order;
//   2  n, then n bytes: those bytes as a datagram;
//   3  d: the clock advances by d * 2 ms;
//   4  Poll at the current time;
//   5  Flush;
//   6  i, p, x: real datagram i with byte p (mod its size) xor x;
//   7  the datagrams and END of the refinement applied() + (next byte mod 3).
// Recovery is kPredict. Errors are fine (StreamReader::FinishRefinement fails
// on loss until recovery exists); after an error the reconstructor must keep
// returning errors and decode nothing more.
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes seed inputs there
// (run fuzz_reconstructor_replay on any folder with that variable pointing at
// tests/fuzz/corpus/reconstructor).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "codec/loss/reconstructor.h"
#include "tests/fuzz/fuzz_input.h"
#include "tests/fuzz/sphere_stream.h"

namespace {

using meshstream::StreamReconstructor;
using meshstream::fuzz::Bug;
using meshstream::fuzz::SphereStream;

constexpr char kTarget[] = "fuzz_reconstructor";
constexpr size_t kMaxInputBytes = size_t{1} << 16;
enum Op : uint8_t { kControl, kReal, kBytes, kClock, kPoll, kFlush, kMutated, kRefinement };

// The real datagrams of a stream, then its END datagrams.
const std::vector<std::vector<uint8_t>>& RealDatagrams(size_t packing) {
  static const std::vector<std::vector<std::vector<uint8_t>>> all = [] {
    std::vector<std::vector<std::vector<uint8_t>>> out(2);
    for (size_t p = 0; p < 2; ++p) {
      const auto& s = meshstream::fuzz::SphereStreams()[p].stream;
      for (const auto& level : s.datagrams) out[p].insert(out[p].end(), level.begin(), level.end());
      for (size_t r = 0; r < s.datagrams.size(); ++r)
        out[p].push_back(meshstream::MakeEndDatagram(0, static_cast<uint32_t>(r),
                                                     static_cast<uint32_t>(s.datagrams[r].size())));
    }
    return out;
  }();
  return all[packing];
}

void WriteSeeds() {
  const char* dir = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (!dir) return;
  const size_t levels = meshstream::fuzz::SphereStreams()[0].stream.control.size();
  for (uint8_t packing = 0; packing < 2; ++packing) {
    const std::string name = packing ? "recon-bundled" : "recon-split";
    const uint8_t roomy = static_cast<uint8_t>(packing | (7 << 1) | (7 << 4));
    // Everything in order: control, its data and END, poll.
    std::vector<uint8_t> seed = {roomy};
    for (size_t r = 0; r < levels; ++r) seed.insert(seed.end(), {kControl, kRefinement, 0, kPoll});
    meshstream::fuzz::WriteSeed(dir, name + "-in-order", seed);
    // Data first (the window's worth ahead), controls later, then a flush.
    seed = {roomy};
    for (size_t r = 0; r < levels; ++r) seed.insert(seed.end(), {kRefinement, 2, kControl, kRefinement, 0, kPoll});
    seed.push_back(kFlush);
    meshstream::fuzz::WriteSeed(dir, name + "-data-ahead", seed);
    // Single real datagrams by index, twice each, with clock steps (ENDs last).
    seed = {static_cast<uint8_t>(packing | (2 << 1) | (1 << 4))};
    for (size_t r = 0; r < 3; ++r) seed.push_back(kControl);
    for (size_t i = 0; i < RealDatagrams(packing).size() && i < 120; ++i)
      seed.insert(seed.end(), {kReal, static_cast<uint8_t>(i), kReal, static_cast<uint8_t>(i), kClock, 3, kPoll});
    meshstream::fuzz::WriteSeed(dir, name + "-singles", seed);
    // Lost ENDs: only the timeout finishes refinements.
    seed = {roomy};
    for (size_t r = 0; r < levels && r < 6; ++r) seed.insert(seed.end(), {kControl, kClock, 60, kPoll});
    meshstream::fuzz::WriteSeed(dir, name + "-timeouts", seed);
    // Garbage, mutated datagrams and a tight budget, with lod 2.
    seed = {static_cast<uint8_t>(packing | (1 << 1) | 0x80)};
    seed.insert(seed.end(), {kBytes, 6, 0x4D, 1, 1, 0, 0, 1, kMutated, 1, 5, 0x40, kMutated, 2, 3, 0x01, kControl,
                             kRefinement, 1, kRefinement, 0, kPoll, kControl, kRefinement, 0, kClock, 255, kPoll,
                             kControl, kFlush, kControl, kPoll});
    meshstream::fuzz::WriteSeed(dir, name + "-hostile", seed);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  if (size < 1 || size > kMaxInputBytes) return 0;
  const uint8_t select = data[0];
  const size_t packing = select & 1;
  const SphereStream& s = meshstream::fuzz::SphereStreams()[packing];
  const size_t levels = s.stream.control.size();
  const auto& real = RealDatagrams(packing);

  meshstream::ReconstructorOptions options;
  options.window = (select >> 1) & 7;
  options.max_buffered_bytes = size_t{512} << ((select >> 4) & 7);
  options.lod = (select & 0x80) ? 2 : -1;
  options.recovery = meshstream::Recovery::kPredict;
  options.straggler_timeout_us = 100000;
  StreamReconstructor rec = meshstream::fuzz::SphereReconstructor(kTarget, s, options);
  const size_t limit = options.lod < 0 ? levels : std::min<size_t>(levels, options.lod);

  meshstream::fuzz::Input in{data, size, 1};  // byte 0 was read above
  size_t controls = 0, applied = 0;
  uint64_t now = 0;
  bool failed = false, hostile = false;
  // After a call that may have decoded: monotone, bounded, well formed.
  auto check = [&](const meshstream::Status& status) {
    if (rec.applied() < applied) Bug(kTarget, "applied went backwards");
    if (rec.applied() > limit) Bug(kTarget, "decoded past the level of detail");
    if (failed && rec.applied() != applied) Bug(kTarget, "decoded after an error");
    if (failed && status.ok()) Bug(kTarget, "an error was forgotten");
    if (!status.ok()) failed = true;
    if (rec.applied() != applied) {
      applied = rec.applied();
      // A failed FinishRefinement may have applied part of its refinement:
      // after an error the mesh is not a level any more, and is not checked.
      if (status.ok()) {
        const meshstream::QuantizedMesh mesh = rec.reader().Mesh();
        const meshstream::QuantizedMesh& want = s.expected[applied - 1];
        meshstream::fuzz::CheckMesh(kTarget, mesh, want.vertex_count());
        // Only the sender's bytes, and every refinement complete: the real mesh.
        if (!hostile && rec.stats().finished_timeout == 0 &&
            (mesh.positions != want.positions || mesh.attributes != want.attributes || mesh.indices != want.indices))
          Bug(kTarget, "the real refinements decoded to a different mesh at level " + std::to_string(applied));
      }
    }
    if (rec.done() != (applied == limit)) Bug(kTarget, "done() disagrees with applied()");
  };
  auto offer = [&](const std::vector<uint8_t>& d) {
    // A copy of its own size, so ASan sees any over-read.
    const std::vector<uint8_t> copy = d;
    rec.OnDatagram(copy.data(), copy.size(), now);
  };
  while (!in.empty()) {
    const uint8_t op = in.Byte() % 8;
    switch (op) {
      case kControl: {
        const size_t r = controls < levels ? controls : 0;
        const meshstream::Status st = rec.OnControl(s.stream.control[r].data(), s.stream.control[r].size(), now);
        if (controls >= levels && st.ok()) Bug(kTarget, "a control block past the end was accepted");
        // Past the end is the caller's error, not the session's.
        check(controls >= levels && !failed ? meshstream::Status::Ok() : st);
        ++controls;
        break;
      }
      case kReal:
        offer(real[in.Byte() % real.size()]);
        break;
      case kBytes: {
        hostile = true;
        offer(in.Take(in.Byte()));
        break;
      }
      case kClock:
        now += uint64_t{in.Byte()} * 2000;
        break;
      case kPoll: {
        auto polled = rec.Poll(now);
        if (polled.ok() && rec.applied() != applied + polled.value()) Bug(kTarget, "Poll miscounted");
        check(polled.status());
        break;
      }
      case kFlush:
        check(rec.Flush());
        break;
      case kMutated: {
        hostile = true;
        std::vector<uint8_t> d = real[in.Byte() % real.size()];
        const uint8_t p = in.Byte(), x = in.Byte();
        if (!d.empty()) d[p % d.size()] ^= x;
        offer(d);
        break;
      }
      case kRefinement: {
        const size_t r = rec.applied() + in.Byte() % 3;
        if (r < levels) {
          for (const auto& d : s.stream.datagrams[r]) offer(d);
          offer(meshstream::MakeEndDatagram(0, static_cast<uint32_t>(r),
                                            static_cast<uint32_t>(s.stream.datagrams[r].size())));
        }
        break;
      }
    }
  }
  if (std::getenv("MESHSTREAM_FUZZ_VERBOSE"))
    std::fprintf(stderr, "applied %zu of %zu, failed %d, hostile %d\n", rec.applied(), limit, failed, hostile);
  const auto& st = rec.stats();
  if (st.accepted + st.duplicates + st.rejected + st.late + st.overflow > st.datagrams + st.ends)
    Bug(kTarget, "counted more outcomes than datagrams");
  return 0;
}
