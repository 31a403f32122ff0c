// Little-endian byte writing and bounds-checked reading for meshstream's
// bitstreams (docs/spec/progressive-format.md).
//
// Contract: ByteReader is safe on untrusted input: it never reads past its span; every getter returns an
// error naming `what` when the bytes are missing or a varint is malformed
// (more than 10 bytes, or above the caller's limit).
#ifndef MESHSTREAM_CODEC_CORE_BYTE_IO_H_
#define MESHSTREAM_CODEC_CORE_BYTE_IO_H_

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

class ByteWriter {
 public:
  void U8(uint8_t v) { out_.push_back(v); }
  void U16(uint16_t v) { for (int i = 0; i < 2; ++i) out_.push_back(static_cast<uint8_t>(v >> (8 * i))); }
  void U32(uint32_t v) { for (int i = 0; i < 4; ++i) out_.push_back(static_cast<uint8_t>(v >> (8 * i))); }
  void F32(float f) { uint32_t v; std::memcpy(&v, &f, 4); U32(v); }
  void Varint(uint64_t v) {
    while (v >= 0x80) { out_.push_back(static_cast<uint8_t>(v | 0x80)); v >>= 7; }
    out_.push_back(static_cast<uint8_t>(v));
  }
  void Bytes(const std::vector<uint8_t>& b) { out_.insert(out_.end(), b.begin(), b.end()); }
  // A length-prefixed block.
  void Block(const std::vector<uint8_t>& b) { Varint(b.size()); Bytes(b); }
  size_t size() const { return out_.size(); }
  std::vector<uint8_t>& bytes() { return out_; }

 private:
  std::vector<uint8_t> out_;
};

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  size_t remaining() const { return size_ - pos_; }
  size_t position() const { return pos_; }

  StatusOr<uint8_t> U8(const char* what) {
    if (remaining() < 1) return Short(what);
    return data_[pos_++];
  }
  StatusOr<uint16_t> U16(const char* what) {
    if (remaining() < 2) return Short(what);
    const uint16_t v = static_cast<uint16_t>(data_[pos_] | (data_[pos_ + 1] << 8));
    pos_ += 2;
    return v;
  }
  StatusOr<uint32_t> U32(const char* what) {
    if (remaining() < 4) return Short(what);
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | data_[pos_ + i];
    pos_ += 4;
    return v;
  }
  StatusOr<float> F32(const char* what) {
    MS_ASSIGN_OR_RETURN(uint32_t v, U32(what));
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }
  // An unsigned LEB128 value no larger than `max`.
  StatusOr<uint64_t> Varint(const char* what, uint64_t max) {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (remaining() < 1) return Short(what);
      const uint8_t b = data_[pos_++];
      // The tenth byte holds bit 63 only: more would wrap past 2^64.
      if (shift == 63 && (b & 0x7E)) return InvalidInput(std::string(what) + ": malformed varint (above 2^64)");
      v |= static_cast<uint64_t>(b & 0x7F) << shift;
      if (!(b & 0x80)) {
        if (v > max) return InvalidInput(std::string(what) + " = " + std::to_string(v) + " exceeds " + std::to_string(max));
        return v;
      }
    }
    return InvalidInput(std::string(what) + ": malformed varint");
  }
  // A length-prefixed block: returns a pointer into the span.
  StatusOr<const uint8_t*> Block(const char* what, size_t* length) {
    MS_ASSIGN_OR_RETURN(uint64_t n, Varint(what, remaining()));
    // The limit above still counted the varint's own bytes.
    if (n > remaining()) return Short(what);
    *length = static_cast<size_t>(n);
    const uint8_t* p = data_ + pos_;
    pos_ += *length;
    return p;
  }
  StatusOr<const uint8_t*> Take(size_t n, const char* what) {
    if (remaining() < n) return Short(what);
    const uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }

 private:
  Status Short(const char* what) const {
    return InvalidInput(std::string(what) + ": truncated at byte " + std::to_string(pos_));
  }
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_BYTE_IO_H_
