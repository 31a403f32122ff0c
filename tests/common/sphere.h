// A closed, manifold UV sphere with poles, `rings` x `segments`, its height
// rippled by 0.1 sin(3 phi) so that no two levels of a simplification are
// alike: the synthetic mesh of the codec's unit tests.
#ifndef MESHSTREAM_TESTS_COMMON_SPHERE_H_
#define MESHSTREAM_TESTS_COMMON_SPHERE_H_

#include <cmath>
#include <cstdint>

#include "codec/mesh/mesh.h"

namespace meshstream::test_util {

inline Primitive RippledSphere(int rings, int segments) {
  Primitive p;
  p.positions.push_back({0, 0, 1});
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      p.positions.push_back({float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                             float(std::cos(theta) + 0.1 * std::sin(3 * phi))});
    }
  }
  p.positions.push_back({0, 0, -1});
  const uint32_t south = static_cast<uint32_t>(p.positions.size() - 1);
  auto id = [&](int r, int s) { return static_cast<uint32_t>(1 + (r - 1) * segments + (s % segments)); };
  for (int s = 0; s < segments; ++s) p.indices.insert(p.indices.end(), {0, id(1, s), id(1, s + 1)});
  for (int r = 1; r < rings - 1; ++r) {
    for (int s = 0; s < segments; ++s) {
      p.indices.insert(p.indices.end(), {id(r, s), id(r + 1, s), id(r + 1, s + 1)});
      p.indices.insert(p.indices.end(), {id(r, s), id(r + 1, s + 1), id(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s) p.indices.insert(p.indices.end(), {south, id(rings - 1, s + 1), id(rings - 1, s)});
  return p;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_SPHERE_H_
