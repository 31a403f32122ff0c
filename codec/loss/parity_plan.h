// Which data datagrams a sender protects with parity, in which blocks, and
// how many parity rows a block gets for the loss a client reports
// (docs/loss-protection.md, "Blocks" and "How much parity").
//
// Blocks: the datagrams of the protected refinements (the delivery record's
// choice, protection.h), in send order, cut into blocks of at most
// `block_datagrams` members spanning at most `max_span` refinements (the
// receiver's window, within which a refinement decoded with a prediction can
// still be decoded again); a block holds refinements of one tier. A block's parity goes out after its last member,
// interleaved with the data that follows (every `interleave`-th datagram), so
// that one burst does not take a block's data and its parity.
//
// Rows: the fewest parity rows m with P(more than m of the block's k + m
// datagrams lost) <= `block_failure` (`strong_failure` for a block of
// strong tier) under the reported loss: independent
// losses (binomial) or, with a mean loss run > 1, a Gilbert-Elliott chain of
// that stationary loss and run length over k + m consecutive datagrams
// (computed exactly). None at a loss of 0; at most max_rate x k rows.
//
// Contract: pure functions; any input (NaN, negative or > 1 losses count as
// 0 and 1; sizes that do not agree give no blocks).
#ifndef MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_
#define MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_

#include <cstdint>
#include <utility>
#include <vector>

#include "codec/bitstream/format.h"

namespace meshstream {

struct ParityPlanOptions {
  uint32_t block_datagrams = 32;  // members per block, at most (and at most 255)
  uint32_t max_span = 8;          // refinements one block spans, at most
  uint32_t interleave = 3;        // a parity goes out after every this many data datagrams
  double block_failure = 0.05;    // the chance a block keeps a loss, at most
  double strong_failure = 0.01;   // the same for a block of the strong tier
  double max_rate = 0.5;          // parity rows per member, at most
};

struct ParityBlockPlan {
  uint8_t tier = 1;  // ProtectionTier of its refinements
  // (refinement, index into stream.datagrams[refinement]), in send order.
  std::vector<std::pair<uint32_t, uint32_t>> members;
  uint32_t first_refinement() const { return members.front().first; }
  uint32_t last_refinement() const { return members.back().first; }
};

// The blocks of refinements [0, refinements) of `stream` whose entry in
// `protect` (a ProtectionTier) is non-zero (a refinement beyond protect's
// size is not protected); refinements without datagrams add nothing.
std::vector<ParityBlockPlan> PlanParityBlocks(const ProgressiveStream& stream, size_t refinements,
                                              const std::vector<uint8_t>& protect,
                                              const ParityPlanOptions& options = {});

// Parity rows for a block of k members of `tier` at `loss` with mean loss
// runs of `burst` datagrams (<= 1: independent).
uint32_t ParityRowsFor(uint32_t k, double loss, double burst, const ParityPlanOptions& options = {},
                       uint8_t tier = 1);

// P(more than m of n consecutive datagrams lost) under that loss model.
double BlockFailure(uint32_t n, uint32_t m, double loss, double burst);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PARITY_PLAN_H_
