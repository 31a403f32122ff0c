// The triangulation of a UV sphere that several tests build their meshes
// on: a north pole, rings - 1 rings of `segments` vertices, a south pole, in
// that vertex order. The caller's `add(theta, phi)` appends one vertex's
// values to `p` (positions and whatever attributes it wants); the sphere
// adds the triangles, outward-facing.
#ifndef MESHSTREAM_TESTS_COMMON_UV_SPHERE_H_
#define MESHSTREAM_TESTS_COMMON_UV_SPHERE_H_

#include <cmath>
#include <cstdint>

#include "codec/mesh/mesh.h"

namespace meshstream::test_util {

template <class Add>
void BuildUvSphere(int rings, int segments, Primitive* p, Add add) {
  add(0.0, 0.0);
  for (int i = 1; i < rings; ++i)
    for (int s = 0; s < segments; ++s) add(M_PI * i / rings, 2 * M_PI * s / segments);
  add(M_PI, 0.0);
  const uint32_t south = static_cast<uint32_t>(p->positions.size() - 1);
  auto id = [segments](int i, int s) { return static_cast<uint32_t>(1 + (i - 1) * segments + s % segments); };
  for (int s = 0; s < segments; ++s) p->indices.insert(p->indices.end(), {0, id(1, s), id(1, s + 1)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int s = 0; s < segments; ++s) {
      p->indices.insert(p->indices.end(), {id(i, s), id(i + 1, s), id(i + 1, s + 1)});
      p->indices.insert(p->indices.end(), {id(i, s), id(i + 1, s + 1), id(i, s + 1)});
    }
  for (int s = 0; s < segments; ++s) {
    p->indices.insert(p->indices.end(), {south, id(rings - 1, s + 1), id(rings - 1, s)});
  }
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_UV_SPHERE_H_
