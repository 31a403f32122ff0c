#include "codec/progressive/local_frame.h"

#include "codec/progressive/wide_cross.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

namespace {

// round(a / b) for b > 0, halves away from zero.
int64_t RoundDiv(int64_t a, int64_t b) {
  const int64_t q = ((a < 0 ? -a : a) + b / 2) / b;
  return a < 0 ? -q : q;
}

int32_t Clamp32(int64_t v) { return static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX)); }

}  // namespace

WideVec3 FanNormal(const Vec3i& w, const Vec3i* ring, size_t d) {
  WideVec3 n = {0, 0, 0};
  if (d == 0) return n;
  for (size_t k = 0; k + 1 < d; ++k) AddCross(n, w, ring[k], ring[k + 1]);
  AddCross(n, w, ring[d - 1], ring[0]);
  return n;
}

std::array<int64_t, 3> ScaleDown(const WideVec3& n, int bits) {
  const __int128 m = std::max({WideAbs(n[0]), WideAbs(n[1]), WideAbs(n[2])});
  int shift = 0;
  while ((m >> shift) >= (__int128{1} << bits)) ++shift;
  std::array<int64_t, 3> out{};
  for (int c = 0; c < 3; ++c) {
    const int64_t mag = static_cast<int64_t>(WideAbs(n[c]) >> shift);
    out[c] = n[c] < 0 ? -mag : mag;
  }
  return out;
}

std::array<int64_t, 3> ScaledFanNormal(const Vec3i& w, const Vec3i* ring, size_t d, int bits) {
  constexpr int64_t kLimit = int64_t{1} << 28;
  bool narrow = d <= 64;
  for (size_t k = 0; k < d && narrow; ++k) {
    for (int c = 0; c < 3; ++c) {
      const int64_t a = int64_t{ring[k][c]} - w[c];
      narrow = narrow && a < kLimit && a > -kLimit;
    }
  }
  if (!narrow) return ScaleDown(FanNormal(w, ring, d), bits);
  // Each product below 2^56, each component of a cross below 2^57, the sum
  // of at most 64 below 2^63: exact in int64.
  int64_t n[3] = {0, 0, 0};
  for (size_t k = 0; k < d; ++k) {
    const Vec3i& p = ring[k];
    const Vec3i& q = ring[k + 1 < d ? k + 1 : 0];
    const int64_t a0 = int64_t{p[0]} - w[0], a1 = int64_t{p[1]} - w[1], a2 = int64_t{p[2]} - w[2];
    const int64_t b0 = int64_t{q[0]} - w[0], b1 = int64_t{q[1]} - w[1], b2 = int64_t{q[2]} - w[2];
    n[0] += a1 * b2 - a2 * b1;
    n[1] += a2 * b0 - a0 * b2;
    n[2] += a0 * b1 - a1 * b0;
  }
  // ScaleDown's shift: the least s with max |n| >> s below 2^bits.
  uint64_t m = 0;
  for (int64_t c : n) m = std::max<uint64_t>(m, c < 0 ? uint64_t(0) - uint64_t(c) : uint64_t(c));
  const int length = m == 0 ? 0 : 64 - __builtin_clzll(m);
  const int shift = std::max(0, length - bits);
  std::array<int64_t, 3> out{};
  for (int c = 0; c < 3; ++c) {
    const uint64_t mag = (n[c] < 0 ? uint64_t(0) - uint64_t(n[c]) : uint64_t(n[c])) >> shift;
    out[c] = n[c] < 0 ? -static_cast<int64_t>(mag) : static_cast<int64_t>(mag);
  }
  return out;
}

int64_t IntegerSqrt(int64_t v) {
  if (v <= 0) return 0;
  int64_t r = static_cast<int64_t>(std::sqrt(static_cast<double>(v)));
  while (r > 0 && r * r > v) --r;
  while ((r + 1) * (r + 1) <= v) ++r;
  return r;
}

LocalFrame::Rotation LocalFrame::Rotation::Of(int64_t c, int64_t s) {
  Rotation out;
  if (c == 0 && s == 0) return out;
  if (c < 0) {  // turn by pi first, then by the remaining angle within +-pi/2
    out.flip = true;
    c = -c;
    s = -s;
  }
  const int64_t r = std::max<int64_t>(1, IntegerSqrt(c * c + s * s));
  out.p = -RoundDiv(s * (int64_t{1} << kFixedBits), r + c);  // -tan(theta / 2), |.| <= 1
  out.s = RoundDiv(s * (int64_t{1} << kFixedBits), r);       // sin(theta)
  return out;
}

LocalFrame LocalFrame::FromNormal(const WideVec3& normal) { return FromScaledNormal(ScaleDown(normal, 20)); }

LocalFrame LocalFrame::FromScaledNormal(const std::array<int64_t, 3>& n) {
  LocalFrame f;
  // About z: (n_x, n_y) onto the +x axis; then in the (z, x) plane:
  // (n_z, rho) onto the +z axis.
  f.about_z_ = Rotation::Of(n[0], -n[1]);
  const int64_t rho = IntegerSqrt(n[0] * n[0] + n[1] * n[1]);
  f.about_y_ = Rotation::Of(n[2], -rho);
  return f;
}

Vec3i LocalFrame::Forward(const Vec3i& v) const {
  int64_t x = v[0], y = v[1], z = v[2];
  about_z_.Forward(x, y);
  about_y_.Forward(z, x);
  return {Clamp32(x), Clamp32(y), Clamp32(z)};
}

void LocalFrame::Tangents(const Vec3i& origin, const Vec3i* points, size_t count, std::array<int64_t, 2>* out) const {
  for (size_t k = 0; k < count; ++k) {
    int64_t x = Clamp32(int64_t{points[k][0]} - origin[0]);
    int64_t y = Clamp32(int64_t{points[k][1]} - origin[1]);
    int64_t z = Clamp32(int64_t{points[k][2]} - origin[2]);
    about_z_.Forward(x, y);
    about_y_.Forward(z, x);
    out[k] = {Clamp32(x), Clamp32(y)};
  }
}

Vec3i LocalFrame::Inverse(const Vec3i& c) const {
  int64_t x = c[0], y = c[1], z = c[2];
  about_y_.Inverse(z, x);
  about_z_.Inverse(x, y);
  return {Clamp32(x), Clamp32(y), Clamp32(z)};
}

}  // namespace meshstream
