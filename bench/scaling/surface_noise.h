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

// The large model of the shaped-link race and the "scan" surface of the
// scaling series: every vertex from `first_new` on (those a subdivision
// added) moves by a uniform offset in [-steps, steps] grid steps along each
// axis, a grid step being the largest extent of the mesh's box over
// 2^bits - 1 (qp `bits`): noise at the scale of the sampling, which a
// single-rate coder pays for (Draco cl7 about 11.8 bits a vertex on the bunny
// subdivided twice, against 6.6 for the flat subdivision) and a simplifier
// cannot remove for free. Deterministic for a given mesh and seed; pure.
Primitive WithGridNoise(const Primitive& in, size_t first_new, double steps, int bits, uint64_t seed);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SCALING_SURFACE_NOISE_H_
