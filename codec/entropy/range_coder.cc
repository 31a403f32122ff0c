#include "codec/entropy/range_coder.h"

namespace meshstream {

namespace {
constexpr uint32_t kTop = 1u << 24;
}  // namespace

void RangeEncoder::ShiftLow() {
  if (static_cast<uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
    const uint8_t carry = static_cast<uint8_t>(low_ >> 32);
    uint8_t temp = cache_;
    do {
      out_.push_back(static_cast<uint8_t>(temp + carry));
      temp = 0xFF;
    } while (--cache_size_ != 0);
    cache_ = static_cast<uint8_t>(low_ >> 24);
  }
  ++cache_size_;
  low_ = (low_ & 0x00FFFFFFu) << 8;
}

void RangeEncoder::EncodeBit(BitModel& model, int bit) {
  const uint32_t bound = (range_ >> kProbabilityBits) * model.p0;
  if (bit == 0) {
    range_ = bound;
  } else {
    low_ += bound;
    range_ -= bound;
  }
  model.Update(bit);
  while (range_ < kTop) {
    range_ <<= 8;
    ShiftLow();
  }
}

void RangeEncoder::Encode(uint32_t cum, uint32_t freq, int total_bits) {
  const uint32_t r = range_ >> total_bits;
  low_ += static_cast<uint64_t>(r) * cum;
  range_ = r * freq;
  while (range_ < kTop) {
    range_ <<= 8;
    ShiftLow();
  }
}

void RangeEncoder::EncodeFrequency(uint32_t cum, uint32_t freq, uint32_t total) {
  const uint32_t r = range_ / total;
  low_ += static_cast<uint64_t>(r) * cum;
  range_ = r * freq;
  while (range_ < kTop) {
    range_ <<= 8;
    ShiftLow();
  }
}

void RangeEncoder::EncodeRaw(uint32_t value, int bits) {
  Encode(value & ((1u << bits) - 1u), 1, bits);
}

void RangeEncoder::EncodeUniform(uint32_t value, uint32_t n) {
  if (n <= 1) return;
  const uint32_t r = range_ / n;
  low_ += static_cast<uint64_t>(r) * value;
  range_ = r;
  while (range_ < kTop) {
    range_ <<= 8;
    ShiftLow();
  }
}

std::vector<uint8_t> RangeEncoder::Finish() {
  for (int i = 0; i < 5; ++i) ShiftLow();
  // The first byte is always the initial zero cache: drop it.
  out_.erase(out_.begin());
  return std::move(out_);
}

RangeDecoder::RangeDecoder(const uint8_t* data, size_t size) : data_(data), size_(size) {
  for (int i = 0; i < 4; ++i) code_ = (code_ << 8) | NextByte();
}

uint8_t RangeDecoder::NextByte() {
  if (pos_ < size_) return data_[pos_++];
  // Four bytes of look-ahead past the last symbol are normal at the very end;
  // anything beyond that means the stream was too short.
  if (++pos_ > size_ + 4) overran_ = true;
  return 0;
}

void RangeDecoder::Normalize() {
  while (range_ < kTop) {
    range_ <<= 8;
    code_ = (code_ << 8) | NextByte();
  }
}

int RangeDecoder::DecodeBit(BitModel& model) {
  const uint32_t bound = (range_ >> kProbabilityBits) * model.p0;
  int bit;
  if (code_ < bound) {
    range_ = bound;
    bit = 0;
  } else {
    code_ -= bound;
    range_ -= bound;
    bit = 1;
  }
  model.Update(bit);
  Normalize();
  return bit;
}

uint32_t RangeDecoder::Peek(int total_bits) {
  pending_range_ = range_ >> total_bits;
  const uint32_t v = code_ / pending_range_;
  const uint32_t max = (1u << total_bits) - 1u;
  return v > max ? max : v;
}

uint32_t RangeDecoder::PeekFrequency(uint32_t total) {
  pending_range_ = range_ / total;
  const uint32_t v = code_ / pending_range_;
  return v >= total ? total - 1 : v;
}

void RangeDecoder::Consume(uint32_t cum, uint32_t freq) {
  code_ -= pending_range_ * cum;
  range_ = pending_range_ * freq;
  Normalize();
}

uint32_t RangeDecoder::DecodeRaw(int bits) {
  const uint32_t v = Peek(bits);
  Consume(v, 1);
  return v;
}

uint32_t RangeDecoder::DecodeUniform(uint32_t n) {
  if (n <= 1) return 0;
  const uint32_t r = range_ / n;
  uint32_t v = code_ / r;
  if (v >= n) v = n - 1;
  code_ -= r * v;
  range_ = r;
  Normalize();
  return v;
}

}  // namespace meshstream
