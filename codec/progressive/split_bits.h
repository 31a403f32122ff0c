// Coding of a refinement's split bits in versions 1 and 2 (version 3:
// split_bit_contexts.h) (one per vertex of the coarser mesh,
// in canonical order) on the reliable channel: an adaptive binary range coder
// whose contexts use only reliable data (docs/design/design.md, "Reliable data"):
//   - the vertex's age: created by the previous refinement, by the one
//     before, or older (base mesh);
//   - for a vertex created by the previous refinement, whether the vertex it
//     was split from splits now (the two are adjacent, and split vertices of
//     one refinement never are); for an older vertex, whether it split in
//     the previous refinement.
// (The split bit of id - 1 as a further context was measured and gave
// nothing on the bunny: 4.45 against 4.42 reliable bits per vertex.)
// Contract: pure; Decode is safe on hostile bytes (fails on overrun, and on a
// block whose bytes do not end exactly with its last bit).
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_H_

#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/progressive/seam_twins.h"

namespace meshstream {

// What earlier refinements tell about the vertices of the current one.
struct SplitHistory {
  uint32_t vertices = 0;                 // vertices of the coarser mesh
  uint32_t previous_start = UINT32_MAX;  // first id created by the previous refinement
  uint32_t older_start = UINT32_MAX;     // first id created by the one before
  std::vector<uint8_t> previous_bits;    // split bits of the previous refinement
  std::vector<uint32_t> previous_splits; // its split vertices: new id previous_start + j came from [j]

  // The history of the refinement after this one, given this one's bits.
  SplitHistory Next(const std::vector<uint8_t>& bits) const;
};

// `twin` (optional, per vertex of the coarser mesh; seam_twins.h): a vertex
// whose seam twin has a smaller id takes its twin's bit, which is not coded
// (the two copies of a seam vertex split together). The encoder's bits
// must agree.
// The twin of v whose bit v takes: its twin when that has a smaller id, else
// kNoTwin (seam_twins.h). Versions 2 and 3 share the rule.
inline uint32_t TwinWithSmallerId(uint32_t v, const std::vector<uint32_t>* twin) {
  if (twin == nullptr || v >= twin->size()) return kNoTwin;
  const uint32_t t = (*twin)[v];
  return t < v ? t : kNoTwin;
}

std::vector<uint8_t> EncodeSplitBits(const std::vector<uint8_t>& bits, const SplitHistory& history,
                                     const std::vector<uint32_t>* twin = nullptr);
StatusOr<std::vector<uint8_t>> DecodeSplitBits(const uint8_t* data, size_t size, const SplitHistory& history,
                                               const std::vector<uint32_t>* twin = nullptr);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_H_
