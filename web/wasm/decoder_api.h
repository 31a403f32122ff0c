// The progressive decoder for the browser and node (codec/ compiled to
// WebAssembly, docs/web.md): one primitive's stream blob, its base as Draco
// decoded it (floats per point, as draco3d's GetAttributeFloatForAllPoints
// gives them), decoded through the same path as the native
// DecodeProgressiveGlb (QuantizeOnto, DecodeStreamLossy), and the result as
// float arrays.
//
// Contract: safe on untrusted bytes (the codec's parsers check everything; a
// failure is a non-zero return and ms_wasm_error() says what and where).
// Pointers returned stay valid until the next call on the same stream.
// Thread safety: one stream per thread.
#ifndef MESHSTREAM_WEB_WASM_DECODER_API_H_
#define MESHSTREAM_WEB_WASM_DECODER_API_H_

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ms_wasm_stream ms_wasm_stream;

// Parses a stream blob (docs/progressive-format.md section 2); `stream_id` is
// the stream's position among the file's streams (it seeds the simulated
// loss as in the native decoder). Null only when out of memory; a blob that
// does not parse gives a stream whose ms_wasm_error() is set.
ms_wasm_stream* ms_wasm_open(const uint8_t* blob, uint32_t size, uint32_t stream_id);
void ms_wasm_close(ms_wasm_stream* s);
// The last error, "" when none.
const char* ms_wasm_error(const ms_wasm_stream* s);
uint32_t ms_wasm_refinements(const ms_wasm_stream* s);

// The base as Draco decoded it: `vertices` points; normals and colours may be
// null; texcoords holds `texcoord_sets` sets of 2 floats per point, one set
// after the other. 0 on success.
int ms_wasm_set_base(ms_wasm_stream* s, uint32_t vertices, const float* positions, const float* normals,
                     uint32_t texcoord_sets, const float* texcoords, const float* colors, uint32_t index_count,
                     const uint32_t* indices);

// Decodes `lod` refinements (-1: all) across a simulated link losing `loss`
// of the datagrams (bursts of mean length `burst`, seed `seed` + stream id,
// as `meshstream decode --loss --burst --seed`); `reliable` lists the
// refinements whose datagrams travel reliably (the file's delivery record).
// 0 on success.
int ms_wasm_decode(ms_wasm_stream* s, int32_t lod, double loss, double burst, uint32_t seed, const uint32_t* reliable,
                   uint32_t reliable_count);

// The decoded mesh (after ms_wasm_decode).
uint32_t ms_wasm_vertex_count(const ms_wasm_stream* s);
uint32_t ms_wasm_index_count(const ms_wasm_stream* s);
uint32_t ms_wasm_texcoord_sets(const ms_wasm_stream* s);
const float* ms_wasm_positions(const ms_wasm_stream* s);          // 3 per vertex
const float* ms_wasm_normals(const ms_wasm_stream* s);            // 3 per vertex or null
const float* ms_wasm_texcoords(const ms_wasm_stream* s, uint32_t set);  // 2 per vertex or null
const float* ms_wasm_colors(const ms_wasm_stream* s);             // 4 per vertex or null
const uint32_t* ms_wasm_indices(const ms_wasm_stream* s);
uint32_t ms_wasm_predicted_vertices(const ms_wasm_stream* s);
// PrimitiveHash (codec/mesh/mesh.h) of the decoded mesh, as 16 hexadecimal
// digits.
const char* ms_wasm_hash(const ms_wasm_stream* s);

#ifdef __cplusplus
}
#endif

#endif  // MESHSTREAM_WEB_WASM_DECODER_API_H_
