#include "web/wasm/decoder_api.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>

#include "codec/bitstream/format.h"
#include "codec/loss/lossy_decode.h"
#include "codec/mesh/mesh.h"
#include "codec/mesh/quantized_mesh.h"

using namespace meshstream;

struct ms_wasm_stream {
  uint32_t stream_id = 0;
  bool parsed = false;
  ProgressiveStream stream;
  StreamHeader header;
  bool has_base = false;
  QuantizedMesh base;
  Primitive decoded;
  uint32_t predicted = 0;
  std::string error;
  char hash[17] = {0};
};

namespace {

int Fail(ms_wasm_stream* s, const Status& status) {
  s->error = status.ToString();
  return 1;
}

}  // namespace

extern "C" {

ms_wasm_stream* ms_wasm_open(const uint8_t* blob, uint32_t size, uint32_t stream_id) {
  auto* s = new (std::nothrow) ms_wasm_stream;
  if (s == nullptr) return nullptr;
  s->stream_id = stream_id;
  auto stream = ProgressiveStream::Parse(blob, size);
  if (!stream.ok()) {
    Fail(s, stream.status());
    return s;
  }
  auto header = stream->ParseHeader();
  if (!header.ok()) {
    Fail(s, header.status());
    return s;
  }
  s->stream = std::move(stream).value();
  s->header = std::move(header).value();
  s->parsed = true;
  return s;
}

void ms_wasm_close(ms_wasm_stream* s) { delete s; }

const char* ms_wasm_error(const ms_wasm_stream* s) { return s ? s->error.c_str() : "no stream"; }

uint32_t ms_wasm_refinements(const ms_wasm_stream* s) {
  return s && s->parsed ? static_cast<uint32_t>(s->header.split_counts.size()) : 0;
}

int ms_wasm_set_base(ms_wasm_stream* s, uint32_t vertices, const float* positions, const float* normals,
                     uint32_t texcoord_sets, const float* texcoords, const float* colors, uint32_t index_count,
                     const uint32_t* indices) {
  if (s == nullptr) return 1;
  if (!s->parsed) return Fail(s, FailedPrecondition("the stream did not parse: " + s->error));
  if (positions == nullptr || (index_count > 0 && indices == nullptr) || (texcoord_sets > 0 && texcoords == nullptr)) {
    return Fail(s, InvalidArgument("set_base: a null array"));
  }
  if (texcoord_sets > 8) return Fail(s, InvalidArgument("set_base: more than 8 texture coordinate sets"));
  Primitive p;
  p.positions.resize(vertices);
  std::memcpy(p.positions.data(), positions, sizeof(float) * 3 * vertices);
  if (normals != nullptr) {
    p.normals.resize(vertices);
    std::memcpy(p.normals.data(), normals, sizeof(float) * 3 * vertices);
  }
  for (uint32_t t = 0; t < texcoord_sets; ++t) {
    p.texcoords.emplace_back(vertices);
    std::memcpy(p.texcoords.back().data(), texcoords + size_t(t) * 2 * vertices, sizeof(float) * 2 * vertices);
  }
  if (colors != nullptr) {
    p.colors.resize(vertices);
    std::memcpy(p.colors.data(), colors, sizeof(float) * 4 * vertices);
  }
  p.indices.assign(indices, indices + index_count);
  auto base = QuantizeOnto(p, s->header.grids);
  if (!base.ok()) return Fail(s, base.status().WithContext("base"));
  s->base = std::move(base).value();
  s->has_base = true;
  s->error.clear();
  return 0;
}

int ms_wasm_decode(ms_wasm_stream* s, int32_t lod, double loss, double burst, uint32_t seed, const uint32_t* reliable,
                   uint32_t reliable_count) {
  if (s == nullptr) return 1;
  if (!s->has_base) return Fail(s, FailedPrecondition("decode: no base was set"));
  const size_t levels = s->header.split_counts.size();
  LossyDecodeOptions lossy;
  lossy.loss.loss = loss;
  lossy.loss.burst = burst;
  lossy.loss.seed = uint64_t{seed} + s->stream_id;
  const Status valid = lossy.loss.Validate();
  if (!valid.ok()) return Fail(s, valid);
  lossy.reconstructor.lod = lod < 0 ? static_cast<int>(levels) : std::min<int>(lod, static_cast<int>(levels));
  for (uint32_t k = 0; k < reliable_count; ++k) {
    if (reliable[k] >= levels) return Fail(s, InvalidArgument("decode: reliable refinement " + std::to_string(reliable[k]) + " does not exist"));
    lossy.reliable.push_back(reliable[k]);
  }
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s->stream, s->stream_id, s->base, lossy, &report);
  if (!reader.ok()) return Fail(s, reader.status());
  s->decoded = DequantizeMesh(reader->Mesh(), -1);
  s->predicted = static_cast<uint32_t>(reader->unreliable_vertices());
  std::snprintf(s->hash, sizeof s->hash, "%016llx", static_cast<unsigned long long>(PrimitiveHash(s->decoded)));
  s->error.clear();
  return 0;
}

uint32_t ms_wasm_vertex_count(const ms_wasm_stream* s) { return s ? static_cast<uint32_t>(s->decoded.positions.size()) : 0; }
uint32_t ms_wasm_index_count(const ms_wasm_stream* s) { return s ? static_cast<uint32_t>(s->decoded.indices.size()) : 0; }
uint32_t ms_wasm_texcoord_sets(const ms_wasm_stream* s) { return s ? static_cast<uint32_t>(s->decoded.texcoords.size()) : 0; }
const float* ms_wasm_positions(const ms_wasm_stream* s) {
  return s && !s->decoded.positions.empty() ? s->decoded.positions.front().data() : nullptr;
}
const float* ms_wasm_normals(const ms_wasm_stream* s) {
  return s && !s->decoded.normals.empty() ? s->decoded.normals.front().data() : nullptr;
}
const float* ms_wasm_texcoords(const ms_wasm_stream* s, uint32_t set) {
  return s && set < s->decoded.texcoords.size() && !s->decoded.texcoords[set].empty()
             ? s->decoded.texcoords[set].front().data()
             : nullptr;
}
const float* ms_wasm_colors(const ms_wasm_stream* s) {
  return s && !s->decoded.colors.empty() ? s->decoded.colors.front().data() : nullptr;
}
const uint32_t* ms_wasm_indices(const ms_wasm_stream* s) {
  return s && !s->decoded.indices.empty() ? s->decoded.indices.data() : nullptr;
}
uint32_t ms_wasm_predicted_vertices(const ms_wasm_stream* s) { return s ? s->predicted : 0; }
const char* ms_wasm_hash(const ms_wasm_stream* s) { return s ? s->hash : ""; }

}  // extern "C"
