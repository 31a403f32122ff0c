#include "importers/draco_base_coder.h"

namespace meshstream {

StatusOr<QuantizedMesh> DecodeDracoBase(const uint8_t* data, size_t size, const DracoAttributeIds& ids,
                                        const QuantizedMesh& grids) {
  MS_ASSIGN_OR_RETURN(Primitive decoded, DecodeDracoPrimitive(data, size, ids));
  return QuantizeOnto(decoded, grids);
}

StatusOr<EncodedBase> EncodeDracoBase(const QuantizedMesh& base, int method, int compression_level,
                                      DracoAttributeIds* ids, Primitive* decoded_floats) {
  const Primitive floats = DequantizeMesh(base, -1);
  DracoEncodeOptions options;
  options.compression_level = compression_level;
  options.qn = base.layout.qn;
  options.position_grid = &base.position_grid;
  options.texcoord_grids = &base.layout.texcoord_grids;
  options.color_grid = base.layout.has_colors ? &base.layout.color_grid : nullptr;
  options.encoding_method = method == 0 ? 1 : 0;
  MS_ASSIGN_OR_RETURN(DracoEncoded encoded, EncodeDracoPrimitive(floats, options));
  if (encoded.dropped_faces != 0) return Internal("the base mesh has triangles that repeat a vertex");
  // Decode what we wrote, once: the decoder's order and values are what the
  // progressive encoder must build on.
  MS_ASSIGN_OR_RETURN(Primitive decoded, DecodeDracoPrimitive(encoded.bytes.data(), encoded.bytes.size(), encoded.ids));
  EncodedBase out;
  MS_ASSIGN_OR_RETURN(out.decoded, QuantizeOnto(decoded, base));
  out.bytes = std::move(encoded.bytes);
  if (ids) *ids = encoded.ids;
  if (decoded_floats) *decoded_floats = std::move(decoded);
  return out;
}

BaseMeshEncoder DracoBaseEncoder(int compression_level) {
  return [compression_level](const QuantizedMesh& base, int method) {
    return EncodeDracoBase(base, method, compression_level, nullptr);
  };
}

}  // namespace meshstream
