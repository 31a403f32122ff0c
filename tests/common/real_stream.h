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
#include "tests/common/test_util.h"

namespace meshstream::test_util {

constexpr uint32_t kRealStreamId = 3;

struct RealStream {
  ProgressiveStream stream;
  QuantizedMesh base;                 // as Draco decodes it (before fix-ups)
  std::vector<QuantizedMesh> levels;  // [i]: after i refinements, decoded without loss
  std::vector<uint32_t> level_vertices;
};

// `tools`: the version 2 tools to write with (as `meshstream encode --tools`).
inline RealStream BuildRealStream(uint8_t tools = kAllTools) {
  auto fail = [](const std::string& what) {
    std::fprintf(stderr, "real stream: %s\n", what.c_str());
    std::abort();
  };
  auto scene = ImportFile(ModelPath("fandisk.obj"));
  if (!scene.ok()) fail(scene.status().ToString());
  ProgressiveEncodeOptions options;
  DracoAttributeIds ids;
  auto enc = EncodeProgressive(scene->meshes[0].primitives[0], options, [&](const QuantizedMesh& base, int method) {
    return EncodeDracoBase(base, method, 7, &ids);
  });
  if (!enc.ok()) fail(enc.status().ToString());
  StreamWriteOptions wo;
  wo.packet_bytes = 200;
  wo.stream_id = kRealStreamId;
  wo.tools = tools;
  auto stream = WriteStream(enc.value(), options.quantization, wo);
  if (!stream.ok()) fail(stream.status().ToString());
  RealStream r;
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
