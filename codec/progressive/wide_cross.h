// The exact 128-bit pieces the version 2 predictors share: the absolute
// value of a 128-bit integer and the sum of cross products (p - o) x (q - o)
// of grid positions (a fan normal, a vertex normal). Header-only, pure;
// exact for any int32 positions.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_WIDE_CROSS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_WIDE_CROSS_H_

#include <array>
#include <cstdint>

#include "codec/core/vec.h"

namespace meshstream {

inline __int128 WideAbs(__int128 v) { return v < 0 ? -v : v; }

// n += (p - o) x (q - o), exactly.
inline void AddCross(std::array<__int128, 3>& n, const Vec3i& o, const Vec3i& p, const Vec3i& q) {
  const int64_t a0 = int64_t{p[0]} - o[0], a1 = int64_t{p[1]} - o[1], a2 = int64_t{p[2]} - o[2];
  const int64_t b0 = int64_t{q[0]} - o[0], b1 = int64_t{q[1]} - o[1], b2 = int64_t{q[2]} - o[2];
  n[0] += __int128{a1} * b2 - __int128{a2} * b1;
  n[1] += __int128{a2} * b0 - __int128{a0} * b2;
  n[2] += __int128{a0} * b1 - __int128{a1} * b0;
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_WIDE_CROSS_H_
