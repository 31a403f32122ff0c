// Scan-like surface noise for the encoder's scaling benchmark (issue 42:
// "a mesh that has surface noise like a scan, not only a smooth
// subdivision"). A midpoint subdivision puts every new vertex on a flat
// triangle, which a progressive encoder simplifies for free (zero-cost
// collapses, perfect predictions); a scanner's surface is rough at the scale
// of its sampling. Every vertex moves along its area-weighted normal by a
// uniform offset in [-a, a], a = `amplitude` x the mesh's mean edge length,
// from a fixed seed: the same input every run.
//
// Contract: positions only (triangles unchanged); deterministic for a given
// mesh, amplitude and seed; vertices without faces do not move. Pure.
#ifndef MESHSTREAM_BENCH_SCALING_SURFACE_NOISE_H_
#define MESHSTREAM_BENCH_SCALING_SURFACE_NOISE_H_

#include <cstdint>

#include "codec/mesh/mesh.h"

namespace meshstream::bench {

Primitive WithSurfaceNoise(const Primitive& in, double amplitude, uint64_t seed);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SCALING_SURFACE_NOISE_H_
