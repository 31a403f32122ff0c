// Draco encoding and decoding of one triangle primitive, for glTF's
// KHR_draco_mesh_compression.
//
// Positions are put on the grid of the brief (codec/mesh/quantization.h): the
// encoder receives an explicit quantization with origin = minimum corner of
// the referenced vertices and range = their largest extent, so a decoded
// position dequantizes to the centre of the same grid cell that
// PositionGrid() gives. Faces with a repeated index are not encodable by
// Draco's edgebreaker and are dropped (they have no area; counted in
// DracoEncoded::dropped_faces).
//
// Contract: DecodeDracoPrimitive is safe on untrusted bytes (Draco's own
// checks plus ours on the decoded counts and attribute shapes). No exception
// escapes. Calls keep no state and may run in parallel.
// Never include draco/io/gltf_decoder.h here or in users of the renamed
// tinygltf namespace (docs/architecture.md, "The tinygltf/Draco trap").
#ifndef MESHSTREAM_IMPORTERS_DRACO_CODEC_H_
#define MESHSTREAM_IMPORTERS_DRACO_CODEC_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/mesh/quantization.h"
#include "codec/core/status.h"

namespace meshstream {

// Draco attribute unique ids per glTF semantic; -1 when absent.
struct DracoAttributeIds {
  int position = -1;
  int normal = -1;
  std::vector<int> texcoords;  // TEXCOORD_0, TEXCOORD_1, ...
  int color = -1;
};

// KHR_draco_mesh_compression's "attributes" object, both ways: the glTF
// semantic of each Draco attribute of `ids` (POSITION, NORMAL, TEXCOORD_n,
// COLOR_0; those at -1 left out), and the one entry `semantic` -> `id` set in
// `ids` (a semantic meshstream does not keep is ignored). InvalidInput
// "Draco attribute SEMANTIC" for a TEXCOORD_ without an index of 1 or 2 digits.
std::map<std::string, int> DracoAttributeNames(const DracoAttributeIds& ids);
Status AddDracoAttribute(const std::string& semantic, int id, DracoAttributeIds& ids);

struct DracoEncodeOptions {
  int qp = 11;  // position bits
  int qn = 8;   // normal bits
  int qt = 10;  // texture coordinate bits
  int qc = 8;   // colour bits
  int compression_level = 7;  // 0 (fastest) .. 10 (smallest), like draco_encoder -cl
  // Explicit grids (from a QuantizedMesh) instead of the primitive's own
  // bounding boxes; null means: positions on the primitive's brief grid,
  // texture coordinates and colours on Draco's own grids.
  const QuantizationGrid* position_grid = nullptr;
  const std::vector<QuantizationGrid>* texcoord_grids = nullptr;
  const QuantizationGrid* color_grid = nullptr;
  // -1: Draco chooses (edgebreaker for meshes); 0: sequential, which keeps the
  // vertex order; 1: edgebreaker.
  int encoding_method = -1;
};

struct DracoEncoded {
  std::vector<uint8_t> bytes;
  DracoAttributeIds ids;
  uint64_t dropped_faces = 0;
};

StatusOr<DracoEncoded> EncodeDracoPrimitive(const Primitive& primitive,
                                            const DracoEncodeOptions& options);

// Decodes a Draco mesh; `ids` says which Draco attribute is which glTF
// semantic (from the extension's "attributes" object).
StatusOr<Primitive> DecodeDracoPrimitive(const uint8_t* data, size_t size,
                                         const DracoAttributeIds& ids);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_DRACO_CODEC_H_
