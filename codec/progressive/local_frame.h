// The local frame of a split (format version 2, docs/spec/progressive-format.md
// section 4.1): an exactly invertible integer rotation that takes the fan
// normal of w's ring to the z axis, so that a residual's two tangential
// components and its normal component are coded with their own models.
//
// The rotation is two plane rotations (about z, then in the z-x plane), each
// done by three lifting steps (shears) with 16-bit fixed-point coefficients
// computed from the normal in integers; a lifting step adds a rounded
// multiple of one coordinate to the other, so the inverse subtracts the same
// amounts in reverse order and every integer vector comes back exactly,
// whatever the coefficients.
//
// Contract: pure integer arithmetic (the same result on every platform);
// Forward and Inverse are exact inverses for residuals of magnitude below
// 2^28 (the encoder's, for grids of at most 24 bits); larger or hostile
// values are clamped to int32 and do not round-trip. Thread safety: none
// needed.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_LOCAL_FRAME_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_LOCAL_FRAME_H_

#include <array>
#include <cstddef>
#include <cstdint>

#include "codec/core/vec.h"

namespace meshstream {

// The fan normal of w's ring, sum over k of (ring[k] - w) x (ring[k+1] - w),
// exact (128-bit).
using WideVec3 = std::array<__int128, 3>;
WideVec3 FanNormal(const Vec3i& w, const Vec3i* ring, size_t degree);

// `n` scaled down by a power of two so that every component's magnitude is
// below 2^bits (rounding toward zero), as int64.
std::array<int64_t, 3> ScaleDown(const WideVec3& n, int bits);

// ScaleDown(FanNormal(w, ring, degree), bits), the same integers, in 64-bit
// arithmetic where that is exact (every coordinate of ring[k] - w below
// 2^28 and degree at most 64: always within the frame's qp <= 24), else
// through the 128-bit path (issue 42: the frame without 128-bit arithmetic
// on the decoder's hot path, the same bits on every platform).
std::array<int64_t, 3> ScaledFanNormal(const Vec3i& w, const Vec3i* ring, size_t degree, int bits);

// floor(sqrt(v)) for v >= 0, exact.
int64_t IntegerSqrt(int64_t v);

class LocalFrame {
 public:
  // The frame of a normal (any vector; zero gives the identity).
  static LocalFrame FromNormal(const WideVec3& normal);
  // The same from a normal already scaled below 2^20 (ScaleDown(normal, 20)).
  static LocalFrame FromScaledNormal(const std::array<int64_t, 3>& n);
  // Residual (x, y, z) -> (t1, t2, n).
  Vec3i Forward(const Vec3i& v) const;
  // (t1, t2, n) -> residual.
  Vec3i Inverse(const Vec3i& c) const;
  // out[k] = the first two components of Forward(points[k] - origin), the
  // difference clamped to int32 per axis, for k < count (a ring in the
  // tangent plane, wing_rank.h).
  void Tangents(const Vec3i& origin, const Vec3i* points, size_t count, std::array<int64_t, 2>* out) const;

 private:
  // A rotation of the plane by three shears; `flip` first turns by pi.
  struct Rotation {
    int64_t p = 0, s = 0;  // -tan(theta/2) and sin(theta), times 2^16
    bool flip = false;
    static Rotation Of(int64_t cos_num, int64_t sin_num);
    void Forward(int64_t& x, int64_t& y) const {
      if (flip) {
        x = -x;
        y = -y;
      }
      x += Rounded(p * y);
      y += Rounded(s * x);
      x += Rounded(p * y);
    }
    void Inverse(int64_t& x, int64_t& y) const {
      x -= Rounded(p * y);
      y -= Rounded(s * x);
      x -= Rounded(p * y);
      if (flip) {
        x = -x;
        y = -y;
      }
    }
  };
  static constexpr int kFixedBits = 16;
  // floor((v + 2^15) / 2^16): v times a 16-bit fixed-point coefficient,
  // rounded. (>> of a negative value is floor division by the power of
  // two, C++20: no branch on the sign, which is random from one vertex to
  // the next.) |v| < 2^50 for int32 inputs (|p|, |s| <= 2^16).
  static int64_t Rounded(int64_t v) { return (v + (int64_t{1} << (kFixedBits - 1))) >> kFixedBits; }
  Rotation about_z_, about_y_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_LOCAL_FRAME_H_
