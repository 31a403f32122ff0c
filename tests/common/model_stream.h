// A shared model encoded as the benchmark encodes it (Draco coding the base
// at compression level 7), written in one packing, with its zero-loss decode
// through the same lossy-decode path a lossy run takes: for tests that
// compare decodes under loss with the lossless one.
#ifndef MESHSTREAM_TESTS_COMMON_MODEL_STREAM_H_
#define MESHSTREAM_TESTS_COMMON_MODEL_STREAM_H_

#include <string>

#include "codec/bitstream/writer.h"
#include "codec/loss/lossy_decode.h"
#include "codec/progressive/encoder.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

struct ModelStream {
  ProgressiveStream stream;
  QuantizedMesh base;       // as Draco decodes it (before fix-ups)
  QuantizedMesh lossless;   // every refinement decoded without loss
  size_t refinements = 0;
};

// `file` under the shared models; the first primitive of its first mesh.
inline StatusOr<ModelStream> EncodeModelStream(const std::string& file, const QuantizationParams& quantization,
                                               Packing packing) {
  MS_ASSIGN_OR_RETURN(Scene scene, ImportFile(ModelPath(file)));
  if (scene.meshes.empty() || scene.meshes[0].primitives.empty()) return InvalidInput(file + ": no primitive");
  ProgressiveEncodeOptions options;
  options.quantization = quantization;
  DracoAttributeIds ids;
  MS_ASSIGN_OR_RETURN(ProgressiveEncoded enc,
                      EncodeProgressive(scene.meshes[0].primitives[0], options, [&](const QuantizedMesh& base, int method) {
                        return EncodeDracoBase(base, method, 7, &ids);
                      }));
  StreamWriteOptions wo;
  wo.packing = packing;
  ModelStream m;
  MS_ASSIGN_OR_RETURN(m.stream, WriteStream(enc, quantization, wo));
  MS_ASSIGN_OR_RETURN(StreamReader reader, StreamReader::Create(m.stream.header.data(), m.stream.header.size(), 0));
  MS_ASSIGN_OR_RETURN(m.base, DecodeDracoBase(enc.base_bytes.data(), enc.base_bytes.size(), ids, reader.header().grids));
  m.refinements = m.stream.control.size();
  LossyDecodeOptions zero;  // no loss, reorder or duplication
  MS_ASSIGN_OR_RETURN(StreamReader done, DecodeStreamLossy(m.stream, 0, m.base, zero, nullptr));
  if (done.applied() != m.refinements) return Internal(file + ": the zero-loss decode stopped early");
  m.lossless = done.Mesh();
  return m;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_MODEL_STREAM_H_
