// Importance-ordered delivery (docs/design/loss-tolerance.md, "The reliable cut"):
// which refinements of a stream travel on the reliable channel with their
// datagrams, so that their loss cannot happen, and which go as datagrams that
// may be lost and are then predicted.
//
// The rule: every refinement has an importance (an estimate of the distortion
// its datagrams' loss would cause, RefinementImportance) and a cost (its
// datagram bytes). Refinements are ranked by importance per byte, highest
// first (ties: the coarser first), and the cut for a budget of B bytes is the
// longest prefix of that ranking whose bytes add up to at most B. A prefix,
// not a knapsack: a larger budget always keeps what a smaller one chose, so a
// session can widen its cut while it streams without undoing anything.
//
// Contract: pure functions, safe on any input (sizes that do not agree give
// an empty cut); no allocation beyond the returned vectors.
#ifndef MESHSTREAM_CODEC_LOSS_RELIABLE_CUT_H_
#define MESHSTREAM_CODEC_LOSS_RELIABLE_CUT_H_

#include <cstdint>
#include <vector>

#include "codec/progressive/refinement.h"

namespace meshstream {

// The budget chosen at encode time: a share of the stream's bytes (base,
// header, control blocks and datagrams) that may move to the reliable channel.
constexpr double kDefaultReliableShare = 0.10;
// The loss rate the encode-time cut is made for; a session scales the budget
// by the loss its client reports (ReliableShareForLoss).
constexpr double kReferenceLoss = 0.12;
// The most a session ever moves (at and above 2 x the reference loss).
constexpr double kMaxReliableShare = 0.20;

// A stream's reliable cut as the progressive .glb records it (the "delivery"
// member of MESHSTREAM_progressive, docs/spec/progressive-format.md section 1;
// importers/progressive_glb.h reads and writes it) and the stream layout
// carries it. A share of 0 and empty lists: no cut (every datagram as UDP).
struct DeliveryRecord {
  double share = 0;                // the encode-time budget, a share of the stream's bytes
  std::vector<uint32_t> ranking;   // refinements by importance per byte (RankRefinements)
  std::vector<uint32_t> reliable;  // the cut for `share`, ascending
  // Loss protection (protection.h), empty in a record written before it:
  // the refinements to protect with parity, ascending and off the cut, and
  // per refinement its harm (its datagrams' largest single-loss Hausdorff
  // distance as datagram_harm.h measures it, a share of the diagonal).
  std::vector<uint32_t> parity;
  std::vector<double> harm;
};

// Per refinement, the distortion its loss would cause, as a share of the
// whole stream's (the entries add up to 1; all zero for a stream without
// geometry). A split's weight is the length of its split vector (what the
// mesh is off by where the split is not applied, or predicted without its
// residual) times the number of final vertices that descend from it (a lost
// coarse split displaces its whole subtree).
std::vector<double> RefinementImportance(const ProgressiveMesh& mesh);

// The ranking: refinement indices by importance per datagram byte, highest
// first (ties: the coarser first). Refinements without datagrams or without
// importance are left out (nothing of them can be lost, or nothing matters).
// Empty when the two vectors' sizes differ.
std::vector<uint32_t> RankRefinements(const std::vector<double>& importance,
                                      const std::vector<uint64_t>& datagram_bytes);

// The cut for a budget: ascending indices of the longest prefix of `ranking`
// whose datagram bytes add up to at most `budget_bytes`. Indices of the
// ranking beyond datagram_bytes end the prefix.
std::vector<uint32_t> CutForBudget(const std::vector<uint32_t>& ranking, const std::vector<uint64_t>& datagram_bytes,
                                   uint64_t budget_bytes);

// The cut for a share of a stream of `stream_bytes` bytes: CutForBudget with
// a budget of share x stream_bytes. What the encoder, the simulated decode and
// a session all use, so that they agree.
std::vector<uint32_t> CutForShare(const std::vector<uint32_t>& ranking, const std::vector<uint64_t>& datagram_bytes,
                                  uint64_t stream_bytes, double share);

// The share of the stream's bytes a session moves for a reported loss rate:
// encoded_share x loss / kReferenceLoss, at least half of encoded_share (so
// the coarse refinements sent before the first report are reliable in every
// session, and a loss-free session keeps the most important half) and at most
// kMaxReliableShare (reached at twice the reference loss with the default
// share). A NaN or negative loss counts as none; the result is never below 0.
double ReliableShareForLoss(double encoded_share, double loss);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_RELIABLE_CUT_H_
