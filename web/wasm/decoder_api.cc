#include "web/wasm/decoder_api.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <new>
#include <memory>
#include <numeric>
#include <string>

#include "codec/bitstream/format.h"
#include "codec/bitstream/writer.h"
#include "codec/progressive/encoder.h"
#include "codec/loss/lossy_decode.h"
#include "codec/loss/reconstructor.h"
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
  std::vector<uint8_t> reliable;  // per vertex of `decoded`
  uint32_t predicted = 0;
  // Live decoding (ms_wasm_live_*): the header's bytes and the reconstructor.
  std::vector<uint8_t> header_bytes;
  std::unique_ptr<StreamReconstructor> live;
  QuantizedMesh snapshot;
  std::string error;
  char hash[17] = {0};
};

namespace {

int Fail(ms_wasm_stream* s, const Status& status) {
  s->error = status.ToString();
  return 1;
}

// The base's floats as a Primitive, quantized onto the header's grids.
StatusOr<QuantizedMesh> BaseFromFloats(const StreamHeader& header, uint32_t vertices, const float* positions,
                                       const float* normals, uint32_t texcoord_sets, const float* texcoords,
                                       const float* colors, uint32_t index_count, const uint32_t* indices) {
  if ((vertices > 0 && positions == nullptr) || (index_count > 0 && indices == nullptr) ||
      (texcoord_sets > 0 && texcoords == nullptr)) {
    return InvalidArgument("set_base: a null array");
  }
  if (texcoord_sets > 8) return InvalidArgument("set_base: more than 8 texture coordinate sets");
  Primitive p;
  p.positions.resize(vertices);
  if (vertices > 0) std::memcpy(p.positions.data(), positions, sizeof(float) * 3 * vertices);
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
  if (index_count > 0) p.indices.assign(indices, indices + index_count);
  auto base = QuantizeOnto(p, header.grids);
  if (!base.ok()) return base.status().WithContext("base");
  return base;
}

// The decoded mesh of `reader` for the accessors.
void Publish(ms_wasm_stream* s, const StreamReader& reader, const QuantizedMesh& mesh) {
  s->decoded = DequantizeMesh(mesh, -1);
  s->reliable = reader.reliable();
  s->reliable.resize(s->decoded.positions.size(), 1);
  s->predicted = static_cast<uint32_t>(reader.unreliable_vertices());
  std::snprintf(s->hash, sizeof s->hash, "%016llx", static_cast<unsigned long long>(PrimitiveHash(s->decoded)));
}

// A latitude-longitude sphere with normals, slightly bumpy so that the
// splits' geometry is not all alike.
Primitive WarmUpSphere(int rings, int segments) {
  Primitive p;
  for (int i = 0; i <= rings; ++i) {
    const double theta = 3.14159265358979 * i / rings;
    for (int j = 0; j < (i == 0 || i == rings ? 1 : segments); ++j) {
      const double phi = 2 * 3.14159265358979 * j / segments;
      const double r = 1.0 + 0.05 * std::sin(5 * theta) * std::cos(3 * phi);
      const float n[3] = {static_cast<float>(std::sin(theta) * std::cos(phi)),
                          static_cast<float>(std::sin(theta) * std::sin(phi)), static_cast<float>(std::cos(theta))};
      p.positions.push_back({static_cast<float>(r * n[0]), static_cast<float>(r * n[1]), static_cast<float>(r * n[2])});
      p.normals.push_back({n[0], n[1], n[2]});
    }
  }
  auto at = [&](int i, int j) -> uint32_t {
    if (i == 0) return 0;
    if (i == rings) return static_cast<uint32_t>(1 + (rings - 1) * segments);
    return static_cast<uint32_t>(1 + (i - 1) * segments + (j % segments));
  };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (i != 0) p.indices.insert(p.indices.end(), {a, b, d});
      if (i != rings - 1) p.indices.insert(p.indices.end(), {b, c, d});
    }
  }
  return p;
}

}  // namespace

