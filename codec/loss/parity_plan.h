// Which data datagrams a sender protects with parity, in which blocks, and
// how many parity rows a block gets for the loss a client reports
// (docs/design/loss-protection.md, "Blocks" and "How much parity").
//
// Blocks: the datagrams of the protected refinements (the delivery record's
// choice, protection.h), in send order, cut into blocks of at most
// `block_datagrams` members spanning at most `max_span` refinements (the
// receiver's window, within which a refinement decoded with a prediction can
// still be decoded again); a block's tier is the strongest of its
// refinements' (a change of tier does not cut a block). A block's parity goes out after its last member,
// interleaved with the data that follows (every `interleave`-th datagram), so
// that one burst does not take a block's data and its parity.
//
// Shape (parity.h): symbols of the smallest size that keeps the data rows at
// most `max_data_rows`; as many parity rows per datagram as fit
// `packet_bytes`; the fewest parity rows m with P(the lost datagrams, members
// and parity, take more than m rows) <= `block_failure` (`strong_failure`
// for a block of strong tier) under the reported loss: independent
// losses or, with a mean loss run > 1, a Gilbert-Elliott chain of that
// stationary loss and run length over the block's datagrams in send order
// (members, then its parity), computed exactly. None at a loss of 0; at
// most max_rate x k rows, and k + m <= 256.
//
// Contract: pure functions; any input (NaN, negative or > 1 losses count as
// 0 and 1; sizes that do not agree give no blocks).
#ifndef MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_
#define MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_

#include <cstdint>
#include <utility>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/loss/parity.h"

namespace meshstream {

struct ParityPlanOptions {
  uint32_t block_datagrams = 100;  // members per block, at most (and at most 255)
  uint32_t max_span = 16;          // refinements one block spans, at most (the receiver's parity horizon: 20)
  uint32_t interleave = 3;        // a parity goes out after every this many data datagrams
  double block_failure = 0.3;     // the chance a block keeps a loss, at most (docs/design/loss-protection.md)
  double strong_failure = 0.1;    // the same for a block of the strong tier
  double max_rate = 0.5;          // parity rows per data row, at most
  uint32_t max_data_rows = 160;   // data rows of a block, at most (the symbol size grows instead)
  uint32_t packet_bytes = 1200;   // a parity datagram's size, at most (roughly)
  // Blocks interleaved this deep: `depth` neighbouring blocks share their
  // refinements, member i of the group going to block i mod depth, so that a
  // burst of losses costs each of them a 1/depth share (an experiment of the
  // loss bench, `--parity-depth`; the sessions send depth 1).
  uint32_t depth = 1;
};

struct ParityBlockPlan {
  uint8_t tier = 1;  // ProtectionTier of its refinements
  // (refinement, index into stream.datagrams[refinement]), in send order.
  std::vector<std::pair<uint32_t, uint32_t>> members;
  uint32_t stride = 1;  // its members lie this many datagrams apart in the send order (depth)
  uint32_t first_refinement() const { return members.front().first; }
  uint32_t last_refinement() const { return members.back().first; }
};

// The blocks of refinements [0, refinements) of `stream` whose entry in
// `protect` (a ProtectionTier) is non-zero (a refinement beyond protect's
// size is not protected); refinements without datagrams add nothing.
std::vector<ParityBlockPlan> PlanParityBlocks(const ProgressiveStream& stream, size_t refinements,
                                              const std::vector<uint8_t>& protect,
                                              const ParityPlanOptions& options = {});

// How to code a block of members of `lengths` bytes (in send order) of
// `tier` at `loss` with mean loss runs of `burst` datagrams (<= 1:
// independent); m = 0 when no parity is needed (or the loss is 0).
// `stride`: the members lie that many datagrams apart in the send order
// (the others' losses take none of this block's rows).
ParityShape ShapeFor(const std::vector<uint32_t>& lengths, double loss, double burst,
                     const ParityPlanOptions& options = {}, uint8_t tier = 1, uint32_t stride = 1);

// P(the lost ones of datagrams sent in this order, each taking weights[i]
// rows, take more than m rows) under that loss model.
double WeightedFailure(const std::vector<uint32_t>& weights, uint32_t m, double loss, double burst);
// The same with every weight 1: P(more than m of n consecutive datagrams lost).
double BlockFailure(uint32_t n, uint32_t m, double loss, double burst);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_
