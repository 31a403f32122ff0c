// Coding of split bits in version 3 (tool kToolSplitContexts;
// docs/spec/progressive-format.md, section 4.6): an adaptive binary range coder
// whose 41 contexts are computed from reliable data only (docs/design/design.md,
// "Reliable data") and whose models adapt over the whole stream (the
// reliable channel is ordered, so refinement i's block is decoded after
// refinement i - 1's).
//
// The reliable graph. What the decoder knows for certain about adjacency
// whatever was lost: the base mesh's edges between vertices that never
// split, and the edge between a vertex and the vertex its latest split made
// (or, for a vertex a split made, its parent) as long as neither has split
// since. A split changes its vertex's ring in a way only the (unreliable)
// wings tell, so every other edge of a split vertex is forgotten.
//
// The context of vertex v in refinement i:
//   - 40 when a reliable neighbour u < v splits in refinement i: split
//     vertices of one refinement are never adjacent, so v almost surely
//     does not split (a context rather than an inference, so that a mesh
//     that broke the rule would still code, only dearer);
//   - else (min(since, 4) * 2 + related) * 4 + min(degree, 3), where `since`
//     counts the refinements since v was last split or made (0: in
//     refinement i - 1; a base vertex that never split: i), `related` is the
//     bit of v's parent in refinement i for a vertex made by refinement
//     i - 1 and v's own bit in refinement i - 1 otherwise, and `degree` is
//     v's number of reliable neighbours.
// Measured before it was built (bench/codec_levers_v3.cc, docs/design/codec.md):
// 3.10 against version 2's 3.52 bits per split on the bunny at qp 11.
//
// A vertex whose seam twin has a smaller id takes its twin's bit, which is
// not coded (as in version 2).
//
// Contract: the coder's state (graph and models) is the stream's: every
// refinement of it passes once, in order, after Reset (Encode, or Decode
// then Advance). Decode changes nothing, so a refused block leaves the
// coder as it was; it is safe on hostile bytes (fails on overrun and on a
// block whose bytes do not end with its last bit). Memory: 7 bytes per
// vertex plus the base's adjacency. Thread safety: one coder per stream.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BIT_CONTEXTS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BIT_CONTEXTS_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/entropy/range_coder.h"

namespace meshstream {

class SplitBitContexts {
 public:
  static constexpr int kContexts = 41;
  using Models = std::array<BitModel, kContexts>;

  // A refinement's decoded bits and the models as they adapted to them.
  struct Decoded {
    std::vector<uint8_t> bits;
    Models models;
  };

  // The base mesh: `base_vertices` vertices and its triangles (three ids
  // each, all below base_vertices; repeated edges and degenerate triangles
  // are allowed). The triangles' order does not matter.
  Status Reset(uint32_t base_vertices, const std::vector<uint32_t>& base_indices);

  // One refinement's bits, one per vertex of the coarser mesh (as many as
  // the graph has vertices), coded; the coder moves on to the next
  // refinement. `twin` as in split_bits.h (optional).
  std::vector<uint8_t> Encode(const std::vector<uint8_t>& bits, const std::vector<uint32_t>* twin = nullptr);
  // The bits of the next refinement; the coder is unchanged until Advance.
  StatusOr<Decoded> Decode(const uint8_t* data, size_t size, const std::vector<uint32_t>* twin = nullptr) const;
  // Moves on to the next refinement with what Decode returned.
  void Advance(Decoded decoded);

  uint32_t vertices() const { return static_cast<uint32_t>(event_.size()); }
  // The context of v in the refinement being coded, given the bits of the
  // vertices below v (exposed for tests).
  int Context(uint32_t v, const std::vector<uint8_t>& bits) const;

 private:
  static constexpr uint32_t kNoLink = UINT32_MAX;
  static constexpr int16_t kBase = -1;
  // Records a refinement's bits: the graph and the ages move on.
  void Record(std::vector<uint8_t> bits);
  // Context() on the bits decided so far (the hot loop's form).
  int ContextOf(uint32_t v, const uint8_t* bits) const {
    const int16_t event = event_[v];
    int degree = 0;
    bool neighbour_splits = false;
    if (event == kBase) {
      for (uint32_t k = base_offsets_[v], end = base_offsets_[v + 1]; k < end; ++k) {
        const uint32_t u = base_adjacent_[k];
        if (event_[u] != kBase) continue;  // split since: the edge is no longer known
        ++degree;
        neighbour_splits |= u < v && bits[u];
      }
    } else if (linked_[v]) {
      degree = 1;
      const uint32_t u = link_[v];
      neighbour_splits = u < v && bits[u];
    }
    if (neighbour_splits) return kContexts - 1;
    const int since = refinement_ - 1 - event;
    // Made by refinement i - 1: its parent (its link, a smaller id) has its bit already.
    const int related = v >= previous_start_ ? bits[link_[v]] : previous_bits_[v];
    return ((since < 4 ? since : 4) * 2 + related) * 4 + (degree < 3 ? degree : 3);
  }

  int refinement_ = 0;  // the refinement being coded
  // The base's adjacency (CSR): neighbours of base vertex v are
  // base_adjacent_[base_offsets_[v] .. base_offsets_[v + 1]).
  std::vector<uint32_t> base_offsets_, base_adjacent_;
  std::vector<int16_t> event_;   // refinement that last split or made the vertex; kBase
  std::vector<uint32_t> link_;   // the other end of that event's edge; kNoLink for a base vertex
  std::vector<uint8_t> linked_;  // 1 while the link holds (neither end has split since): link_[link_[v]] == v
  std::vector<uint8_t> previous_bits_;  // refinement i - 1's bits
  uint32_t previous_start_ = UINT32_MAX;  // first vertex made by refinement i - 1
  Models models_{};
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_BIT_CONTEXTS_H_
