#include "codec/progressive/split_bit_contexts.h"

#include <algorithm>
#include <string>

#include "codec/progressive/split_bits.h"

namespace meshstream {

Status SplitBitContexts::Reset(uint32_t base_vertices, const std::vector<uint32_t>& base_indices) {
  if (base_indices.size() % 3 != 0) return InvalidArgument("split bit contexts: the base's index count is not a multiple of 3");
  for (size_t k = 0; k < base_indices.size(); ++k) {
    if (base_indices[k] >= base_vertices) {
      return InvalidArgument("split bit contexts: base triangle " + std::to_string(k / 3) + " names vertex " +
                             std::to_string(base_indices[k]) + " of " + std::to_string(base_vertices));
    }
  }
  // Both directions of every edge, counted, placed, then sorted and made unique per vertex.
  std::vector<uint32_t> count(size_t{base_vertices} + 1, 0);
  for (size_t f = 0; f < base_indices.size(); f += 3)
    for (int c = 0; c < 3; ++c) count[base_indices[f + c]] += 2;
  base_offsets_.assign(size_t{base_vertices} + 1, 0);
  for (uint32_t v = 0; v < base_vertices; ++v) base_offsets_[v + 1] = base_offsets_[v] + count[v];
  base_adjacent_.assign(base_offsets_[base_vertices], 0);
  std::vector<uint32_t> at(base_offsets_.begin(), base_offsets_.end() - 1);
  for (size_t f = 0; f < base_indices.size(); f += 3) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = base_indices[f + c];
      base_adjacent_[at[v]++] = base_indices[f + (c + 1) % 3];
      base_adjacent_[at[v]++] = base_indices[f + (c + 2) % 3];
    }
  }
  uint32_t out = 0;
  for (uint32_t v = 0; v < base_vertices; ++v) {
    const uint32_t begin = base_offsets_[v], end = base_offsets_[v + 1];
    std::sort(base_adjacent_.begin() + begin, base_adjacent_.begin() + end);
    base_offsets_[v] = out;
    for (uint32_t k = begin; k < end; ++k) {
      const uint32_t u = base_adjacent_[k];
      if (u == v || (k > begin && u == base_adjacent_[k - 1])) continue;  // a degenerate triangle's, or a repeat
      base_adjacent_[out++] = u;
    }
  }
  base_offsets_[base_vertices] = out;
  base_adjacent_.resize(out);
  base_adjacent_.shrink_to_fit();
  event_.assign(base_vertices, kBase);
  link_.assign(base_vertices, kNoLink);
  linked_.assign(base_vertices, 0);
  previous_bits_.assign(base_vertices, 0);  // refinement 0: "its bit in refinement -1" is 0
  previous_start_ = UINT32_MAX;
  refinement_ = 0;
  models_.fill(BitModel{});
  return Status::Ok();
}

int SplitBitContexts::Context(uint32_t v, const std::vector<uint8_t>& bits) const { return ContextOf(v, bits.data()); }

void SplitBitContexts::Record(std::vector<uint8_t> bits) {
  const uint32_t before = vertices();
  const size_t made = before + static_cast<size_t>(std::count(bits.begin(), bits.end(), uint8_t{1}));
  event_.resize(made);
  link_.resize(made);
  linked_.resize(made);
  const int16_t now = static_cast<int16_t>(refinement_);
  for (uint32_t w = 0, n = before; w < before; ++w) {
    if (!bits[w]) continue;
    if (linked_[w]) linked_[link_[w]] = 0;  // its old partner's edge is no longer known
    event_[w] = now;
    link_[w] = n;
    linked_[w] = 1;
    event_[n] = now;
    link_[n] = w;
    linked_[n] = 1;
    ++n;
  }
  previous_bits_ = std::move(bits);
  previous_start_ = before;
  ++refinement_;
}

std::vector<uint8_t> SplitBitContexts::Encode(const std::vector<uint8_t>& bits, const std::vector<uint32_t>* twin) {
  RangeEncoder enc;
  for (uint32_t v = 0; v < bits.size(); ++v) {
    if (TwinWithSmallerId(v, twin) != kNoTwin) continue;
    enc.EncodeBit(models_[ContextOf(v, bits.data())], bits[v]);
  }
  Record(bits);
  return enc.Finish();
}

StatusOr<SplitBitContexts::Decoded> SplitBitContexts::Decode(const uint8_t* data, size_t size,
                                                              const std::vector<uint32_t>* twin) const {
  RangeDecoder dec(data, size);
  const uint32_t n = vertices();
  Decoded out;
  out.models = models_;
  std::vector<uint8_t>& bits = out.bits;
  bits.assign(n, 0);
  for (uint32_t v = 0; v < n; ++v) {
    const uint32_t from = TwinWithSmallerId(v, twin);
    bits[v] = from != kNoTwin ? bits[from] : static_cast<uint8_t>(dec.DecodeBit(out.models[ContextOf(v, bits.data())]));
  }
  if (dec.overran()) return InvalidInput("split bits are truncated");
  if (!dec.ended_exactly()) {
    return InvalidInput("split bits: the block's " + std::to_string(size) + " bytes do not end with its " +
                        std::to_string(n) + " bits");
  }
  return out;
}

void SplitBitContexts::Advance(Decoded decoded) {
  models_ = decoded.models;
  Record(std::move(decoded.bits));
}

}  // namespace meshstream
