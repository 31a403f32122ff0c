// Parity datagrams (docs/progressive-format.md, section 6.1): Reed-Solomon
// parity over a block of data datagrams that may span consecutive
// refinements of one stream, so that a receiver rebuilds lost datagrams
// without asking again (docs/loss-protection.md). The code's arithmetic is
// the caller's ErasureCode (codec/core/erasure_code.h).
//
// Layout after the datagram header (kind 4; refinement = the block's first
// refinement f, stride = the block's rows n = k + m, offset = this parity's
// row, count = k):
//   varint R                runs of members, 1 <= R <= k
//   R x { varint refinement delta (from f, then from the run before; the
//         first is 0), u8 kind (0, 1 or 2), varint first offset O,
//         varint length L >= 1 }  members (refinement, kind, O) .. (O + L - 1)
//   k x u16 (little endian)  each member's length in bytes (whole datagram)
//   rest                     the parity symbol: as long as the longest member
// Members are strictly increasing in (refinement, kind, offset), the order
// in which their symbols enter the code (rows 0..k-1); a member's symbol is
// its whole datagram, header included, zero-padded to the longest.
//
// Contract: ParityDatagram::Parse is safe on untrusted input (every count
// checked against the bytes present before anything is sized by it); the
// parsed view points into the datagram's bytes.
#ifndef MESHSTREAM_CODEC_LOSS_PARITY_H_
#define MESHSTREAM_CODEC_LOSS_PARITY_H_

#include <cstdint>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/erasure_code.h"
#include "codec/core/status.h"

namespace meshstream {

// A data datagram as a member of a parity block: (refinement, kind, offset)
// name it within its stream (the encoder's datagrams of one refinement and
// kind have distinct offsets), length is its size.
struct ParityMember {
  uint32_t refinement = 0;
  DatagramKind kind = DatagramKind::kBundled;
  uint32_t offset = 0;
  uint32_t length = 0;
  bool SameDatagram(const DatagramHeader& h, size_t size) const {
    return h.refinement == refinement && h.kind == kind && h.offset == offset && size == length;
  }
};
// The order of members in a block: (refinement, kind, offset).
bool MemberBefore(const ParityMember& a, const ParityMember& b);

struct ParityDatagram {
  uint8_t version = kStreamVersion;
  uint32_t stream = 0;
  uint32_t rows = 0;  // n = k + m as the sender planned the block
  uint32_t row = 0;   // this parity's row, k <= row < rows
  std::vector<ParityMember> members;  // k, in block order
  const uint8_t* symbol = nullptr;    // the parity symbol (into the datagram)
  size_t symbol_size = 0;             // the longest member's length

  uint32_t first_refinement() const { return members.empty() ? 0 : members.front().refinement; }
  uint32_t last_refinement() const { return members.empty() ? 0 : members.back().refinement; }
  // `d` must be a kind 4 datagram (DatagramHeader::Parse checked its header).
  static StatusOr<ParityDatagram> Parse(const ParsedDatagram& d);
};

// The bytes of a parity datagram: header, members and `symbol`
// (symbol_size bytes, the longest member's length).
std::vector<uint8_t> SerializeParity(uint8_t version, uint32_t stream, uint32_t rows, uint32_t row,
                                     const std::vector<ParityMember>& members, const uint8_t* symbol);

// The sender: parity rows [first_row, first_row + count) of the block made
// of `datagrams` (whole data datagrams of one stream, any order: they are
// put in block order; at most 255, no two naming the same member) for a
// block of `rows` rows. first_row >= k and first_row + count <= rows <= 256.
StatusOr<std::vector<std::vector<uint8_t>>> EncodeParity(ErasureCode& code, uint32_t stream,
                                                         const std::vector<const std::vector<uint8_t>*>& datagrams,
                                                         uint32_t rows, uint32_t first_row, uint32_t count);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PARITY_H_
