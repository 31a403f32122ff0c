// Deterministic 1-to-4 midpoint subdivision, for the encoder's scaling
// benchmark (docs/results/benchmarks.md, "The encoder at scale"): every triangle
// becomes four, each edge gaining one vertex at its midpoint (shared by the
// triangles on both sides, so the surface stays closed where it was). The
// new vertices lie on the old flat triangles; that is what "the bunny
// subdivided" means in issue 24, and the same input every run.
//
// Contract: positions and triangles only (other attributes are dropped);
// the result has V + E vertices and 4 F triangles. Pure.
#ifndef MESHSTREAM_BENCH_SCALING_SUBDIVIDE_H_
#define MESHSTREAM_BENCH_SCALING_SUBDIVIDE_H_

#include "codec/mesh/mesh.h"

namespace meshstream::bench {

Primitive SubdivideMidpoint(const Primitive& in);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SCALING_SUBDIVIDE_H_
