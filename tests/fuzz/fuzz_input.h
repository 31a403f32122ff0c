// The operations a fuzz target reads from its input: one byte at a time (0
// once the input is spent), or the next n bytes (fewer at its end).
#ifndef MESHSTREAM_TESTS_FUZZ_FUZZ_INPUT_H_
#define MESHSTREAM_TESTS_FUZZ_FUZZ_INPUT_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace meshstream::fuzz {

struct Input {
  const uint8_t* data;
  size_t size, pos = 0;
  bool empty() const { return pos >= size; }
  uint8_t Byte() { return pos < size ? data[pos++] : 0; }
  std::vector<uint8_t> Take(size_t n) {
    n = std::min(n, size - std::min(pos, size));
    std::vector<uint8_t> out(data + pos, data + pos + n);
    pos += n;
    return out;
  }
  std::string Bytes(size_t n) {
    const std::vector<uint8_t> v = Take(n);
    return std::string(v.begin(), v.end());
  }
};

}  // namespace meshstream::fuzz

#endif  // MESHSTREAM_TESTS_FUZZ_FUZZ_INPUT_H_
