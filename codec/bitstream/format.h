// The progressive bitstream of one primitive (docs/spec/progressive-format.md):
// shared definitions of the stream writer (writer.h) and reader (reader.h),
// mirrored stages in the manner of Draco's prediction schemes.
//
// A stream has a reliable part (header with grids and counts, fix-ups of the
// base, and per refinement its split bits and static models) and an
// unreliable part (per refinement, datagrams of at most packet_bytes that
// each decode on their own given the reliable part). The base mesh itself is
// the single-rate coder's bytes (Draco), kept beside the stream.
//
// Contract: the parsers here (StreamHeader::Parse, ProgressiveStream::Parse,
// DatagramHeader::Parse)
// are safe on untrusted input: every field is checked against the bytes
// present and against the range the spec defines before anything it sizes
// is allocated, and a reserved or out-of-range value is refused with an
// error naming the field.
#ifndef MESHSTREAM_CODEC_BITSTREAM_FORMAT_H_
#define MESHSTREAM_CODEC_BITSTREAM_FORMAT_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/core/byte_io.h"
#include "codec/progressive/coding_tools.h"
#include "codec/mesh/quantized_mesh.h"
#include "codec/core/status.h"

namespace meshstream {

// Version 4 is what the encoder writes, in one of two profiles (Profile);
// version 1, 2 and 3 streams (and their datagrams) are still decoded: a
// version 3 stream is a version 4 stream of the loss-tolerant profile
// without the profile byte, a version 2 stream a version 3 stream whose
// tools fit one byte, a version 1 stream one without coding tools
// (docs/spec/progressive-format.md, section 10).
constexpr uint8_t kStreamVersion = 4;
constexpr uint8_t kOldestStreamVersion = 1;
constexpr uint8_t kDatagramMagic = 0x4D;  // 'M'
constexpr uint8_t kDatagramVersion = kStreamVersion;  // a datagram carries its stream's version

// Whether a blob, header or datagram of `version` is decoded; how errors
// name the versions that are.
constexpr bool IsStreamVersion(uint64_t version) {
  return version >= kOldestStreamVersion && version <= kStreamVersion;
}
constexpr const char* kStreamVersionsText = "1, 2, 3 or 4";

// The two profiles of version 4 (docs/spec/progressive-format.md, "Version 4").
// Loss-tolerant: the paper's rules (independent splits, split bits from the
// reliable graph, datagrams that decode on their own): what UDP sessions
// receive; every stream before version 4 is one. Reliable: for transports
// that lose nothing (files, HTTP ranges, WebSocket and gRPC-only sessions):
// a refinement's splits apply one after the other under the matching rule,
// their split bits in contexts of the whole coarser mesh, and their data in
// the control block with models adapted over the whole stream; no datagrams.
enum class Profile : uint8_t { kLossTolerant = 0, kReliable = 1 };
inline const char* ProfileName(Profile p) { return p == Profile::kReliable ? "reliable" : "loss-tolerant"; }

// The coding tools of a stream: codec/progressive/coding_tools.h.
constexpr uint32_t kMinPacketBytes = 64;
constexpr uint32_t kMaxPacketBytes = 65507;  // the largest UDP payload
constexpr uint32_t kWingAlphabet = 16;       // wings are indices below the maximum valence
constexpr uint32_t kMaxRefinements = 255;
constexpr uint64_t kMaxStreamVertices = uint64_t{1} << 28;
constexpr uint64_t kMaxBaseVertices = uint64_t{1} << 22;

enum class Packing : uint8_t {
  kSplit = 0,    // structure and geometry of a split in separate datagrams (the default)
  kBundled = 1,  // structure and geometry of a split in one fragment
};

enum class DatagramKind : uint8_t {
  kBundled = 0,    // structure then geometry of each split
  kStructure = 1,  // wings only
  kGeometry = 2,   // position and attribute differences only
  kEnd = 3,        // the sender's END of a refinement: count = its data datagrams, no payload
  kParity = 4,     // Reed-Solomon parity of a block of data datagrams (codec/loss/parity.h)
};

// A parity datagram's header fields (section 6.1 of the spec): refinement is
// the block's first refinement, stride its rows n = k + m (at most 256),
// offset this parity's row (k <= row < n) and count its k data members.
constexpr uint64_t kParityMaxRows = 256;

// The reliable header of a stream.
struct StreamHeader {
  uint8_t version = kStreamVersion;
  ToolSet tools = kAllTools;  // StreamTool bits: DefinedTools(version) at most
  bool has(StreamTool t) const { return (tools & t) != 0; }
  Packing packing = Packing::kSplit;
  Profile profile = Profile::kLossTolerant;  // version 4's byte; before it, loss-tolerant
  bool reliable() const { return profile == Profile::kReliable; }
  QuantizationParams quantization;
  QuantizedMesh grids;  // grids and layout only (no vertices)
  uint32_t base_vertices = 0;
  uint32_t base_faces = 0;
  uint8_t base_method = 0;
  std::vector<uint32_t> split_counts;  // per refinement
  // Written by the encoder; a parsed header keeps the coded blocks and
  // decodes them only once the base mesh has been seen (DecodeFixups), so a
  // lying vertex count cannot make it allocate what the stream does not hold.
  std::vector<int32_t> base_position_fix;
  std::vector<int32_t> base_attribute_fix;
  std::vector<uint8_t> position_fix_block;
  std::vector<uint8_t> attribute_fix_block;
  // With kToolSeams: the seam twins of the base mesh, (p, s) with p < s <
  // base_vertices, canonical ids (seam_twins.h). Checked for repeats when
  // the base is set (RefinementState::SetTwins).
  std::vector<std::array<uint32_t, 2>> seam_twins;

