// Where each primitive's base mesh and progressive stream sit inside a
// progressive .glb (importers/progressive_glb.h; docs/spec/progressive-format.md
// sections 1-2), so that a streaming session sends them straight from the
// artifact's bytes, without decoding any mesh. The layout is computed once,
// when the artifact is made, and stored as JSON with the version
// (ArtifactSummary::layout_json; the format is in docs/design/pipeline.md).
//
// Offsets are absolute byte offsets inside the .glb file.
//
// Contract: ComputeStreamLayout and LocateStreamBlocks are safe on untrusted
// bytes (the GLB framing, the glTF JSON and the stream blob are checked
// before anything they size is used); ParseStreamLayout is safe on untrusted
// text (every field's type, range and consistency is checked). None throws.
// Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_PIPELINE_STREAM_LAYOUT_H_
#define MESHSTREAM_SERVICES_PIPELINE_STREAM_LAYOUT_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/status.h"
#include "codec/loss/reliable_cut.h"

namespace meshstream {

constexpr int kStreamLayoutVersion = 1;

struct ByteRange {
  uint64_t offset = 0;
  uint64_t length = 0;
  bool operator==(const ByteRange& o) const { return offset == o.offset && length == o.length; }
};

// One stream: a refined primitive of the file.
struct PrimitiveLayout {
  uint32_t mesh = 0;       // index in the glTF "meshes"
  uint32_t primitive = 0;  // index in that mesh's "primitives" (file order)
  uint32_t stream = 0;     // the stream number in its datagram headers
  ByteRange base;          // the base mesh's Draco bytes (KHR_draco_mesh_compression)
  ByteRange stream_blob;   // the MSPS ProgressiveStream blob (MESHSTREAM_progressive)
  // The reliable profile's blob beside it (MESHSTREAM_progressive's
  // "reliable", format version 4): the same refinements and split counts, no
  // datagrams. Length 0: the file has none (a file of one profile, or an
  // artifact stored before version 4); then stream_blob is the only one.
  ByteRange reliable_blob;
  uint64_t reliable_profile_bytes = 0;  // its header and control blocks
  bool has_reliable() const { return reliable_blob.length > 0; }
  QuantizationParams quantization;
  Packing packing = Packing::kSplit;
  uint32_t refinements = 0;
  std::vector<uint32_t> split_counts;     // per refinement
  std::vector<uint32_t> datagram_counts;  // per refinement
  std::vector<uint32_t> level_vertices;   // refinements + 1 entries: the base, then after each
  uint64_t reliable_bytes = 0;    // header and control blocks (the base excluded, as PrimitiveStreamReport)
  uint64_t unreliable_bytes = 0;  // the datagrams
  // The reliable cut (codec/loss/reliable_cut.h), from the primitive's
  // MESHSTREAM_progressive "delivery"; empty when the file has none
  // (artifacts made before it): every datagram goes as UDP.
  DeliveryRecord delivery;
  // The error left at each level (refinements + 1 entries, scene units), from
  // MESHSTREAM_progressive "residual_error"; empty when the file has none: the
  // scene's levels are then one refinement per primitive
  // (codec/progressive/scene_levels.h).
  std::vector<double> residual_error;
};

struct StreamLayout {
  uint64_t file_bytes = 0;  // of the .glb
  std::vector<PrimitiveLayout> primitives;  // in stream order
  // The most refinements any stream has (the artifact's level count).
  uint32_t levels() const;
};

// Reads the layout from a progressive .glb: the GLB chunks, the glTF JSON
// (each primitive's two extensions and their bufferViews), and for each
// stream its blob's framing and header (ProgressiveStream::Parse,
// StreamHeader::Parse). A file without refined primitives has an empty layout.
StatusOr<StreamLayout> ComputeStreamLayout(const uint8_t* glb, size_t size);

// One line of JSON (docs/design/pipeline.md, "Stream layout").
std::string StreamLayoutJson(const StreamLayout& layout);
// The inverse, on untrusted text: InvalidInput naming the field that is
// missing, of the wrong type, out of range or inconsistent.
StatusOr<StreamLayout> ParseStreamLayout(const std::string& json);

// The blocks of one stream, as absolute ranges inside the .glb: what a
// session sends on the reliable channel (base, header, control[i]) and on
// the unreliable one (datagrams[i][d]).
struct StreamBlocks {
  ByteRange base;
  ByteRange header;
  std::vector<ByteRange> control;                 // per refinement
  std::vector<std::vector<ByteRange>> datagrams;  // per refinement
};

// Parses only the MSPS framing of `entry`'s blob (no mesh, no header
// decoding) and returns where every block lies: of its reliable profile's
// blob with `reliable` (which the entry must have; it has no datagrams),
// else of stream_blob. InvalidInput when the ranges leave the file or the
// blob is malformed; DataLoss when the blob's counts differ from the
// layout's (the layout belongs to another artifact).
StatusOr<StreamBlocks> LocateStreamBlocks(const uint8_t* glb, size_t size, const PrimitiveLayout& entry,
                                          bool reliable = false);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_PIPELINE_STREAM_LAYOUT_H_
