#include "codec/mesh/quantization.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace meshstream {

int64_t QuantizationGrid::Quantize(float value, int component) const {
  const double v = (static_cast<double>(value) - origin[component]) / step();
  return static_cast<int64_t>(std::llround(v));
}

float QuantizationGrid::Dequantize(int64_t q, int component) const {
  return static_cast<float>(origin[component] + static_cast<double>(q) * step());
}

Status CheckQuantizationBits(int bits, const char* flag) {
  if (bits < kMinQuantizationBits || bits > kMaxQuantizationBits) {
    return InvalidArgument(std::string(flag) + " must be between " +
                           std::to_string(kMinQuantizationBits) + " and " +
                           std::to_string(kMaxQuantizationBits) + ", got " +
                           std::to_string(bits));
  }
  return Status::Ok();
}

namespace {

template <size_t N>
StatusOr<QuantizationGrid> GridOfBox(const std::array<float, N>& lo,
                                     const std::array<float, N>& hi, int bits) {
  QuantizationGrid grid;
  grid.bits = bits;
  grid.components = static_cast<int>(N);
  double extent = 0;
  for (size_t c = 0; c < N; ++c) {
    grid.origin[c] = lo[c];
    extent = std::max(extent, static_cast<double>(hi[c]) - lo[c]);
  }
  if (!std::isfinite(extent) || !std::isfinite(static_cast<float>(extent))) {
    return InvalidInput("values span more than a float can hold; they cannot be quantized");
  }
  grid.range = static_cast<float>(extent);
  if (!(grid.range > 0.0f)) grid.range = 1.0f;  // all values equal
  return grid;
}

template <size_t N>
StatusOr<QuantizationGrid> GridOfValues(const std::vector<std::array<float, N>>& values,
                                        int bits, const char* what) {
  MS_RETURN_IF_ERROR(CheckQuantizationBits(bits, what));
  if (values.empty()) return InvalidInput(std::string("no values to build a ") + what + " grid");
  const ComponentBounds<N> b = BoundsOf(values);
  return GridOfBox<N>(b.lo, b.hi, bits);
}

}  // namespace

StatusOr<QuantizationGrid> PositionGrid(const std::vector<Vec3f>& positions,
                                        const std::vector<uint32_t>& indices, int bits) {
  MS_RETURN_IF_ERROR(CheckQuantizationBits(bits, "position bits (--qp)"));
  Vec3f lo, hi;
  lo.fill(std::numeric_limits<float>::infinity());
  hi.fill(-std::numeric_limits<float>::infinity());
  auto grow = [&](const Vec3f& p) {
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], p[c]);
      hi[c] = std::max(hi[c], p[c]);
    }
  };
  if (indices.empty()) {
    for (const Vec3f& p : positions) grow(p);
  } else {
    for (uint32_t i : indices) {
      if (i >= positions.size()) {
        return InvalidInput("index " + std::to_string(i) + " is out of range (" +
                            std::to_string(positions.size()) + " positions)");
      }
      grow(positions[i]);
    }
  }
  if (!(lo[0] <= hi[0])) return InvalidInput("no referenced vertex to build a position grid");
  return GridOfBox<3>(lo, hi, bits);
}

StatusOr<QuantizationGrid> GridOf(const std::vector<Vec2f>& values, int bits) {
  return GridOfValues<2>(values, bits, "texture coordinate bits (--qt)");
}

StatusOr<QuantizationGrid> GridOf(const std::vector<Vec4f>& values, int bits) {
  return GridOfValues<4>(values, bits, "colour bits (--qc)");
}

std::vector<Vec3q> QuantizePositions(const std::vector<Vec3f>& positions,
                                     const QuantizationGrid& grid) {
  std::vector<Vec3q> out(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    for (int c = 0; c < 3; ++c) out[i][c] = grid.Quantize(positions[i][c], c);
  }
  return out;
}

void SnapToGrid(std::vector<Vec3f>& positions, const QuantizationGrid& grid) {
  for (Vec3f& p : positions) {
    for (int c = 0; c < 3; ++c) p[c] = grid.Dequantize(grid.Quantize(p[c], c), c);
  }
}

std::array<uint32_t, 2> QuantizeNormal(const Vec3f& normal, int bits) {
  double x = normal[0], y = normal[1], z = normal[2];
  const double l1 = std::fabs(x) + std::fabs(y) + std::fabs(z);
  if (!(l1 > 0) || !std::isfinite(l1)) {
    x = 0; y = 0; z = 1;
  } else {
    x /= l1; y /= l1; z /= l1;
  }
  double s = x, t = y;
  if (z < 0) {
    s = (1.0 - std::fabs(y)) * (x >= 0 ? 1.0 : -1.0);
    t = (1.0 - std::fabs(x)) * (y >= 0 ? 1.0 : -1.0);
  }
  const double max = static_cast<double>((1u << bits) - 1u);
  auto to_grid = [&](double v) {
    const double q = std::round((v + 1.0) * 0.5 * max);
    return static_cast<uint32_t>(std::clamp(q, 0.0, max));
  };
  uint32_t qs = to_grid(s), qt = to_grid(t);
  // The border of the octahedral square folds onto itself: (s, +-1) and
  // (-s, +-1) are one direction, and so are (+-1, t) and (+-1, -t). Keep the
  // non-negative half so that every direction has exactly one code.
  const uint32_t m = (1u << bits) - 1u;
  if ((qt == 0 || qt == m) && qs < m - qs) qs = m - qs;
  if ((qs == 0 || qs == m) && qt < m - qt) qt = m - qt;
  return {qs, qt};
}

Vec3f DequantizeNormal(const std::array<uint32_t, 2>& q, int bits) {
  const double max = static_cast<double>((1u << bits) - 1u);
  double s = q[0] / max * 2.0 - 1.0;
  double t = q[1] / max * 2.0 - 1.0;
  double z = 1.0 - std::fabs(s) - std::fabs(t);
  double x = s, y = t;
  if (z < 0) {
    x = (1.0 - std::fabs(t)) * (s >= 0 ? 1.0 : -1.0);
    y = (1.0 - std::fabs(s)) * (t >= 0 ? 1.0 : -1.0);
  }
  const double len = std::sqrt(x * x + y * y + z * z);
  return {static_cast<float>(x / len), static_cast<float>(y / len), static_cast<float>(z / len)};
}

}  // namespace meshstream
