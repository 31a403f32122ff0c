// FNV-1a, 64 bits: a fast checksum for telling byte sequences apart (equal
// decodes in tests and benchmarks, duplicate datagrams), not a defence
// against anyone choosing the bytes.
//
// Contract: pure, the same value on every platform for the same bytes.
#ifndef MESHSTREAM_CODEC_CORE_FNV_H_
#define MESHSTREAM_CODEC_CORE_FNV_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshstream {

struct Fnv1a {
  uint64_t value = 14695981039346656037ull;

  void Add(const void* data, size_t size) {
    const auto* b = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < size; ++i) value = (value ^ b[i]) * 1099511628211ull;
  }
  // The element count (8 bytes), then the elements' bytes.
  template <class T>
  void AddVector(const std::vector<T>& v) {
    const uint64_t n = v.size();
    Add(&n, sizeof n);
    if (!v.empty()) Add(v.data(), v.size() * sizeof(T));
  }
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_FNV_H_
