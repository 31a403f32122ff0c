#include "codec/progressive/texcoord_prediction.h"

#include <algorithm>

#include "codec/progressive/midpoint.h"

namespace meshstream {

namespace {

constexpr int kScaleBits = 15;     // every |q_k| component below 2^15 after the shift
constexpr int64_t kMaxT = 1 << 20;  // |t| components clamped to 2^20 after it
constexpr int64_t kMaxPrediction = int64_t{1} << 30;

int32_t Clamp32(int64_t v) { return static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX)); }

Vec3i Difference(const Vec3i& a, const Vec3i& b) {
  return {Clamp32(int64_t{a[0]} - b[0]), Clamp32(int64_t{a[1]} - b[1]), Clamp32(int64_t{a[2]} - b[2])};
}

// Magnitude shifted right, sign kept.
int64_t ShiftDown(int64_t v, int shift) { return v < 0 ? -((-v) >> shift) : v >> shift; }

}  // namespace

void RingChannelMap::Reset(const Vec3i& m, const Vec3i& d, const Vec3i* ring, size_t degree, const LocalFrame& frame) {
  degree_ = 0;
  if (degree < 3 || degree > kMaxPredictedValence) return;
  // The ring and the split vector in the tangent plane (64-bit: |component| <= 2^31).
  int64_t extent = 0;
  std::array<std::array<int64_t, 2>, kMaxPredictedValence> q;  // [0, degree) set below
  for (size_t k = 0; k < degree; ++k) {
    const Vec3i f = frame.Forward(Difference(ring[k], m));
    q[k] = {f[0], f[1]};
    extent = std::max({extent, q[k][0] < 0 ? -q[k][0] : q[k][0], q[k][1] < 0 ? -q[k][1] : q[k][1]});
  }
  int shift = 0;
  while ((extent >> shift) >= (int64_t{1} << kScaleBits)) ++shift;
  const Vec3i ft = frame.Forward(d);
  const int64_t t0 = std::clamp<int64_t>(ShiftDown(ft[0], shift), -kMaxT, kMaxT);
  const int64_t t1 = std::clamp<int64_t>(ShiftDown(ft[1], shift), -kMaxT, kMaxT);
  // A = sum q q^T: entries below 64 * 2^30 = 2^36.
  int64_t a00 = 0, a01 = 0, a11 = 0;
  for (size_t k = 0; k < degree; ++k) {
    const int64_t x = ShiftDown(q[k][0], shift), y = ShiftDown(q[k][1], shift);
    q_[k] = {static_cast<int32_t>(x), static_cast<int32_t>(y)};
    a00 += x * x;
    a01 += x * y;
    a11 += y * y;
  }
  const __int128 det = __int128{a00} * a11 - __int128{a01} * a01;  // below 2^72
  if (det <= 0) return;
  det_ = det;
  // adj(A) t: below 2 * 2^36 * 2^20 = 2^57.
  h_[0] = a11 * t0 - a01 * t1;
  h_[1] = a00 * t1 - a01 * t0;
  degree_ = degree;
}

int32_t RingChannelMap::Predict(const int32_t* values, size_t stride, const uint32_t* ids, int32_t coarse) const {
  if (degree_ == 0) return 0;
  // B = sum (x_k - c) q_k: below 64 * 2^32 * 2^15 = 2^53.
  int64_t b0 = 0, b1 = 0;
  for (size_t k = 0; k < degree_; ++k) {
    const int64_t delta = int64_t{values[size_t(ids[k]) * stride]} - coarse;
    b0 += delta * q_[k][0];
    b1 += delta * q_[k][1];
  }
  // B adj(A) t: below 2 * 2^53 * 2^57 = 2^111; rounded to nearest, halves away from zero.
  const __int128 num = __int128{b0} * h_[0] + __int128{b1} * h_[1];
  const __int128 twice = (num < 0 ? -num : num) * 2 + det_;
  const __int128 den = 2 * det_;
  // The same quotient in 64 bits when both fit (small rings: most splits).
  constexpr __int128 kFits = __int128{1} << 62;
  const __int128 mag = twice < kFits && den < kFits ? __int128{static_cast<int64_t>(twice) / static_cast<int64_t>(den)}
                                                    : twice / den;
  const __int128 p = std::min<__int128>(mag, kMaxPrediction);
  return static_cast<int32_t>(num < 0 ? -p : p);
}

void PredictChannelDeltas(const RefinementState& state, const uint32_t* ring, const Vec3i* ring_positions,
                          size_t degree, const LocalFrame& frame, uint32_t w, uint32_t n, int first, int count,
                          int32_t* out) {
  const size_t ch = static_cast<size_t>(state.channels);
  int32_t coarse[kMaxMappedChannels];
  for (int c = 0; c < count; ++c) {
    const size_t at = static_cast<size_t>(first + c);
    coarse[c] = Midpoint(state.attributes[w * ch + at], state.attributes[n * ch + at]);
  }
  PredictChannelDeltas(state.attributes.data(), ch, ring, ring_positions, degree, frame, state.positions[w],
                       state.positions[n], coarse, first, count, out);
}

void PredictChannelDeltas(const int32_t* attributes, size_t stride, const uint32_t* ring, const Vec3i* ring_positions,
                          size_t degree, const LocalFrame& frame, const Vec3i& u, const Vec3i& v, const int32_t* coarse,
                          int first, int count, int32_t* out) {
  const Vec3i m = {Midpoint(u[0], v[0]), Midpoint(u[1], v[1]), Midpoint(u[2], v[2])};
  RingChannelMap map;
  map.Reset(m, Difference(u, v), ring_positions, degree, frame);
  for (int c = 0; c < count; ++c) out[c] = map.Predict(attributes + first + c, stride, ring, coarse[c]);
}

}  // namespace meshstream
