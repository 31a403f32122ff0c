// The models of the stream benchmark: the bunny, the horse and the largest
// single-file model of the shared folder (by file size; the shaped link's
// by vertices, shaped.cc), read once, ingested into a benchmark server.
#ifndef MESHSTREAM_BENCH_STREAM_MODELS_H_
#define MESHSTREAM_BENCH_STREAM_MODELS_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "bench/stream/args.h"
#include "meshstream/v1/asset_service.pb.h"

namespace meshstream::bench::stream {

// name (the asset's), file (in the upload), path and bytes: ModelFile's.
struct Model : ModelFile {
  std::vector<std::string> roles;  // "bunny", "horse", "largest"
  int64_t version = 0;  // 0 until ingested
  v1::Version info;
};

// Every single-file model (.obj, .ply, .glb: a .gltf would need its
// resources) anywhere under `dir`, sorted (std::filesystem::path order).
std::vector<std::filesystem::path> SingleFileModels(const std::string& dir);

// The bunny, the horse and the largest model by file size (one Model per
// file, with every role it plays), filtered by --model (unless
// --only-shaped: the shaped part filters its own), their bytes read; Die
// when a file is missing or none is left.
std::vector<Model> ChooseModels(const Args& args);

// The model at `relative` under `dir` with `roles`, its bytes read (Die
// when it cannot be).
Model LoadModel(const std::string& dir, const std::string& relative, std::vector<std::string> roles);

bool IsLargest(const Model& m);

// Drops the models whose name is not in `only` (nothing when it is empty).
void KeepOnly(const std::vector<std::string>& only, std::vector<Model>& models);

// Ingests `m` into the server at `address` and waits for its job: fills
// m.version and m.info; Die when the upload or the job fails.
void Ingest(const std::string& address, Model& m);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_MODELS_H_
