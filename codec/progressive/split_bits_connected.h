// Split bits of the reliable profile (format version 4, profile 1;
// docs/spec/progressive-format.md, "Version 4"): an adaptive binary range coder
// whose contexts come from the coarser mesh as the decoder has it, which a
// loss-free transport guarantees to be the encoder's (the loss-tolerant
// profile may read only the reliable graph: split_bit_contexts.h).
//
// Vertices are coded in ascending id. The context of vertex v:
//   (hits * 3 + since) * 3 + degree, 27 contexts, where
//   - hits: how many triangles v shares with lower vertices already coded 1
//     in this refinement (0, 1-2, 3 or more: about 0, 1, 2 or more split
//     neighbours; under the matching rule a neighbour that splits makes a
//     split of v rarer, not impossible);
//   - since: refinements since v was made or last split (0, 1, 2 or more);
//   - degree: v's triangles (5 or fewer, 6, 7 or more).
// Not coded: the bit of a vertex on a boundary that has no seam twin (such
// a vertex never collapses: it is 0), and the bit of a vertex whose seam
// twin has a smaller id (its twin's bit, as in versions 2 and 3). A vertex
// is on a boundary when its triangles do not close around it: the base's
// are found once, and a split keeps it (a seam split's vertices are on the
// seam, an interior split's inside).
//
// Contract: the coder's state is the stream's: every refinement passes once,
// in order, after Reset (Encode, or Decode then Advance), each with the
// connectivity of the coarser mesh before it. Decode changes nothing, so a
// refused block leaves the coder as it was; it is safe on hostile bytes
// (fails on overrun and on a block whose bytes do not end with its last
// bit). O(vertices) per refinement plus O(valence) per split. Memory: 3
// bytes per vertex. Thread safety: one coder per stream.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_CONNECTED_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_CONNECTED_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/entropy/range_coder.h"
#include "codec/progressive/split_connectivity.h"

namespace meshstream {

class ConnectedSplitBits {
 public:
  static constexpr int kContexts = 27;
  using Models = std::array<BitModel, kContexts>;

  struct Decoded {
    std::vector<uint8_t> bits;
    Models models;
  };

  // The base mesh's connectivity (after SplitConnectivity::Reset).
  void Reset(const SplitConnectivity& base);
  uint32_t vertices() const { return static_cast<uint32_t>(since_.size()); }

  // `bits` has one entry per vertex of `mesh` (the coarser mesh); `twins`
  // per vertex its seam twin or kNoTwin (null: none). Advances the coder.
  std::vector<uint8_t> Encode(const std::vector<uint8_t>& bits, const SplitConnectivity& mesh,
                              const std::vector<uint32_t>* twins);
  StatusOr<Decoded> Decode(const uint8_t* data, size_t size, const SplitConnectivity& mesh,
                           const std::vector<uint32_t>* twins) const;
  // After a Decode that was accepted.
  void Advance(Decoded&& decoded);
  // The context each vertex of the next refinement is coded in, given its
  // bits (-1: not coded), without advancing: what the spec's test vector
  // lists.
  std::vector<int> Contexts(const std::vector<uint8_t>& bits, const SplitConnectivity& mesh,
                            const std::vector<uint32_t>* twins) const;

 private:
  // The context of v, or -1 when its bit is not coded (inferred 0).
  int Context(uint32_t v, const SplitConnectivity& mesh, const std::vector<uint8_t>& hits) const;
  // After v's bit 1: its higher neighbours' hits.
  static void Hit(uint32_t v, const SplitConnectivity& mesh, std::vector<uint8_t>& hits);
  // The vertices after a refinement with these bits: each split's new
  // vertex inherits its split vertex's boundary flag.
  void Step(const std::vector<uint8_t>& bits);

  Models models_;
  std::vector<uint8_t> since_;     // per vertex: refinements since it was made or split, at most 2
  std::vector<uint8_t> boundary_;  // per vertex: 1 on a boundary
  mutable std::vector<uint8_t> hits_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BITS_CONNECTED_H_
