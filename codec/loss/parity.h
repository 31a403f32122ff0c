// Parity datagrams (docs/spec/progressive-format.md, section 6.1): Reed-Solomon
// parity over a block of data datagrams that may span consecutive
// refinements of one stream, so that a receiver rebuilds lost datagrams
// without asking again (docs/design/loss-protection.md). The code's arithmetic is
// the caller's ErasureCode (codec/core/erasure_code.h).
//
// Symbols: the block's members in block order, each cut into symbols of S
// bytes (its last zero-padded): data rows 0..k-1. A member of L bytes is
// ceil(L / S) rows, so datagrams of unequal lengths cost parity in proportion
// to their bytes, not to the longest (no padding beyond each member's last
// symbol). Parity rows k..n-1 are the code's; a parity datagram carries one
// or more consecutive parity rows.
//
// Layout after the datagram header (kind 4; refinement = the block's first
// refinement f, stride = the block's rows n <= 256, offset = the first
// parity row it carries, count = k):
//   varint S                 symbol bytes, 1..65507
//   varint c                 parity rows carried, offset + c <= n
//   varint R                 runs of members, 1 <= R
//   R x { varint refinement delta (from f, then from the run before; the
//         first is 0), u8 kind (0, 1 or 2), varint first offset O,
//         varint length L >= 1 }  members (refinement, kind, O) .. (O + L - 1)
//   M x u16 (little endian)  each member's length in bytes (whole datagram);
//                            the members' ceil(length / S) add up to k
//   c x S bytes              parity rows offset .. offset + c - 1
// Members are strictly increasing in (refinement, kind, offset); a member's
// symbols are its whole datagram, header included.
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
// Data rows of a member of `length` bytes with symbols of `symbol` bytes.
inline uint64_t SymbolsOf(uint64_t length, uint64_t symbol) { return (length + symbol - 1) / symbol; }

struct ParityDatagram {
  uint8_t version = kStreamVersion;
  uint32_t stream = 0;
  uint32_t rows = 0;        // n, the block's rows as the sender planned them
  uint32_t first_row = 0;   // the first parity row carried (>= k)
  uint32_t count = 0;       // parity rows carried
  uint32_t k = 0;           // data rows
  uint32_t symbol_size = 0; // S
  std::vector<ParityMember> members;  // in block order
  const uint8_t* symbols = nullptr;   // count x S bytes (into the datagram)

  uint32_t first_refinement() const { return members.empty() ? 0 : members.front().refinement; }
  uint32_t last_refinement() const { return members.empty() ? 0 : members.back().refinement; }
  // `d` must be a kind 4 datagram (DatagramHeader::Parse checked its header).
  static StatusOr<ParityDatagram> Parse(const ParsedDatagram& d);
};

// How a sender codes one block.
struct ParityShape {
  uint32_t symbol_size = 0;  // S
  uint32_t k = 0;            // data rows
  uint32_t m = 0;            // parity rows
  uint32_t per_datagram = 0; // parity rows per parity datagram (the last may carry fewer)
  uint32_t datagrams() const { return per_datagram == 0 ? 0 : (m + per_datagram - 1) / per_datagram; }
};

// The symbol size for members of `lengths` bytes: the smallest S that keeps
// the data rows at most `max_k` (and S at most the longest member).
uint32_t SymbolSizeFor(const std::vector<uint32_t>& lengths, uint32_t max_k);
// Parity rows per datagram so that one fits `packet_bytes` with its header
// (an estimate from the member count; at least 1).
uint32_t RowsPerDatagram(uint32_t symbol_size, size_t members, uint32_t packet_bytes);

// The sender: the parity datagrams of the block made of `datagrams` (whole
// data datagrams of one stream, any order: they are put in block order; no
// two naming the same member) with shape.symbol_size; `shape.k` must be
// their data rows and k + m <= 256.
StatusOr<std::vector<std::vector<uint8_t>>> EncodeParity(ErasureCode& code, uint32_t stream,
                                                         const std::vector<const std::vector<uint8_t>*>& datagrams,
                                                         const ParityShape& shape);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PARITY_H_