  // Fills base_position_fix and base_attribute_fix for `base_vertices`
  // vertices (the caller has checked that against the real base).
  Status DecodeFixups();

  void Serialize(ByteWriter& w) const;
  static StatusOr<StreamHeader> Parse(const uint8_t* data, size_t size);
  // Vertices at each level: [0] the base, [i + 1] after refinement i.
  std::vector<uint32_t> level_vertices() const;
};

// Everything of one primitive's stream except the base mesh bytes.
struct ProgressiveStream {
  uint8_t version = kStreamVersion;  // the blob's version byte (the header repeats it)
  std::vector<uint8_t> header;                                // StreamHeader
  std::vector<std::vector<uint8_t>> control;                  // per refinement: split bits + models
  std::vector<std::vector<std::vector<uint8_t>>> datagrams;   // per refinement

  size_t reliable_bytes() const;
  size_t unreliable_bytes() const;
  size_t datagram_count() const;
  // One blob: "MSPS", version, header, refinements with control and datagrams.
  std::vector<uint8_t> Serialize() const;
  static StatusOr<ProgressiveStream> Parse(const uint8_t* data, size_t size);
  // The header parsed (StreamHeader::Parse), refused unless it counts as
  // many refinements as the blob holds.
  StatusOr<StreamHeader> ParseHeader() const;
};

// The fixed part of a datagram, before its range-coded payload.
struct DatagramHeader {
  uint8_t version = kStreamVersion;  // 1, 2 or 3: must be its stream's (DatagramFits)
  DatagramKind kind = DatagramKind::kBundled;
  uint32_t stream = 0;      // primitive within the asset
  uint32_t refinement = 0;
  uint32_t stride = 1;      // the datagram carries ordinals offset, offset + stride, ...
  uint32_t offset = 0;
  uint32_t count = 0;

  void Serialize(ByteWriter& w) const;
  // Checks magic, version, kind and that offset < stride; the reader checks
  // the ordinals against the refinement's split count. An END has stride 1,
  // offset 0, any count (the refinement's data datagrams) and no payload. A
  // parity has 1 <= count < stride <= 256 and count <= offset < stride; its
  // payload is parsed by ParityDatagram::Parse (codec/loss/parity.h).
  static StatusOr<DatagramHeader> Parse(ByteReader& r);
};

// A datagram whose header has been read, once (DatagramHeader::Parse): the
// header and the bytes it was read from, so that the receiver's layers
// (session, reconstructor, reader) share one parse. Made only by Parse, so a
// header always satisfies Parse's checks and describes `data`; the stream's
// own checks (DatagramFits, the stream id) are still each layer's.
// Not owning: `data` must outlive the view.
class ParsedDatagram {
 public:
  static StatusOr<ParsedDatagram> Parse(const uint8_t* data, size_t size);
  const DatagramHeader& header() const { return header_; }
  const uint8_t* data() const { return data_; }  // the whole datagram
  size_t size() const { return size_; }
  const uint8_t* payload() const { return data_ + payload_offset_; }  // after the header
  size_t payload_size() const { return size_ - payload_offset_; }
  // The same datagram over `copy`, a byte-identical copy of data() that the
  // caller owns (a receiver that buffers it).
  ParsedDatagram Over(const uint8_t* copy) const;

 private:
  ParsedDatagram() = default;
  DatagramHeader header_;
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  size_t payload_offset_ = 0;
};

// Whether a data datagram (not an END) fits a stream: its kind matches the
// packing and its ordinals lie below the split count of its refinement
// (which must exist); never in the reliable profile, which has none. Stream number and timing are the receiver's business.
bool DatagramFits(const DatagramHeader& h, const StreamHeader& header);

// The END datagram the sender puts on the unreliable channel after the data
// datagrams of a refinement (docs/spec/progressive-format.md, section 6).
std::vector<uint8_t> MakeEndDatagram(uint32_t stream, uint32_t refinement, uint32_t datagrams,
                                     uint8_t version = kStreamVersion);

// The END of refinement `refinement` of the stream whose header is
// `stream_header` (its bytes as the artifact and SessionStart carry them):
// the one form of a session's END, whether the server sends it as a datagram
// or the client rebuilds it from RefinementEnd or for a repair. It carries
// the stream's version, the header's first byte (docs/spec/progressive-format.md,
// sections 3 and 6; kStreamVersion for an empty header, which no reader
// accepts anyway). Safe on any header bytes: only the first is read.
std::vector<uint8_t> MakeStreamEndDatagram(const uint8_t* stream_header, size_t header_size, uint32_t stream,
                                           uint32_t refinement, uint32_t datagrams);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_BITSTREAM_FORMAT_H_
