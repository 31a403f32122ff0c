// A real progressive stream for the reconstructor and lossy-decode tests:
// fandisk (the shared model) encoded with Draco coding the base, written in
// split packing with small datagrams (several per refinement) as stream 3,
// and its lossless decode level by level through StreamReader.
#ifndef MESHSTREAM_TESTS_COMMON_REAL_STREAM_H_
#define MESHSTREAM_TESTS_COMMON_REAL_STREAM_H_

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "codec/progressive/encoder.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

constexpr uint32_t kRealStreamId = 3;

struct RealStream {
  ProgressiveStream stream;
  QuantizedMesh base;                 // as Draco decodes it (before fix-ups)
  std::vector<QuantizedMesh> levels;  // [i]: after i refinements, decoded without loss
  std::vector<uint32_t> level_vertices;
  size_t encoded_base_vertices = 0;
  size_t base_bytes = 0;  // Draco's
  size_t seam_pairs = 0;  // seam twins of the base
};

// `tools`: the version 2 tools to write with (as `meshstream encode --tools`).
// `model`: a shared model (fandisk by default); `packing`, `packet_bytes`:
// as `meshstream encode`. Seams collapse when `tools` has the seams tool.
inline RealStream BuildRealStream(ToolSet tools = kAllTools, const std::string& model = "fandisk.obj",
                                  Packing packing = Packing::kSplit, uint32_t packet_bytes = 200,
                                  double ring_term_bits = StreamWriteOptions().ring_term_bits) {
  auto fail = [](const std::string& what) {
    std::fprintf(stderr, "real stream: %s\n", what.c_str());
    std::abort();
  };
  auto scene = ImportFile(ModelPath(model));
  if (!scene.ok()) fail(scene.status().ToString());
  ProgressiveEncodeOptions options;
  options.simplify.collapse_seams = (tools & kToolSeams) != 0;
  DracoAttributeIds ids;
  auto enc = EncodeProgressive(scene->meshes[0].primitives[0], options, [&](const QuantizedMesh& base, int method) {
    return EncodeDracoBase(base, method, 7, &ids);
  });
  if (!enc.ok()) fail(enc.status().ToString());
  StreamWriteOptions wo;
  wo.packet_bytes = packet_bytes;
  wo.packing = packing;
  wo.stream_id = kRealStreamId;
  wo.tools = tools;
  wo.ring_term_bits = ring_term_bits;
  auto stream = WriteStream(enc.value(), options.quantization, wo);
  if (!stream.ok()) fail(stream.status().ToString());
  RealStream r;
  r.encoded_base_vertices = enc->mesh.base.vertex_count();
  r.base_bytes = enc->base_bytes.size();
  r.seam_pairs = enc->mesh.base_twins.size();
  r.stream = std::move(stream).value();
  auto reader = StreamReader::Create(r.stream.header.data(), r.stream.header.size(), kRealStreamId);
  if (!reader.ok()) fail(reader.status().ToString());
  auto base = DecodeDracoBase(enc->base_bytes.data(), enc->base_bytes.size(), ids, reader->header().grids);
  if (!base.ok()) fail(base.status().ToString());
  r.base = base.value();
  r.level_vertices = reader->header().level_vertices();
  if (!reader->SetBase(std::move(base).value()).ok()) fail("base");
  r.levels.push_back(reader->Mesh());
  for (size_t i = 0; i < r.stream.control.size(); ++i) {
    if (!reader->BeginRefinement(r.stream.control[i].data(), r.stream.control[i].size()).ok()) fail("begin");
    for (const auto& d : r.stream.datagrams[i])
      if (!reader->OfferDatagram(d.data(), d.size())) fail("a real datagram was refused");
    if (!reader->FinishRefinement().ok()) fail("finish");
    r.levels.push_back(reader->Mesh());
  }
  return r;
}

inline const RealStream& Fandisk() {
  static const RealStream s = BuildRealStream();
  return s;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_REAL_STREAM_H_
