// Small fixed-size vectors and the few operations on them that more than one
// algorithm needs. Header-only, pure, no allocation.
#ifndef MESHSTREAM_CODEC_CORE_VEC_H_
#define MESHSTREAM_CODEC_CORE_VEC_H_

#include <array>
#include <cmath>
#include <cstdint>

namespace meshstream {

using Vec2f = std::array<float, 2>;
using Vec3f = std::array<float, 3>;
using Vec4f = std::array<float, 4>;
using Vec2d = std::array<double, 2>;
using Vec3d = std::array<double, 3>;
using Vec3i = std::array<int32_t, 3>;

inline Vec3d ToDouble(const Vec3i& p) { return {double(p[0]), double(p[1]), double(p[2])}; }
inline Vec3d ToDouble(const Vec3f& p) { return {p[0], p[1], p[2]}; }
inline Vec3d Sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3d Add(const Vec3d& a, const Vec3d& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3d Scale(const Vec3d& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double Dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double Norm(const Vec3d& a) { return std::sqrt(Dot(a, a)); }
inline Vec3d Cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

inline Vec2d Sub(const Vec2d& a, const Vec2d& b) { return {a[0] - b[0], a[1] - b[1]}; }
inline double Cross(const Vec2d& a, const Vec2d& b) { return a[0] * b[1] - a[1] * b[0]; }
// Plane coordinates come from 32-bit grid values, so the squares cannot
// overflow a double: plain sqrt (std::hypot's overflow care cost 13 % of a
// decode at 12 % loss, docs/results/decode-profile.md).
inline double Distance(const Vec2d& a, const Vec2d& b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1];
  return std::sqrt(dx * dx + dy * dy);
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_VEC_H_
