// The receiver's half of parity datagrams (codec/loss/parity.h): keeps a
// copy of every data datagram of a stream's recent refinements, gathers the
// parity of each block, and rebuilds a block's lost members as soon as k of
// its n rows are in (docs/design/loss-protection.md, "Receiving"). The stream
// reconstructor owns one and hands what it rebuilds back to itself as
// arrivals.
//
// Contract: no clocks or threads. Safe on hostile datagrams: a parity is
// parsed (ParityDatagram::Parse) before anything is stored; a rebuilt
// datagram is returned only when its header names the member it was rebuilt
// as (else the block is dropped and counted as inconsistent). Memory is
// bounded: copies and parity symbols together at most `max_bytes` (each
// charged 64 bytes besides its size); what does not fit is dropped and
// counted. Thread safety: none.
#ifndef MESHSTREAM_CODEC_LOSS_PARITY_RECOVERY_H_
#define MESHSTREAM_CODEC_LOSS_PARITY_RECOVERY_H_

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/erasure_code.h"
#include "codec/loss/parity.h"

namespace meshstream {

struct ParityStats {
  uint64_t parity = 0;        // parity datagrams offered
  uint64_t rejected = 0;      // malformed, or naming another stream
  uint64_t late = 0;          // for a block older than the horizon, or already whole
  uint64_t recovered = 0;     // data datagrams rebuilt
  uint64_t inconsistent = 0;  // blocks whose rebuild did not give back their members
  uint64_t overflow = 0;      // copies or symbols beyond max_bytes
};

class ParityRecovery {
 public:
  ParityRecovery(ErasureCode* code, uint32_t stream, size_t max_bytes)
      : code_(code), stream_(stream), max_bytes_(max_bytes) {}

  // A data datagram of the stream arrived (the caller checked that it fits
  // the stream): keeps a copy unless one is kept already, and appends to
  // `rebuilt` the datagrams that its arrival lets a block rebuild.
  void OnData(const ParsedDatagram& d, std::vector<std::vector<uint8_t>>* rebuilt);
  // A parity datagram arrived: appends what its block can rebuild now.
  void OnParity(const ParsedDatagram& d, std::vector<std::vector<uint8_t>>* rebuilt);
  // The data datagrams kept for refinement r, in arrival order (a re-decode
  // feeds them to the reader again); empty when none.
  std::vector<const std::vector<uint8_t>*> Kept(uint32_t r) const;
  // Forgets refinements below `first`: their copies, and blocks whose last
  // member lies below it. Parity of such blocks counts as late after this.
  void Release(uint32_t first);
  // Whether parity that rebuilds a datagram of refinement r may still come:
  // some of a block that holds r came and the block is still short of rows,
  // or no parity came yet for a block that begins after r. A sender begins
  // sending its blocks' parity in the order of their members
  // (docs/design/loss-protection.md), so once a later block's parity is in and no
  // block holding r is gathering rows, r's block's parity was lost, or r
  // has none.
  bool MayStillCover(uint32_t r) const;

  const ParityStats& stats() const { return stats_; }
  size_t held_bytes() const { return held_; }

 private:
  struct Copy {
    DatagramKind kind;
    uint32_t offset;
    std::vector<uint8_t> bytes;
  };
  struct Block {
    std::vector<ParityMember> members;
    uint32_t k = 0;
    uint32_t symbol_size = 0;
    std::map<uint32_t, std::vector<uint8_t>> parity;  // row -> symbol
  };
  const Copy* Find(const ParityMember& m) const;
  bool Keep(uint32_t refinement, DatagramKind kind, uint32_t offset, const uint8_t* data, size_t size);
  // Rebuilds block `b` if it can; returns whether the block is finished
  // (whole, rebuilt, or inconsistent) and may be dropped.
  bool TryRebuild(Block& b, std::vector<std::vector<uint8_t>>* rebuilt);
  void DropBlock(size_t i);

  ErasureCode* code_;
  uint32_t stream_;
  size_t max_bytes_;
  size_t held_ = 0;
  uint32_t first_ = 0;  // refinements below are released
  // The latest first member refinement of the parity datagrams of this
  // stream that arrived (none before the first).
  std::optional<uint32_t> newest_first_;
  std::map<uint32_t, std::vector<Copy>> copies_;  // by refinement
  std::vector<Block> blocks_;
  ParityStats stats_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PARITY_RECOVERY_H_
