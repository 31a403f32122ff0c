// Static symbol models for the range coder: frequencies that sum to 2^12,
// built from a histogram by the encoder and sent once (per refinement) on
// the reliable channel, so that every datagram decodes with them on its own.
// Also the coding of signed integers as (bucket, raw bits): bucket 0 is the
// value 0, bucket k > 0 holds zigzag values in [2^(k-1), 2^k).
//
// Contract: Parse is safe on hostile bytes (alphabet size and frequencies
// checked; the table must sum to exactly 2^12). Decode never returns a symbol
// outside the alphabet.
#ifndef MESHSTREAM_CODEC_SYMBOL_MODEL_H_
#define MESHSTREAM_CODEC_SYMBOL_MODEL_H_

#include <cstdint>
#include <vector>

#include "codec/byte_io.h"
#include "codec/range_coder.h"
#include "codec/status.h"

namespace meshstream {

constexpr int kModelBits = 12;
constexpr uint32_t kMaxAlphabet = 64;
constexpr uint32_t kSignedBuckets = 33;  // bucket 0 .. 32

class StaticModel {
 public:
  // From symbol counts; every symbol with a nonzero count gets a nonzero
  // frequency. An all-zero histogram gives a model of symbol 0 only.
  static StaticModel FromCounts(const std::vector<uint64_t>& counts);
  static StatusOr<StaticModel> Parse(ByteReader& reader);
  void Serialize(ByteWriter& writer) const;

  void Encode(RangeEncoder& enc, uint32_t symbol) const { enc.Encode(cum_[symbol], freq_[symbol], kModelBits); }
  uint32_t Decode(RangeDecoder& dec) const {
    const uint32_t s = lookup_[dec.Peek(kModelBits)];
    dec.Consume(cum_[s], freq_[s]);
    return s;
  }
  // Cost of a symbol in bits (for estimates).
  double Cost(uint32_t symbol) const;
  uint32_t alphabet() const { return static_cast<uint32_t>(freq_.size()); }
  bool Has(uint32_t symbol) const { return symbol < freq_.size() && freq_[symbol] > 0; }

 private:
  void Build();
  std::vector<uint32_t> freq_, cum_;
  std::vector<uint8_t> lookup_;
};

inline uint32_t ZigZag(int32_t v) { return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31); }
inline int32_t UnZigZag(uint32_t z) { return static_cast<int32_t>((z >> 1) ^ (~(z & 1) + 1)); }
inline uint32_t BucketOf(int32_t v) {
  const uint32_t z = ZigZag(v);
  return z == 0 ? 0 : 32 - static_cast<uint32_t>(__builtin_clz(z));
}

void EncodeSigned(RangeEncoder& enc, const StaticModel& model, int32_t v);
int32_t DecodeSigned(RangeDecoder& dec, const StaticModel& model);
double SignedCost(const StaticModel& model, int32_t v);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_SYMBOL_MODEL_H_
