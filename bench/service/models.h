// The models of the service benchmark, and the variants of one: the same
// mesh in other bytes and with other encode options, so that every fresh
// ingest stores a new source blob, a new artifact and a new export.
#ifndef MESHSTREAM_BENCH_SERVICE_MODELS_H_
#define MESHSTREAM_BENCH_SERVICE_MODELS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "bench/service/args.h"
#include "meshstream/v1/asset_service.pb.h"

namespace meshstream::bench::service {

// name (the asset's), file (in the upload), path and bytes: ModelFile's.
struct Model : ModelFile {
  bool has_normals = false, has_texcoords = false;  // in any primitive
};

// The model at `relative` under `dir`, read and imported (Die when it
// cannot be).
Model LoadModel(const std::string& dir, const std::string& relative);

// The models of --model (all the shared models the benchmark uses without
// it); Die when none is left.
std::vector<Model> LoadModels(const Args& args);

// Variant k of a model's bytes: the same mesh in other bytes, so that the
// source blob is new (the PostgreSQL store would skip storing bytes it has)
// -- a comment for OBJ and PLY, whitespace in the JSON chunk of a .glb.
std::vector<uint8_t> VariantBytes(const Model& m, int k);

// The encode options of variant k: the defaults but the bits of an
// attribute the model does not have (see models.cc).
v1::EncodeOptions VariantOptions(const Model& m, int k);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_MODELS_H_
