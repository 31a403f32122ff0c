// Quantization of vertex attributes onto integer grids, with parameters like
// Draco's (--qp, --qn, --qt, --qc).
//
// Positions (docs/design/design.md, "The position grid"): origin at the minimum corner of the
// bounding box of the referenced vertices, one step for all three axes,
// step = range / (2^bits - 1) where range is the largest extent (rounded to
// float, as Draco stores it; 1 when the extent is 0), value = round((x - origin) / step).
// UVs and colours use the same rule with their own bounding box.
// Normals use the octahedral map onto a (2^bits - 1)^2 grid.
//
// Contract: pure functions, no allocation beyond the returned vectors. Values
// outside the grid's box quantize to integers outside [0, 2^bits - 1] rather
// than being clamped, so that comparing a mesh on another mesh's grid is exact.
// Dequantize(Quantize(x)) lies within step/2 of x; Quantize(Dequantize(q)) == q.
// For normals the octahedral square folds its border onto itself, so the
// guarantee is idempotence: QuantizeNormal(DequantizeNormal(q)) == q for every
// q that QuantizeNormal produced.
#ifndef MESHSTREAM_CODEC_MESH_QUANTIZATION_H_
#define MESHSTREAM_CODEC_MESH_QUANTIZATION_H_

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

constexpr int kMinQuantizationBits = 1;
constexpr int kMaxQuantizationBits = 30;

// A uniform grid of up to four components sharing one step.
struct QuantizationGrid {
  int bits = 0;
  int components = 0;
  std::array<float, 4> origin = {0, 0, 0, 0};
  float range = 1.0f;  // the largest extent, as Draco's explicit quantization takes it

  uint32_t max_value() const { return (bits >= 32) ? 0xffffffffu : ((1u << bits) - 1u); }
  double step() const { return static_cast<double>(range) / max_value(); }

  int64_t Quantize(float value, int component) const;
  float Dequantize(int64_t q, int component) const;
};

Status CheckQuantizationBits(int bits, const char* flag);

// Per-component minimum and maximum of `values` (+inf / -inf when empty).
template <size_t N>
struct ComponentBounds {
  std::array<float, N> lo, hi;
};
template <size_t N>
ComponentBounds<N> BoundsOf(const std::vector<std::array<float, N>>& values) {
  ComponentBounds<N> b;
  b.lo.fill(std::numeric_limits<float>::infinity());
  b.hi.fill(-std::numeric_limits<float>::infinity());
  for (const auto& v : values) {
    for (size_t c = 0; c < N; ++c) {
      b.lo[c] = v[c] < b.lo[c] ? v[c] : b.lo[c];
      b.hi[c] = v[c] > b.hi[c] ? v[c] : b.hi[c];
    }
  }
  return b;
}

// Grid of the positions of the vertices referenced by `indices` (all vertices
// when `indices` is empty). Fails when no vertex is referenced or bits are out
// of [1, 30].
StatusOr<QuantizationGrid> PositionGrid(const std::vector<Vec3f>& positions,
                                        const std::vector<uint32_t>& indices, int bits);

// Grids for UVs and colours: the bounding box of all values.
StatusOr<QuantizationGrid> GridOf(const std::vector<Vec2f>& values, int bits);
StatusOr<QuantizationGrid> GridOf(const std::vector<Vec4f>& values, int bits);

using Vec3q = std::array<int64_t, 3>;
std::vector<Vec3q> QuantizePositions(const std::vector<Vec3f>& positions,
                                     const QuantizationGrid& grid);
// Replaces every position by the centre of its grid cell (its dequantized value).
void SnapToGrid(std::vector<Vec3f>& positions, const QuantizationGrid& grid);

// Octahedral normal quantization, `bits` per component (Draco's --qn).
// The input need not be unit length; a zero vector maps to +Z.
std::array<uint32_t, 2> QuantizeNormal(const Vec3f& normal, int bits);
Vec3f DequantizeNormal(const std::array<uint32_t, 2>& q, int bits);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_QUANTIZATION_H_
