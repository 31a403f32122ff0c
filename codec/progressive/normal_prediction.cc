#include "codec/progressive/normal_prediction.h"

#include <algorithm>

namespace meshstream {

namespace {

__int128 Abs(__int128 v) { return v < 0 ? -v : v; }

}  // namespace

WideVec3 VertexNormal(const RefinementState& state, uint32_t v) {
  WideVec3 n = {0, 0, 0};
  const std::vector<Face>& faces = state.connectivity.faces();
  for (uint32_t f : state.connectivity.faces_of(v)) {
    const Vec3i& p0 = state.positions[faces[f][0]];
    const Vec3i& p1 = state.positions[faces[f][1]];
    const Vec3i& p2 = state.positions[faces[f][2]];
    const int64_t a0 = int64_t{p1[0]} - p0[0], a1 = int64_t{p1[1]} - p0[1], a2 = int64_t{p1[2]} - p0[2];
    const int64_t b0 = int64_t{p2[0]} - p0[0], b1 = int64_t{p2[1]} - p0[1], b2 = int64_t{p2[2]} - p0[2];
    n[0] += __int128{a1} * b2 - __int128{a2} * b1;
    n[1] += __int128{a2} * b0 - __int128{a0} * b2;
    n[2] += __int128{a0} * b1 - __int128{a1} * b0;
  }
  return n;
}

std::array<int32_t, 2> OctahedralCode(const WideVec3& normal, int bits) {
  const std::array<int64_t, 3> v = ScaleDown(normal, 40);
  const __int128 m = (__int128{1} << bits) - 1;
  __int128 l1 = Abs(v[0]) + Abs(v[1]) + Abs(v[2]);
  __int128 s = v[0], t = v[1];
  if (l1 == 0) {
    s = 0;
    t = 0;
    l1 = 1;
  } else if (v[2] < 0) {
    s = (l1 - Abs(v[1])) * (v[0] >= 0 ? 1 : -1);
    t = (l1 - Abs(v[0])) * (v[1] >= 0 ? 1 : -1);
  }
  // q = round((x / l1 + 1) / 2 * M), the numerator never negative.
  auto code = [&](__int128 x) {
    const __int128 num = (x + l1) * m, den = 2 * l1;
    return std::clamp<__int128>((2 * num + den) / (2 * den), 0, m);
  };
  __int128 qs = code(s), qt = code(t);
  if ((qt == 0 || qt == m) && qs < m - qs) qs = m - qs;
  if ((qs == 0 || qs == m) && qt < m - qt) qt = m - qt;
  return {static_cast<int32_t>(qs), static_cast<int32_t>(qt)};
}

std::array<int32_t, 2> PredictNormalDelta(const RefinementState& state, uint32_t w, uint32_t n, int bits) {
  const std::array<int32_t, 2> a = OctahedralCode(VertexNormal(state, w), bits);
  const std::array<int32_t, 2> b = OctahedralCode(VertexNormal(state, n), bits);
  return {a[0] - b[0], a[1] - b[1]};
}

}  // namespace meshstream
