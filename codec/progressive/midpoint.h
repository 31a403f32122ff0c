// The reversible midpoint/difference transform of the geometric data of a
// split: the coarser vertex holds floor((u + v) / 2), the split sends
// d = u - v, and FromMidpoint gives u back exactly (docs/spec/progressive-format.md,
// "Geometry"). Header-only, pure, overflow-free for any int32 inputs.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_MIDPOINT_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_MIDPOINT_H_

#include <array>
#include <cstdint>

namespace meshstream {

// floor((a + b) / 2) and its exact inverse given d = a - b (the reversible
// midpoint/difference transform of the geometric data).
inline int32_t Midpoint(int32_t a, int32_t b) {
  const int64_t s = static_cast<int64_t>(a) + b;
  return static_cast<int32_t>(s >= 0 ? s / 2 : -((-s + 1) / 2));
}
inline int32_t FromMidpoint(int32_t m, int32_t d) {
  // a + b = 2m + (d mod 2), a - b = d.
  const int64_t twice_a = 2 * static_cast<int64_t>(m) + (d & 1) + d;
  return static_cast<int32_t>(twice_a / 2);
}
// Both values back from the coarse value m and d = u - v: {u, v} (v wraps
// to int32 as the decoder's state stores it).
inline std::array<int32_t, 2> FromMidpointPair(int32_t m, int32_t d) {
  const int32_t u = FromMidpoint(m, d);
  return {u, static_cast<int32_t>(static_cast<int64_t>(u) - d)};
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_MIDPOINT_H_
