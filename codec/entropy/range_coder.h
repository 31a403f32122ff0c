// A byte-oriented range coder (LZMA-style: 32-bit range, 64-bit low with
// carry propagation) for binary adaptive models and static multi-symbol
// models whose frequencies sum to a power of two.
//
// Contract: the encoder appends to a byte vector it owns. The decoder reads a
// caller-owned span and is safe on arbitrary bytes: past the end it reads
// zeros and records that it overran (overran()), so a caller can reject a
// stream that claimed more symbols than its bytes hold. No allocation, no
// exceptions. Thread safety: one coder per thread.
#ifndef MESHSTREAM_CODEC_ENTROPY_RANGE_CODER_H_
#define MESHSTREAM_CODEC_ENTROPY_RANGE_CODER_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshstream {

constexpr int kProbabilityBits = 12;
constexpr uint32_t kProbabilityOne = 1u << kProbabilityBits;

// Adaptive probability that the next bit is 0, in 1/4096.
struct BitModel {
  uint16_t p0 = kProbabilityOne / 2;
  static constexpr int kAdaptShift = 5;
  void Update(int bit) {
    if (bit) p0 -= p0 >> kAdaptShift;
    else p0 += (kProbabilityOne - p0) >> kAdaptShift;
  }
};

class RangeEncoder {
 public:
  void EncodeBit(BitModel& model, int bit);
  // A symbol of a static model: [cum, cum + freq) out of 2^total_bits.
  void Encode(uint32_t cum, uint32_t freq, int total_bits);
  // A symbol of a model whose frequencies sum to `total` (at most 2^16):
  // [cum, cum + freq) out of total (adaptive_model.h).
  void EncodeFrequency(uint32_t cum, uint32_t freq, uint32_t total);
  // `bits` raw bits (at most 16), equiprobable.
  void EncodeRaw(uint32_t value, int bits);
  // A value in [0, n) with n <= 2^16, equiprobable.
  void EncodeUniform(uint32_t value, uint32_t n);
  // Flushes; the coder must not be used afterwards.
  std::vector<uint8_t> Finish();

 private:
  void ShiftLow();
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t cache_size_ = 1;
  std::vector<uint8_t> out_;
};

class RangeDecoder {
 public:
  RangeDecoder(const uint8_t* data, size_t size);
  int DecodeBit(BitModel& model);
  // Returns the scaled value in [0, 2^total_bits) to look a symbol up with;
  // then call Consume with that symbol's cum and freq.
  uint32_t Peek(int total_bits);
  void Consume(uint32_t cum, uint32_t freq);
  // The same for a model whose frequencies sum to `total` (at most 2^16):
  // a value in [0, total), then Consume.
  uint32_t PeekFrequency(uint32_t total);
  uint32_t DecodeRaw(int bits);
  // A value in [0, n); values >= n from hostile bytes are clamped to n - 1.
  uint32_t DecodeUniform(uint32_t n);
  // True when the decoder needed bytes beyond the end of its input.
  bool overran() const { return overran_; }
  // True when the decoder has read exactly its input, no byte more or less.
  // A decoder reads as many bytes as the encoder wrote (4 at the start, one
  // per normalization; the encoder's 5 final shifts minus its dropped first
  // byte make the same count), so this holds at the end of every block the
  // encoder wrote; a block with stray bytes after its data, or cut short,
  // fails it (docs/spec/progressive-format.md, section 7).
  bool ended_exactly() const { return pos_ == size_; }

 private:
  uint8_t NextByte();
  void Normalize();
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint32_t code_ = 0;
  uint32_t pending_range_ = 0;  // range / 2^total_bits between Peek and Consume
  bool overran_ = false;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_ENTROPY_RANGE_CODER_H_
