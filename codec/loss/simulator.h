// A seeded, deterministic network simulator for one progressive stream: it
// schedules what a server sends (per refinement, its control block on the
// reliable channel; its datagrams, then an END datagram, on the unreliable
// channel) and returns what a client receives, in arrival order, after loss
// (independent, or bursty by a two-state Gilbert-Elliott chain),
// reordering and duplication of datagrams. The reliable channel is ordered
// and lossless.
//
// Contract: pure; the same stream, model and seed give the same events
// (std::mt19937_64, no global state). Events point into the stream (and into
// the schedule's own END datagrams): they live as long as both. A zero model
// (no loss, reorder or duplication) delivers every datagram once, in order,
// through the same code path. Thread safety: none needed (no shared state).
#ifndef MESHSTREAM_CODEC_LOSS_SIMULATOR_H_
#define MESHSTREAM_CODEC_LOSS_SIMULATOR_H_

#include <cstdint>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/erasure_code.h"
#include "codec/core/status.h"
#include "codec/loss/parity_plan.h"

namespace meshstream {

struct LossModel {
  double loss = 0;       // probability that a datagram is dropped, in [0, 1]
  double burst = 0;      // mean length of a loss burst; <= 1: independent losses
  double reorder = 0;    // fraction of datagrams delayed behind later ones, in [0, 1]
  double duplicate = 0;  // fraction of datagrams delivered twice, in [0, 1]
  uint64_t seed = 1;
  Status Validate() const;  // kInvalidArgument naming the field out of range
};

// Timing of the simulated link, in microseconds of simulated time.
struct LinkTiming {
  uint64_t refinement_interval_us = 20000;  // between the starts of two refinements
  uint64_t datagram_interval_us = 100;      // between two datagrams of a refinement
  uint64_t reliable_latency_us = 30000;     // control block send -> arrival
  uint64_t unreliable_latency_us = 10000;   // datagram send -> arrival
  uint64_t reorder_delay_us = 5000;         // a reordered datagram arrives up to this much later
};

struct ChannelEvent {
  enum class Kind : uint8_t { kControl, kDatagram };
  Kind kind = Kind::kControl;
  uint64_t time_us = 0;       // arrival time
  uint32_t refinement = 0;    // kControl: which control block
  const uint8_t* data = nullptr;
  size_t size = 0;
  // kControl: parity datagrams covering the refinement follow (it is a
  // member of a block that gets parity rows), as a session's control block
  // says (ControlBlock.parity_follows).
  bool parity_follows = false;
};

struct TransmissionStats {
  uint64_t datagrams_sent = 0;  // data datagrams, END datagrams not included, reliable ones included
  uint64_t datagrams_lost = 0;  // data datagrams the simulator dropped
  uint64_t reliable_datagrams = 0;  // data datagrams of the reliable cut (never lost)
  uint64_t reliable_bytes = 0;      // their bytes
  uint64_t lost_bytes = 0;          // bytes of the data datagrams dropped
  uint64_t refinements_with_loss = 0;  // refinements that lost at least one data datagram
  uint64_t parity_blocks = 0;       // parity blocks (SimulatedParity) that got at least one parity row
  uint64_t parity_datagrams = 0;    // parity datagrams sent (not in datagrams_sent)
  uint64_t parity_bytes = 0;        // their bytes
  uint64_t parity_lost = 0;         // parity datagrams the simulator dropped
  uint64_t datagram_bytes = 0;      // bytes of the data datagrams sent (reliable ones included)
  uint64_t ends_sent = 0;
  uint64_t ends_lost = 0;
  uint64_t duplicated = 0;
  uint64_t reordered = 0;
};

// Parity on the unreliable channel (parity_plan.h, parity.h): the sender's
// blocks over the protected refinements, with rows sized for `loss` and
// `burst` (what the client reported), sent interleaved after each block.
struct SimulatedParity {
  ErasureCode* code = nullptr;   // null: no parity
  std::vector<uint8_t> protect;  // per refinement: its ProtectionTier (protection.h); empty: every refinement
                                 // not on the reliable cut, strong
  double loss = 0;               // the loss parity is sized for; 0: none sent
  double burst = 0;              // the mean loss run it is sized for (<= 1: independent)
  ParityPlanOptions plan;
};

// Move it, do not copy it: a copy's events still point at the original's
// END and parity datagrams.
struct Transmission {
  std::vector<std::vector<uint8_t>> end_datagrams;  // owned END datagrams
  std::vector<std::vector<uint8_t>> parity_datagrams;  // owned parity datagrams, in send order
  std::vector<ChannelEvent> events;                  // by arrival time
  TransmissionStats stats;
};

// Sends refinements [0, refinements) of `stream` (numbered `stream_id` in
// its datagrams); refinements beyond the stream's count are an error.
// `reliable` (ascending refinement indices, reliable_cut.h) names the
// refinements whose datagrams and END travel on the reliable channel: they
// arrive reliable_latency_us after they are sent, in order, and are never
// lost, duplicated or reordered; they still take their draws from the
// generator, so the datagrams on the unreliable channel see the same loss
// pattern with and without a cut for one seed.
//
// Schedule: refinement i starts at i * refinement_interval_us; its control
// block arrives reliable_latency_us later; its d-th datagram is sent at the
// start + d * datagram_interval_us and its END one interval after the last
// datagram; a datagram arrives unreliable_latency_us after it is sent, plus
// a uniform extra delay in (0, reorder_delay_us] for the `reorder` fraction;
// the copy of a duplicated datagram arrives within one datagram interval after
// it. Loss applies to data and END datagrams alike: independent when
// burst <= 1, otherwise a Gilbert-Elliott chain with stationary loss `loss`
// and mean loss-run length `burst` (p(bad -> good) = 1 / burst,
// p(good -> bad) = loss / (burst (1 - loss))). Every datagram takes the same
// number of draws from the generator whatever the model, so for one seed the
// loss pattern does not depend on `reorder` and `duplicate`. Events are
// ordered by arrival time, ties by send order (a control block before its
// refinement's datagrams, a copy after its original).
//
// `parity` (null or without a code: none): the blocks of PlanParityBlocks
// over the protected refinements (never those of the reliable cut), each
// coded as ShapeFor(its members' lengths, parity->loss, parity->burst) says.
// Parity datagram j of a
// block is sent after the ((j + 1) x interleave)-th data datagram that
// follows the block's last member (after the last datagram at the end of
// the stream), at that datagram's send time. A parity datagram takes no
// draw from the data's generator, so the data see the same loss pattern with
// and without parity for one seed: with bursts it is lost when the chain is
// in its bad state for the next data datagram (a burst spans it), otherwise
// by a draw of its own at `loss`; it is never reordered or duplicated.
StatusOr<Transmission> SimulateTransmission(const ProgressiveStream& stream, uint32_t stream_id, size_t refinements,
                                            const LossModel& model, const LinkTiming& timing = {},
                                            const std::vector<uint32_t>& reliable = {},
                                            const SimulatedParity* parity = nullptr);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_SIMULATOR_H_
