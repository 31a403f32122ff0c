// Static symbol models for the range coder: frequencies that sum to 2^12,
// built from a histogram by the encoder and sent once (per refinement) on
// the reliable channel, so that every datagram decodes with them on its own.
// A model travels as its alphabet size and one 4-bit code per symbol: 0 for
// an absent symbol, else c in [1, 15] for a weight of about 1.6^c relative
// to the others; both sides rebuild the same frequencies from the codes
// (about n/2 bytes instead of a table of 12-bit counts).
// Also the coding of signed integers as a symbol plus raw bits (below).
//
// Contract: Parse is safe on hostile bytes (alphabet size and frequencies
// checked; the table must sum to exactly 2^12). Decode never returns a symbol
// outside the alphabet.
#ifndef MESHSTREAM_CODEC_ENTROPY_SYMBOL_MODEL_H_
#define MESHSTREAM_CODEC_ENTROPY_SYMBOL_MODEL_H_

#include <cstdint>
#include <vector>

#include "codec/core/byte_io.h"
#include "codec/entropy/range_coder.h"
#include "codec/core/status.h"

namespace meshstream {

constexpr int kModelBits = 12;
constexpr uint32_t kMaxAlphabet = 96;

class StaticModel {
 public:
  // From symbol counts; every symbol with a nonzero count gets a nonzero
  // frequency. An all-zero histogram gives a model of symbol 0 only.
  static StaticModel FromCounts(const std::vector<uint64_t>& counts);
  // Refuses an alphabet size of 0 or above `max_alphabet` (the slot's: 16 for
  // wings, kSignedSymbols for signed values; docs/spec/progressive-format.md,
  // section 5), a stray high nibble, codes that are all 0, and codes whose
  // largest symbol would be left with a frequency below 1.
  static StatusOr<StaticModel> Parse(ByteReader& reader, uint32_t max_alphabet = kMaxAlphabet);
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
  // The symbol's frequency out of 2^kModelBits (0 when absent).
  uint32_t Frequency(uint32_t symbol) const { return symbol < freq_.size() ? freq_[symbol] : 0; }

 private:
  void Build();
  // False when the codes leave the largest symbol no frequency (only hostile
  // codes can: the encoder's never do).
  bool FromCodes();
  std::vector<uint8_t> codes_;
  std::vector<uint32_t> freq_, cum_;
  std::vector<uint8_t> lookup_;
};

inline uint32_t ZigZag(int32_t v) { return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31); }
inline int32_t UnZigZag(uint32_t z) { return static_cast<int32_t>((z >> 1) ^ (~(z & 1) + 1)); }

// Signed values as symbols: zigzag values below 16 are their own symbol;
// larger ones are coded by bit length L (5..32) and the bit below the
// leading one (symbol 16 + 2 (L - 5) + that bit), followed by L - 2 raw bits.
constexpr uint32_t kDirectSymbols = 16;
constexpr uint32_t kSignedSymbols = kDirectSymbols + 2 * 28;  // 72
inline uint32_t SignedSymbol(int32_t v) {
  const uint32_t z = ZigZag(v);
  if (z < kDirectSymbols) return z;
  const uint32_t length = 32 - static_cast<uint32_t>(__builtin_clz(z));
  return kDirectSymbols + 2 * (length - 5) + ((z >> (length - 2)) & 1);
}

// The raw bits after a signed value's symbol (symbol >= kDirectSymbols).
void EncodeSignedRest(RangeEncoder& enc, uint32_t symbol, int32_t v);
int32_t DecodeSignedRest(RangeDecoder& dec, uint32_t symbol);
inline uint32_t SignedRestBits(uint32_t symbol) {
  return symbol < kDirectSymbols ? 0 : (symbol - kDirectSymbols) / 2 + 3;
}

// A signed value with any model that has Encode(enc, symbol) and
// Decode(dec) (StaticModel, AdaptiveModel).
template <class Model>
void EncodeSigned(RangeEncoder& enc, Model& model, int32_t v) {
  const uint32_t symbol = SignedSymbol(v);
  model.Encode(enc, symbol);
  if (symbol >= kDirectSymbols) EncodeSignedRest(enc, symbol, v);
}
template <class Model>
int32_t DecodeSigned(RangeDecoder& dec, Model& model) {
  const uint32_t symbol = model.Decode(dec);
  return symbol < kDirectSymbols ? UnZigZag(symbol) : DecodeSignedRest(dec, symbol);
}
double SignedCost(const StaticModel& model, int32_t v);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_ENTROPY_SYMBOL_MODEL_H_
