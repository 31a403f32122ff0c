// libFuzzer target for a refinement's control block (split bits and the
// static models; the reliable channel of docs/design/design.md, "Reliable data"): hostile bytes
// get an error, never a crash, a hang or an unbounded allocation.
//
// The stream is the valid sphere stream of sphere_stream.h (split packing).
// Input: byte 0 selects the refinement r (byte 0 mod the refinement count);
// the rest replaces r's control block. Refinements before r are applied from
// the real stream. When BeginRefinement accepts the bytes, the real datagrams
// of r are offered (decoded with the models the fuzzer wrote) and the
// refinement is finished; when that succeeds the mesh must be well formed
// (every triangle on existing, distinct vertices, the header's vertex count),
// the next refinements are applied from the real stream and checked alike,
// and whenever everything decoded equals the real refinements the mesh is
// the real one. When BeginRefinement refuses the bytes, the reader must still
// take the real control block and decode the stream exactly from there.
// (Later refinements: the next kFollowingRefinements of sphere_stream.h.)
// A failure of any of these stops the fuzzer (__builtin_trap).
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes the real control
// blocks there as seeds (tests/fuzz/make_progressive_corpus.py).
#include <algorithm>
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

constexpr char kTarget[] = "fuzz_split_bits";
constexpr size_t kMaxInputBytes = size_t{1} << 16;

void WriteSeeds(const SphereStream& s) {
  const char* dir = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (!dir) return;
  for (size_t r = 0; r < s.stream.control.size(); ++r) {
    std::vector<uint8_t> seed = {static_cast<uint8_t>(r)};
    seed.insert(seed.end(), s.stream.control[r].begin(), s.stream.control[r].end());
    meshstream::fuzz::WriteSeed(dir, "control-" + std::to_string(r), seed);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const SphereStream& s = meshstream::fuzz::SphereStreams()[0];
  static const bool seeded = (WriteSeeds(s), true);
  (void)seeded;
  if (size < 1 || size > kMaxInputBytes) return 0;
  const size_t levels = s.stream.control.size();
  const size_t r = data[0] % levels;
  const std::vector<uint8_t> control(data + 1, data + size);  // exactly the bytes, for ASan

  StreamReader reader = s.prepared[r];
  const meshstream::Status begun = reader.BeginRefinement(control.data(), control.size());
  if (!begun.ok()) {
    if (begun.message().empty()) Bug(kTarget, "an error without a message");
    // The refused block must leave the reader as it was.
    const meshstream::Status real = reader.BeginRefinement(s.stream.control[r].data(), s.stream.control[r].size());
    if (!real.ok()) Bug(kTarget, "after a refused control block the real one fails: " + real.ToString());
    for (const auto& d : s.stream.datagrams[r]) reader.OfferDatagram(d.data(), d.size());
    const meshstream::Status finished = reader.FinishRefinement();
    if (!finished.ok()) Bug(kTarget, "after a refused control block the real refinement fails: " + finished.ToString());
    bool exact = true;
    meshstream::fuzz::CheckLevel(kTarget, s, reader, r, exact);
    if (!exact) Bug(kTarget, "after a refused control block the real refinement decodes differently");
    meshstream::fuzz::FinishWithRealData(kTarget, s, reader, r + 1, exact);
    if (reader.applied() != std::min(levels, r + 1 + meshstream::fuzz::kFollowingRefinements)) {
      Bug(kTarget, "after a refused control block the real stream does not decode");
    }
    return 0;
  }
  for (const auto& d : s.stream.datagrams[r]) reader.OfferDatagram(d.data(), d.size());
  if (!reader.FinishRefinement().ok()) return 0;
  bool exact = true;
  meshstream::fuzz::CheckLevel(kTarget, s, reader, r, exact);
  meshstream::fuzz::FinishWithRealData(kTarget, s, reader, r + 1, exact);
  return 0;
}
