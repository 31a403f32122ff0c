#include "codec/progressive/normal_prediction.h"

#include <algorithm>

#include "codec/progressive/wide_cross.h"

namespace meshstream {

WideVec3 VertexNormal(const RefinementState& state, uint32_t v) {
  WideVec3 n = {0, 0, 0};
  const std::vector<Face>& faces = state.connectivity.faces();
  for (uint32_t f : state.connectivity.faces_of(v)) {
    AddCross(n, state.positions[faces[f][0]], state.positions[faces[f][1]], state.positions[faces[f][2]]);
  }
  return n;
}

std::array<int32_t, 2> OctahedralCode(const WideVec3& normal, int bits) {
  const std::array<int64_t, 3> v = ScaleDown(normal, 40);
  const __int128 m = (__int128{1} << bits) - 1;
  __int128 l1 = WideAbs(v[0]) + WideAbs(v[1]) + WideAbs(v[2]);
  __int128 s = v[0], t = v[1];
  if (l1 == 0) {
    s = 0;
    t = 0;
    l1 = 1;
  } else if (v[2] < 0) {
    s = (l1 - WideAbs(v[1])) * (v[0] >= 0 ? 1 : -1);
    t = (l1 - WideAbs(v[0])) * (v[1] >= 0 ? 1 : -1);
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

void AddPredictedNormals(int bits, size_t j, uint32_t w, uint32_t n, RefinementState& state, Refinement* decoded) {
  if (bits == 0) return;
  const std::array<int32_t, 2> p = PredictNormalDelta(state, w, n, bits);
  state.AddPredictedDeltas(j, w, n, 0, p.data(), 2, decoded);
}

}  // namespace meshstream
