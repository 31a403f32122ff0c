#include "codec/metrics/grid_equality.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "codec/mesh/quantization.h"

namespace meshstream {

namespace {

using Corner = std::array<int64_t, 3>;
using OrientedTriangle = std::array<Corner, 3>;

// Integer grid positions of the vertices the faces use (others stay 0).
StatusOr<std::vector<Corner>> QuantizeReferenced(const Primitive& p, const QuantizationGrid& grid,
                                                 const char* side) {
  std::vector<Corner> out(p.positions.size(), Corner{0, 0, 0});
  std::vector<char> done(p.positions.size(), 0);
  const double step = grid.step();
  for (uint32_t v : p.indices) {
    if (done[v]) continue;
    done[v] = 1;
    for (int c = 0; c < 3; ++c) {
      const double steps = (static_cast<double>(p.positions[v][c]) - grid.origin[c]) / step;
      if (!(std::fabs(steps) < 4503599627370496.0)) {  // 2^52
        return InvalidInput(std::string(side) + ": position " + std::to_string(v) +
                            " is too far from the grid to quantize");
      }
      out[v][c] = grid.Quantize(p.positions[v][c], c);
    }
  }
  return out;
}

// The rotation of the face that starts at its smallest corner (ties broken by
// the following corners), so rotations compare equal and reversals do not.
std::vector<OrientedTriangle> CanonicalTriangles(const Primitive& p,
                                                 const std::vector<Corner>& q) {
  std::vector<OrientedTriangle> out(p.face_count());
  for (size_t f = 0; f < out.size(); ++f) {
    const OrientedTriangle t = {q[p.indices[3 * f]], q[p.indices[3 * f + 1]],
                                q[p.indices[3 * f + 2]]};
    OrientedTriangle best = t;
    for (int r = 1; r < 3; ++r) {
      const OrientedTriangle rotated = {t[r], t[(r + 1) % 3], t[(r + 2) % 3]};
      if (rotated < best) best = rotated;
    }
    out[f] = best;
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

StatusOr<GridComparison> CompareOnGrid(const Primitive& a, const Primitive& b, int qp) {
  Status status = ValidatePrimitive(a);
  if (!status.ok()) return status.WithContext("A");
  status = ValidatePrimitive(b);
  if (!status.ok()) return status.WithContext("B");
  MS_ASSIGN_OR_RETURN(const QuantizationGrid grid, PositionGrid(a.positions, a.indices, qp));
  MS_ASSIGN_OR_RETURN(const std::vector<Corner> qa, QuantizeReferenced(a, grid, "A"));
  MS_ASSIGN_OR_RETURN(const std::vector<Corner> qb, QuantizeReferenced(b, grid, "B"));
  const std::vector<OrientedTriangle> ta = CanonicalTriangles(a, qa);
  const std::vector<OrientedTriangle> tb = CanonicalTriangles(b, qb);

  GridComparison out;
  out.faces_a = ta.size();
  out.faces_b = tb.size();
  size_t i = 0, j = 0;
  while (i < ta.size() && j < tb.size()) {
    if (ta[i] < tb[j]) {
      ++out.only_in_a;
      ++i;
    } else if (tb[j] < ta[i]) {
      ++out.only_in_b;
      ++j;
    } else {
      ++i;
      ++j;
    }
  }
  out.only_in_a += ta.size() - i;
  out.only_in_b += tb.size() - j;
  out.equal = out.differing() == 0;
  return out;
}

StatusOr<bool> SameOnGrid(const Primitive& a, const Primitive& b, int qp) {
  MS_ASSIGN_OR_RETURN(const GridComparison comparison, CompareOnGrid(a, b, qp));
  return comparison.equal;
}

}  // namespace meshstream
