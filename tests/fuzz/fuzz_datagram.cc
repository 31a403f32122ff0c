// libFuzzer target for UDP datagrams (docs/design/design.md, "Independent datagrams" and "Hostile input"): whatever
// bytes arrive, the reader drops or uses each datagram whole, never crashes,
// hangs or allocates beyond what the refinement's split count allows, and a
// refinement it finishes is well formed.
//
// The stream is the valid sphere stream of sphere_stream.h, in either
// packing. Input: byte 0 holds
//   bit 0     packing: 0 split, 1 bundled;
//   bit 1     1: the rest is one datagram; 0: the rest is a sequence of
//             datagrams, each a 2-byte little-endian length and its bytes
//             (a length past the end takes what is left);
//   bit 2     1: offer the real datagrams of the refinement afterwards;
//   bits 3-7  the refinement r (mod the refinement count).
// Refinements before r come from the real stream, then BeginRefinement(r)
// with the real control block, the fuzzer's datagrams, optionally the real
// ones, and FinishRefinement (an error is fine). When it succeeds the mesh
// must be well formed (every triangle on existing, distinct vertices, the
// header's vertex count), the next kFollowingRefinements (sphere_stream.h)
// are applied from the real stream and checked alike, and whenever
// everything decoded equals the real refinements the mesh is the real one;
// otherwise __builtin_trap.
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes the real datagrams
// there as seeds (tests/fuzz/make_progressive_corpus.py).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "tests/fuzz/sphere_stream.h"

namespace {

using meshstream::StreamReader;
using meshstream::fuzz::Bug;
using meshstream::fuzz::SphereStream;

constexpr char kTarget[] = "fuzz_datagram";
constexpr size_t kMaxInputBytes = size_t{1} << 17;
constexpr uint8_t kBundled = 1, kSingle = 2, kThenReal = 4;

void WriteSeeds() {
  const char* dir = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (!dir) return;
  for (uint8_t packing = 0; packing < 2; ++packing) {
    const SphereStream& s = meshstream::fuzz::SphereStreams()[packing];
    const std::string name = packing ? "bundled" : "split";
    for (size_t r = 0; r < s.stream.control.size(); ++r) {
      const uint8_t select = static_cast<uint8_t>(packing | (r << 3));
      const auto& datagrams = s.stream.datagrams[r];
      // Each of the first two datagrams alone, then completed by the real ones.
      for (size_t d = 0; d < datagrams.size() && d < 2; ++d) {
        std::vector<uint8_t> seed = {static_cast<uint8_t>(select | kSingle | kThenReal)};
        seed.insert(seed.end(), datagrams[d].begin(), datagrams[d].end());
        meshstream::fuzz::WriteSeed(dir, name + "-r" + std::to_string(r) + "-d" + std::to_string(d), seed);
      }
      // All of them, in reverse order: the refinement completes.
      std::vector<uint8_t> seed = {select};
      for (size_t d = datagrams.size(); d-- > 0;) {
        seed.push_back(static_cast<uint8_t>(datagrams[d].size()));
        seed.push_back(static_cast<uint8_t>(datagrams[d].size() >> 8));
        seed.insert(seed.end(), datagrams[d].begin(), datagrams[d].end());
      }
      meshstream::fuzz::WriteSeed(dir, name + "-r" + std::to_string(r) + "-all", seed);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  if (size < 1 || size > kMaxInputBytes) return 0;
  const uint8_t select = data[0];
  const SphereStream& s = meshstream::fuzz::SphereStreams()[select & kBundled];
  const size_t levels = s.stream.control.size();
  const size_t r = static_cast<size_t>(select >> 3) % levels;

  // Every datagram in a buffer of its own size, so ASan sees any over-read.
  std::vector<std::vector<uint8_t>> datagrams;
  if (select & kSingle) {
    datagrams.emplace_back(data + 1, data + size);
  } else {
    for (size_t at = 1; at < size;) {
      size_t length = data[at];
      if (at + 1 < size) length |= size_t{data[at + 1]} << 8;
      at += 2;
      if (at > size) at = size;
      length = std::min(length, size - at);
      datagrams.emplace_back(data + at, data + at + length);
      at += length;
    }
  }

  StreamReader reader = s.prepared[r];
  const meshstream::Status begun = reader.BeginRefinement(s.stream.control[r].data(), s.stream.control[r].size());
  if (!begun.ok()) Bug(kTarget, "the real control block fails: " + begun.ToString());
  const uint64_t before = reader.stats().accepted + reader.stats().rejected + reader.stats().duplicates;
  for (const auto& d : datagrams) reader.OfferDatagram(d.data(), d.size());
  const uint64_t after = reader.stats().accepted + reader.stats().rejected + reader.stats().duplicates;
  if (after - before != datagrams.size()) Bug(kTarget, "a datagram was not counted");
  if (select & kThenReal)
    for (const auto& d : s.stream.datagrams[r]) reader.OfferDatagram(d.data(), d.size());
  if (!reader.FinishRefinement().ok()) return 0;
  bool exact = true;
  meshstream::fuzz::CheckLevel(kTarget, s, reader, r, exact);
  meshstream::fuzz::FinishWithRealData(kTarget, s, reader, r + 1, exact);
  return 0;
}
