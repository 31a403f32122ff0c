// Writes a ProgressiveEncoded mesh as a progressive stream: entropy coding of
// the reliable part (split bits with contexts, static models) and
// packetization of structure and geometry into datagrams (paper, 4.2; docs/design/design.md,
// "Independent datagrams").
//
// Interleaving: the splits of a refinement are dealt round-robin to its D
// datagrams (split j goes to datagram j mod D), so a datagram carries splits
// D ordinals apart; splits are ordered by the canonical id of their vertex,
// which follows the base coder's traversal, so neighbours on the surface land
// in different datagrams. D is the smallest count for which every datagram
// fits in packet_bytes.
//
// Contract: pure. Fails with InvalidArgument when packet_bytes is outside
// [kMinPacketBytes, kMaxPacketBytes].
#ifndef MESHSTREAM_CODEC_BITSTREAM_WRITER_H_
#define MESHSTREAM_CODEC_BITSTREAM_WRITER_H_

#include <cstdint>

#include "codec/progressive/encoder.h"
#include "codec/bitstream/format.h"

namespace meshstream {

struct StreamWriteOptions {
  Packing packing = Packing::kSplit;
  uint32_t packet_bytes = 1200;  // payload bytes of a datagram, header included
  uint32_t stream_id = 0;        // the primitive's index in the asset
  uint8_t version = kStreamVersion;  // 1, 2 or 3 write the older formats (with the tools they define: none in 1)
  // Version 4's profile (format.h): kReliable needs a hierarchy of the
  // matching rule (BatchRule::kMatching), kLossTolerant one of the strict rule.
  Profile profile = Profile::kLossTolerant;
  ToolSet tools = kAllTools;         // StreamTool bits (coding_tools.h)
  // With the ring predictor: a refinement uses its 2-ring term only where it
  // saves at least this many bits per split (estimated), because it costs
  // the decoder a walk over the faces of the ring (docs/design/codec.md, "The ring
  // predictor": about 0.3 % of the bunny's bytes for about 15 % more decode
  // instructions). 0: wherever it saves anything.
  double ring_term_bits = 0.5;
};

// The tools a stream of this quantization and layout is written
// with when `requested` are asked for: without the local frame above qp 24
// (its rotation is exact below 2^28), without texture coordinate prediction
// when there are neither texture coordinates nor colours. (WriteStream may
// still drop the wing rank, for a ring beyond kMaxRankedValence.)
ToolSet ApplicableTools(ToolSet requested, const QuantizationParams& quantization, const AttributeLayout& layout);

StatusOr<ProgressiveStream> WriteStream(const ProgressiveEncoded& encoded, const QuantizationParams& quantization,
                                        const StreamWriteOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_BITSTREAM_WRITER_H_
