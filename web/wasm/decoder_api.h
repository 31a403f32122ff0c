// The progressive decoder for the browser and node (codec/ compiled to
// WebAssembly, docs/design/web.md): one primitive's stream blob, its base as Draco
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

// Parses a stream blob (docs/spec/progressive-format.md section 2); `stream_id` is
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
// Per vertex of the decoded mesh: 1 when its position is exact, 0 when a
// prediction placed it or one of its neighbours (the reader's reliability
// bits); null before a decode.
const uint8_t* ms_wasm_reliable(const ms_wasm_stream* s);

// Runs the decoder once on a mesh of its own (a sphere of about 2,500
// vertices, encoded here and decoded three times), so that the engine has
// compiled the decoder's hot code before the first real stream: a fresh
// module otherwise decodes its first stream several times slower (docs/design/web.md,
// "Warming the decoder"). Returns the vertices of the decoded sphere (0 on
// an error).
uint32_t ms_wasm_warm_up(void);

// --- Live decoding: the refinements as they arrive ---------------------------
// The same stream fed piece by piece, as a session's messages (SessionStart's
// header and base, ControlBlocks, datagrams; docs/spec/streaming-protocol.md) or a
// file read by HTTP ranges (the blob's header, then each refinement's control
// block, datagrams and an END made from the count the blob gives) deliver it,
// through codec's StreamReconstructor. Both transports are reliable, so the
// reconstructor's clock never runs out: a refinement is decoded when its
// control block, its END and every datagram the END announces have arrived
// (or at ms_wasm_live_flush, with what arrived: predictions fill the rest).
// After each call that decodes, ms_wasm_live_snapshot puts the current mesh
// where the accessors above read it.

// `header`: the stream header (PrimitiveStart.header, or the blob's header
// block); `lod`: refinements to decode, -1 all. Null only when out of memory;
// a header that does not parse gives a stream whose ms_wasm_error() is set.
ms_wasm_stream* ms_wasm_live_open(const uint8_t* header, uint32_t size, uint32_t stream_id, int32_t lod);
// The header's counts: vertices of the base, and of the mesh once every
// refinement is applied (the base's plus one per split).
uint32_t ms_wasm_live_base_vertices(const ms_wasm_stream* s);
uint32_t ms_wasm_live_final_vertices(const ms_wasm_stream* s);
// Splits of refinement `refinement` (0 past the last).
uint32_t ms_wasm_live_splits(const ms_wasm_stream* s, uint32_t refinement);
// The base, as for ms_wasm_set_base. 0 on success.
int ms_wasm_live_set_base(ms_wasm_stream* s, uint32_t vertices, const float* positions, const float* normals,
                          uint32_t texcoord_sets, const float* texcoords, const float* colors, uint32_t index_count,
                          const uint32_t* indices);
// The next refinement's control block (in order). 0 on success.
int ms_wasm_live_control(ms_wasm_stream* s, const uint8_t* control, uint32_t size);
// A datagram, data or END (any order; duplicates and bad ones are dropped
// and counted by the reconstructor).
void ms_wasm_live_datagram(ms_wasm_stream* s, const uint8_t* data, uint32_t size);
// The END of `refinement` announcing `datagrams` data datagrams, made here
// (a file holds no END; a session's RefinementEnd names the count).
void ms_wasm_live_end(ms_wasm_stream* s, uint32_t refinement, uint32_t datagrams);
// What of `refinement` has not arrived will not (a viewer's simulated loss,
// or a session that knows it lost datagrams): it is decoded once its control
// block is in, predictions filling the rest.
void ms_wasm_live_declare(ms_wasm_stream* s, uint32_t refinement);
// Decodes every refinement that is ready; returns the refinements applied
// so far, or -1 on an error (ms_wasm_error()).
int32_t ms_wasm_live_poll(ms_wasm_stream* s);
// The stream is over: decodes every refinement whose control block arrived.
int32_t ms_wasm_live_flush(ms_wasm_stream* s);
// The current mesh (base and refinements applied) dequantized for the
// accessors above. 0 on success.
int ms_wasm_live_snapshot(ms_wasm_stream* s);

#ifdef __cplusplus
}
#endif

#endif  // MESHSTREAM_WEB_WASM_DECODER_API_H_
