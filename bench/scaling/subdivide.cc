#include "bench/scaling/subdivide.h"

#include <unordered_map>

namespace meshstream::bench {

Primitive SubdivideMidpoint(const Primitive& in) {
  Primitive out;
  out.positions = in.positions;
  std::unordered_map<uint64_t, uint32_t> midpoint;
  midpoint.reserve(in.indices.size());
  auto middle = [&](uint32_t a, uint32_t b) {
    const uint64_t key = a < b ? (uint64_t{a} << 32 | b) : (uint64_t{b} << 32 | a);
    auto [it, added] = midpoint.emplace(key, static_cast<uint32_t>(out.positions.size()));
    if (added) {
      const Vec3f& p = in.positions[a];
      const Vec3f& q = in.positions[b];
      out.positions.push_back({(p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2});
    }
    return it->second;
  };
  out.indices.reserve(in.indices.size() * 4);
  for (size_t t = 0; t + 2 < in.indices.size(); t += 3) {
    const uint32_t a = in.indices[t], b = in.indices[t + 1], c = in.indices[t + 2];
    const uint32_t ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
    out.indices.insert(out.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  return out;
}

}  // namespace meshstream::bench
