// The shaped link's distances, measured after every run (nothing else
// running, on every core): the symmetric Hausdorff and mean distance of each
// distinct mesh a client showed against its model's full lossless mesh, and
// per model those of Draco's GLB and of the source file.
#ifndef MESHSTREAM_BENCH_STREAM_SHAPED_DISTANCES_H_
#define MESHSTREAM_BENCH_STREAM_SHAPED_DISTANCES_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/models.h"
#include "codec/mesh/mesh.h"

namespace meshstream::bench::stream {

// Per model name: the full lossless mesh (a gRPC session straight to the
// server) and its hash, the decoded Draco GLB and the source file.
struct ShapedMeshes {
  std::map<std::string, Primitive> reference, draco, source;
  std::map<std::string, uint64_t> reference_hash;
};

struct DistanceCounts {
  size_t distinct_meshes = 0;  // distances computed
  size_t snapshots = 0;        // meshes shown, with a distance each
  double seconds = 0;
};

// Reads each run's snapshot file (snapshot_files[i] of runs[i]; "" when
// none) and removes it; adds "quality" (one distance per snapshot, with its
// event's time) to every run of `runs`, and "draco_vs_reference",
// "source_vs_reference" and "draco_vs_source" to each model of
// `model_info`. `samples`: surface samples per side (0: every vertex, edge
// midpoint and face centroid).
DistanceCounts MeasureShapedDistances(const std::vector<Model>& models, const ShapedMeshes& meshes,
                                      const std::vector<std::string>& snapshot_files, int64_t samples,
                                      nlohmann::json& runs, nlohmann::json& model_info);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SHAPED_DISTANCES_H_