extern "C" {

uint32_t ms_wasm_warm_up(void) {
  ProgressiveEncodeOptions options;
  auto identity = [](const QuantizedMesh& base, int) -> StatusOr<EncodedBase> {
    EncodedBase e;
    e.decoded = base;
    e.bytes = {0};
    return e;
  };
  auto encoded = EncodeProgressive(WarmUpSphere(40, 64), options, identity);
  if (!encoded.ok()) return 0;
  auto stream = WriteStream(encoded.value(), options.quantization, StreamWriteOptions());
  if (!stream.ok()) return 0;
  uint32_t vertices = 0;
  for (int run = 0; run < 3; ++run) {
    auto reader = DecodeStreamLossy(stream.value(), 0, encoded->mesh.base, LossyDecodeOptions(), nullptr);
    if (!reader.ok()) return 0;
    vertices = static_cast<uint32_t>(DequantizeMesh(reader->Mesh(), -1).positions.size());
  }
  return vertices;
}

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
  auto base = BaseFromFloats(s->header, vertices, positions, normals, texcoord_sets, texcoords, colors, index_count,
                             indices);
  if (!base.ok()) return Fail(s, base.status());
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
  Publish(s, reader.value(), reader->Mesh());
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
const uint8_t* ms_wasm_reliable(const ms_wasm_stream* s) {
  return s && !s->reliable.empty() ? s->reliable.data() : nullptr;
}

ms_wasm_stream* ms_wasm_live_open(const uint8_t* header, uint32_t size, uint32_t stream_id, int32_t lod) {
  auto* s = new (std::nothrow) ms_wasm_stream;
  if (s == nullptr) return nullptr;
  s->stream_id = stream_id;
  if (header == nullptr && size > 0) {
    Fail(s, InvalidArgument("live_open: a null header"));
    return s;
  }
  s->header_bytes.assign(header, header + size);
  auto parsed = StreamHeader::Parse(s->header_bytes.data(), s->header_bytes.size());
  if (!parsed.ok()) {
    Fail(s, parsed.status().WithContext("header"));
    return s;
  }
  s->header = std::move(parsed).value();
  ReconstructorOptions options;
  options.lod = lod < 0 ? -1 : lod;
  // Reliable transports: the clock never declares a straggler lost.
  options.straggler_timeout_us = UINT64_MAX;
  auto rec = StreamReconstructor::Create(s->header_bytes.data(), s->header_bytes.size(), stream_id, options);
  if (!rec.ok()) {
    Fail(s, rec.status());
    return s;
  }
  s->live = std::make_unique<StreamReconstructor>(std::move(rec).value());
  s->parsed = true;
  return s;
}

uint32_t ms_wasm_live_base_vertices(const ms_wasm_stream* s) { return s && s->parsed ? s->header.base_vertices : 0; }

uint32_t ms_wasm_live_final_vertices(const ms_wasm_stream* s) {
  if (s == nullptr || !s->parsed) return 0;
  return std::accumulate(s->header.split_counts.begin(), s->header.split_counts.end(), s->header.base_vertices);
}

uint32_t ms_wasm_live_splits(const ms_wasm_stream* s, uint32_t refinement) {
  return s && s->parsed && refinement < s->header.split_counts.size() ? s->header.split_counts[refinement] : 0;
}

int ms_wasm_live_set_base(ms_wasm_stream* s, uint32_t vertices, const float* positions, const float* normals,
                          uint32_t texcoord_sets, const float* texcoords, const float* colors, uint32_t index_count,
                          const uint32_t* indices) {
  if (s == nullptr) return 1;
  if (!s->live) return Fail(s, FailedPrecondition("live_set_base: the stream did not open: " + s->error));
  auto base = BaseFromFloats(s->header, vertices, positions, normals, texcoord_sets, texcoords, colors, index_count,
                             indices);
  if (!base.ok()) return Fail(s, base.status());
  const Status set = s->live->SetBase(std::move(base).value());
  if (!set.ok()) return Fail(s, set);
  s->has_base = true;
  s->error.clear();
  return 0;
}

int ms_wasm_live_control(ms_wasm_stream* s, const uint8_t* control, uint32_t size) {
  if (s == nullptr) return 1;
  if (!s->has_base || !s->live) return Fail(s, FailedPrecondition("live_control: no base was set"));
  if (control == nullptr && size > 0) return Fail(s, InvalidArgument("live_control: a null block"));
  const Status st = s->live->OnControl(control, size, 0);
  return st.ok() ? 0 : Fail(s, st);
}

void ms_wasm_live_datagram(ms_wasm_stream* s, const uint8_t* data, uint32_t size) {
  if (s == nullptr || !s->live || (data == nullptr && size > 0)) return;
  s->live->OnDatagram(data, size, 0);
}

void ms_wasm_live_end(ms_wasm_stream* s, uint32_t refinement, uint32_t datagrams) {
  if (s == nullptr || !s->live) return;
  const std::vector<uint8_t> end =
      MakeStreamEndDatagram(s->header_bytes.data(), s->header_bytes.size(), s->stream_id, refinement, datagrams);
  s->live->OnDatagram(end.data(), end.size(), 0);
}

void ms_wasm_live_declare(ms_wasm_stream* s, uint32_t refinement) {
  if (s != nullptr && s->live) s->live->Declare(refinement);
}

int32_t ms_wasm_live_poll(ms_wasm_stream* s) {
  if (s == nullptr) return -1;
  if (!s->has_base || !s->live) return Fail(s, FailedPrecondition("live_poll: no base was set")), -1;
  auto n = s->live->Poll(0);
  if (!n.ok()) return Fail(s, n.status()), -1;
  return static_cast<int32_t>(s->live->applied());
}

int32_t ms_wasm_live_flush(ms_wasm_stream* s) {
  if (s == nullptr) return -1;
  if (!s->has_base || !s->live) return Fail(s, FailedPrecondition("live_flush: no base was set")), -1;
  const Status st = s->live->Flush();
  if (!st.ok()) return Fail(s, st), -1;
  return static_cast<int32_t>(s->live->applied());
}

int ms_wasm_live_snapshot(ms_wasm_stream* s) {
  if (s == nullptr) return 1;
  if (!s->has_base || !s->live) return Fail(s, FailedPrecondition("live_snapshot: no base was set"));
  s->live->reader().MeshInto(s->snapshot);
  Publish(s, s->live->reader(), s->snapshot);
  return 0;
}

}  // extern "C"
