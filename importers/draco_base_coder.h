// Draco as the single-rate coder of the progressive codec's base mesh
// (codec/progressive/encoder.h, BaseMeshEncoder).
//
// Positions, texture coordinates and colours use Draco's explicit
// quantization with exactly our grids, so the decoded values requantize to
// the same integers; normals use Draco's own octahedral quantization at --qn
// bits, and the few values that do not requantize exactly are carried as
// fix-ups by the progressive stream. Method 0 is edgebreaker, method 1 the
// order-preserving sequential coder (used when coincident vertices of the
// base cannot be told apart after edgebreaker reorders them).
//
// Contract: DecodeDracoBase is safe on untrusted input (the bytes come from a
// progressive file or the network): Draco's decoder checks its own framing,
// the decoded values are requantized onto `grids` (QuantizeOnto refuses what
// does not fit them), and StreamReader::SetBase checks the result against
// the header's counts before it is used. Thread safety: no shared state.
#ifndef MESHSTREAM_IMPORTERS_DRACO_BASE_CODER_H_
#define MESHSTREAM_IMPORTERS_DRACO_BASE_CODER_H_

#include <cstdint>
#include <vector>

#include "codec/progressive/encoder.h"
#include "codec/mesh/quantized_mesh.h"
#include "importers/draco_codec.h"

namespace meshstream {

BaseMeshEncoder DracoBaseEncoder(int compression_level);

// Encodes; also returns, when asked, the Draco attribute ids and the base as
// Draco decodes it to floats (both for the glTF primitive).
StatusOr<EncodedBase> EncodeDracoBase(const QuantizedMesh& base, int method, int compression_level,
                                      DracoAttributeIds* ids, Primitive* decoded_floats = nullptr);

// Decodes a base mesh onto the grids and layout of `grids`.
StatusOr<QuantizedMesh> DecodeDracoBase(const uint8_t* data, size_t size, const DracoAttributeIds& ids,
                                        const QuantizedMesh& grids);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_DRACO_BASE_CODER_H_
