#include "codec/recovery/degenerate_faces.h"

namespace meshstream {

bool Collinear(const Vec3i& a, const Vec3i& b, const Vec3i& c) {
  const int64_t e[3] = {int64_t(b[0]) - a[0], int64_t(b[1]) - a[1], int64_t(b[2]) - a[2]};
  const int64_t f[3] = {int64_t(c[0]) - a[0], int64_t(c[1]) - a[1], int64_t(c[2]) - a[2]};
  return e[1] * f[2] - e[2] * f[1] == 0 && e[2] * f[0] - e[0] * f[2] == 0 && e[0] * f[1] - e[1] * f[0] == 0;
}

int DegenerateFaces(const RefinementState& state, uint32_t v) {
  int count = 0;
  for (uint32_t f : state.connectivity.faces_of(v)) {
    const Face& t = state.connectivity.faces()[f];
    count += Collinear(state.positions[t[0]], state.positions[t[1]], state.positions[t[2]]) ? 1 : 0;
  }
  return count;
}

bool AvoidDegenerateFaces(RefinementState* state, uint32_t w, uint32_t n) {
  if (DegenerateFaces(*state, w) == 0 && DegenerateFaces(*state, n) == 0) return false;
  // The new vertex, then w, moves by the smallest grid step that leaves the
  // fewest collinear triangles around the two (a prediction, whatever
  // arrived). Moving one vertex changes only its own triangles.
  std::vector<Vec3i>& positions = state->positions;
  for (uint32_t moving : {n, w}) {
    int best = DegenerateFaces(*state, moving);
    Vec3i best_at = positions[moving];
    const Vec3i at = positions[moving];
    for (int32_t r = 1; r <= 3 && best > 0; ++r) {
      for (int k = 0; k < 27 && best > 0; ++k) {
        if (k == 13) continue;
        positions[moving] = {at[0] + r * (k % 3 - 1), at[1] + r * (k / 3 % 3 - 1), at[2] + r * (k / 9 - 1)};
        const int count = DegenerateFaces(*state, moving);
        if (count < best) {
          best = count;
          best_at = positions[moving];
        }
      }
    }
    positions[moving] = best_at;
  }
  return true;
}

}  // namespace meshstream
