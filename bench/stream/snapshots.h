// What a shaped-link client showed over time: the flattened geometry at a
// few events, written by the child (shaped_client.cc) to a file after its
// clock has stopped and read back by the parent (shaped.cc), which measures
// each distinct mesh once against the full lossless mesh.
//
// Contract: the file is this program's own, between its processes on one
// machine (native byte order); ReadSnapshots still checks the magic and
// bounds the sizes, and Dies on a file it cannot read.
#ifndef MESHSTREAM_BENCH_STREAM_SNAPSHOTS_H_
#define MESHSTREAM_BENCH_STREAM_SNAPSHOTS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"

namespace meshstream::bench::stream {

struct Snapshot {
  int32_t level = 0;  // 0: the base mesh; the level; -1: kComplete; -2: the Draco GLB decoded
  Primitive mesh;
};

void WriteSnapshots(const std::string& path, const std::vector<Snapshot>& snapshots);
std::vector<Snapshot> ReadSnapshots(const std::string& path);

// FNV-1a over the positions' and indices' bytes: equal meshes, equal hashes
// (the distances of a mesh shown in several runs are computed once).
uint64_t MeshHash(const Primitive& p);

// The scene flattened, geometry only: what the distances need.
Primitive Geometry(const Scene& scene);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SNAPSHOTS_H_
