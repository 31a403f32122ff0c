// The progressive encoder: quantize, simplify in batches, code the base mesh
// with a caller-supplied single-rate coder (Draco, in importers/), take the
// canonical order from that coder's *decoded* output, then replay the
// refinements exactly as the decoder will and record split bits, structure
// and geometry (progressive_mesh.h).
//
// Contract: pure (the base coder is a callback). The result is verified
// before it is returned: replaying it gives back every triangle of the
// quantized input (up to vertex order) and every vertex's values, or the
// encoder fails with kInternal. The encoder gives the input's arrays to the
// simplifier, so the verification compares fingerprints of the input taken
// first (128-bit sums of hashes of triangles and of vertex records: a wrong
// replay passes with a probability of about 2^-128).
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_ENCODER_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_ENCODER_H_

#include <cstdint>
#include <functional>
#include <vector>

#include "codec/progressive/batch_simplifier.h"
#include "codec/progressive/refinement.h"
#include "codec/mesh/quantized_mesh.h"
#include "codec/core/status.h"

namespace meshstream {

// What a single-rate coder returns for the base mesh: its bytes, and the mesh
// as its decoder will return it (values on our grids, the decoder's vertex
// order). `method` 0 is the preferred method; higher values are fallbacks
// that must keep vertices distinguishable (e.g. an order-preserving one).
struct EncodedBase {
  std::vector<uint8_t> bytes;
  QuantizedMesh decoded;
};
using BaseMeshEncoder = std::function<StatusOr<EncodedBase>(const QuantizedMesh& base, int method)>;
constexpr int kBaseMethods = 2;

struct ProgressiveEncodeOptions {
  QuantizationParams quantization;
  SimplifyOptions simplify;
};

struct ProgressiveEncoded {
  ProgressiveMesh mesh;            // base in canonical order, refinements coarse to fine
  std::vector<uint8_t> base_bytes; // the single-rate coding of the base
  int base_method = 0;
  // Per base vertex and channel: true value minus what the base decoder
  // returns (nonzero only where the single-rate coder does not land exactly
  // on our grids; sent on the reliable channel).
  std::vector<int32_t> base_position_fix;  // 3 per base vertex
  std::vector<int32_t> base_attribute_fix; // channels per base vertex
  uint64_t input_vertices = 0;   // referenced
  uint64_t input_faces = 0;      // after clean-up
  uint64_t removed_faces = 0;
  uint64_t locked_vertices = 0;
  // Per level, the error it leaves (progressive/residual_error.h), grid units.
  std::vector<double> residual_error;
};

StatusOr<ProgressiveEncoded> EncodeProgressive(const Primitive& input, const ProgressiveEncodeOptions& options,
                                               const BaseMeshEncoder& base_encoder);

// Same, from an already quantized mesh: pass std::move(input) to give up its
// arrays (the encoder works in them; EncodeProgressive does), or a copy.
StatusOr<ProgressiveEncoded> EncodeProgressiveQuantized(QuantizedMesh input, const ProgressiveEncodeOptions& options,
                                                        const BaseMeshEncoder& base_encoder);

// Multiset equality of oriented triangles (corners rotated, not reversed).
bool SameTriangles(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_ENCODER_H_
