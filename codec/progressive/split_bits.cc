#include "codec/progressive/split_bits.h"

#include "codec/entropy/range_coder.h"
#include "codec/progressive/seam_twins.h"

namespace meshstream {

namespace {

constexpr int kContexts = 3 * 2;

// `bits` holds the decisions for ids below v already.
int Context(uint32_t v, const std::vector<uint8_t>& bits, const SplitHistory& h) {
  int age = 2;
  int related = 0;
  if (v >= h.previous_start) {
    age = 0;
    const uint32_t parent = h.previous_splits[v - h.previous_start];
    related = bits[parent];  // parent < previous_start <= v: already decided
  } else {
    if (v >= h.older_start) age = 1;
    related = v < h.previous_bits.size() ? h.previous_bits[v] : 0;
  }
  return age * 2 + related;
}

}  // namespace

SplitHistory SplitHistory::Next(const std::vector<uint8_t>& bits) const {
  SplitHistory next;
  next.previous_splits.clear();
  for (uint32_t v = 0; v < bits.size(); ++v)
    if (bits[v]) next.previous_splits.push_back(v);
  next.vertices = vertices + static_cast<uint32_t>(next.previous_splits.size());
  next.previous_start = vertices;
  next.older_start = previous_start;
  next.previous_bits = bits;
  return next;
}

std::vector<uint8_t> EncodeSplitBits(const std::vector<uint8_t>& bits, const SplitHistory& h,
                                     const std::vector<uint32_t>* twin) {
  RangeEncoder enc;
  BitModel models[kContexts];
  for (uint32_t v = 0; v < bits.size(); ++v) {
    if (TwinWithSmallerId(v, twin) != kNoTwin) continue;
    enc.EncodeBit(models[Context(v, bits, h)], bits[v]);
  }
  return enc.Finish();
}

StatusOr<std::vector<uint8_t>> DecodeSplitBits(const uint8_t* data, size_t size, const SplitHistory& h,
                                               const std::vector<uint32_t>* twin) {
  RangeDecoder dec(data, size);
  BitModel models[kContexts];
  std::vector<uint8_t> bits(h.vertices, 0);
  for (uint32_t v = 0; v < h.vertices; ++v) {
    const uint32_t from = TwinWithSmallerId(v, twin);
    bits[v] = from != kNoTwin ? bits[from] : static_cast<uint8_t>(dec.DecodeBit(models[Context(v, bits, h)]));
  }
  if (dec.overran()) return InvalidInput("split bits are truncated");
  if (!dec.ended_exactly()) {
    return InvalidInput("split bits: the block's " + std::to_string(size) + " bytes do not end with its " +
                        std::to_string(h.vertices) + " bits");
  }
  return bits;
}

}  // namespace meshstream
