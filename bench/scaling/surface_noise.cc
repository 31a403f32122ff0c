#include "bench/scaling/surface_noise.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace meshstream::bench {

Primitive WithSurfaceNoise(const Primitive& in, double amplitude, uint64_t seed) {
  Primitive out;
  out.positions = in.positions;
  out.indices = in.indices;
  const size_t n = in.positions.size();
  std::vector<std::array<double, 3>> normal(n, {0.0, 0.0, 0.0});
  double edge_sum = 0;
  size_t edges = 0;
  for (size_t t = 0; t + 2 < in.indices.size(); t += 3) {
    const uint32_t v[3] = {in.indices[t], in.indices[t + 1], in.indices[t + 2]};
    if (v[0] >= n || v[1] >= n || v[2] >= n) continue;
    const Vec3f& a = in.positions[v[0]];
    const Vec3f& b = in.positions[v[1]];
    const Vec3f& c = in.positions[v[2]];
    const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const double cross[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
    for (uint32_t k : v)
      for (int i = 0; i < 3; ++i) normal[k][i] += cross[i];  // twice the area, weighted
    for (int s = 0; s < 3; ++s) {
      const Vec3f& p = in.positions[v[s]];
      const Vec3f& q = in.positions[v[(s + 1) % 3]];
      edge_sum += std::sqrt(std::pow(double(p[0]) - q[0], 2) + std::pow(double(p[1]) - q[1], 2) +
                            std::pow(double(p[2]) - q[2], 2));
      ++edges;
    }
  }
  if (edges == 0) return out;
  const double a = amplitude * edge_sum / static_cast<double>(edges);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> offset(-a, a);
  for (size_t k = 0; k < n; ++k) {
    const double d = offset(rng);  // drawn for every vertex: the sequence does not depend on the normals
    const double len = std::sqrt(normal[k][0] * normal[k][0] + normal[k][1] * normal[k][1] + normal[k][2] * normal[k][2]);
    if (!(len > 0)) continue;
    for (int i = 0; i < 3; ++i) {
      out.positions[k][i] = static_cast<float>(out.positions[k][i] + d * normal[k][i] / len);
    }
  }
  return out;
}

Primitive WithGridNoise(const Primitive& in, size_t first_new, double steps, int bits, uint64_t seed) {
  Primitive out;
  out.positions = in.positions;
  out.indices = in.indices;
  if (in.positions.empty()) return out;
  double lo[3], hi[3];
  for (int i = 0; i < 3; ++i) lo[i] = hi[i] = in.positions[0][i];
  for (const Vec3f& p : in.positions) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], double(p[i]));
      hi[i] = std::max(hi[i], double(p[i]));
    }
  }
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const double step = extent / (std::ldexp(1.0, bits) - 1);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> offset(-steps * step, steps * step);
  for (size_t k = first_new; k < out.positions.size(); ++k) {
    for (int i = 0; i < 3; ++i) out.positions[k][i] = static_cast<float>(out.positions[k][i] + offset(rng));
  }
  return out;
}

}  // namespace meshstream::bench
