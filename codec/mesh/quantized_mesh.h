// A triangle mesh on integer grids: what the progressive codec works on.
//
// Positions are on the position grid of the brief (quantization.h); every
// other attribute is a set of integer channels per vertex, in this order:
// NORMAL (2, octahedral), TEXCOORD_0.. (2 each), COLOR_0 (4). The codec treats
// channels alike (midpoint/difference transform), so lossless coding of
// positions and of attributes is the same code.
//
// Contract: pure. Quantize drops unreferenced vertices (the brief allows it)
// and keeps the order of the others. Dequantize(Quantize(p)) puts every value
// on its grid cell's centre.
#ifndef MESHSTREAM_CODEC_MESH_QUANTIZED_MESH_H_
#define MESHSTREAM_CODEC_MESH_QUANTIZED_MESH_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/mesh/quantization.h"
#include "codec/core/status.h"
#include "codec/core/vec.h"

namespace meshstream {

struct QuantizationParams {
  int qp = 11;  // position bits
  int qn = 8;   // normal bits (octahedral, per component)
  int qt = 10;  // texture coordinate bits
  int qc = 8;   // colour bits
};

// What the channels of a QuantizedMesh mean, and the grids to map them back.
struct AttributeLayout {
  bool has_normals = false;
  int texcoord_sets = 0;
  bool has_colors = false;
  std::vector<QuantizationGrid> texcoord_grids;
  QuantizationGrid color_grid;
  int qn = 8;

  int channels() const { return (has_normals ? 2 : 0) + 2 * texcoord_sets + (has_colors ? 4 : 0); }
  int normal_offset() const { return 0; }
  int texcoord_offset(int set) const { return (has_normals ? 2 : 0) + 2 * set; }
  int color_offset() const { return (has_normals ? 2 : 0) + 2 * texcoord_sets; }
};

struct QuantizedMesh {
  QuantizationGrid position_grid;
  AttributeLayout layout;
  std::vector<Vec3i> positions;
  std::vector<int32_t> attributes;  // layout.channels() per vertex
  std::vector<uint32_t> indices;    // three per triangle

  size_t vertex_count() const { return positions.size(); }
  size_t face_count() const { return indices.size() / 3; }
  const int32_t* attribute(size_t v) const { return attributes.data() + v * layout.channels(); }
};

StatusOr<QuantizedMesh> QuantizePrimitive(const Primitive& primitive, const QuantizationParams& params);
Primitive DequantizeMesh(const QuantizedMesh& mesh, int32_t material);
// The same from the arrays of a mesh held elsewhere (a decoder's state),
// without copying them into a QuantizedMesh first: `indices` holds
// `index_count` entries. DequantizeMesh(m, material) is
// DequantizeArrays(m.position_grid, m.layout, m.positions, m.attributes,
// m.indices.data(), m.indices.size(), material), bit for bit.
Primitive DequantizeArrays(const QuantizationGrid& position_grid, const AttributeLayout& layout,
                           const std::vector<Vec3i>& positions, const std::vector<int32_t>& attributes,
                           const uint32_t* indices, size_t index_count, int32_t material);

// Flat float arrays, one entry per vertex, tightly packed: xyz, normal xyz,
// TEXCOORD_0 uv, COLOR_0 rgba (a host's vertex buffers). Null: not wanted.
struct FlatVertexArrays {
  float* positions = nullptr;
  float* normals = nullptr;
  float* texcoords = nullptr;
  float* colors = nullptr;
};
// Vertices [first, first + count) of `mesh` (the caller checked the range)
// written at their own index into `out`'s arrays (each at least first + count
// entries), the same floats DequantizeMesh gives, bit for bit; an attribute
// the layout lacks is left alone.
void DequantizeVerticesInto(const QuantizedMesh& mesh, size_t first, size_t count, const FlatVertexArrays& out);

// Quantizes every vertex of `primitive` (unreferenced ones too, order kept)
// onto the grids of `grids` (its position grid and attribute layout). The
// primitive must have the attributes the layout names.
StatusOr<QuantizedMesh> QuantizeOnto(const Primitive& primitive, const QuantizedMesh& grids);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_QUANTIZED_MESH_H_
