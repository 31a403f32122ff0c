// The client's stream reconstructor (paper, section 4.3): buffers the
// datagrams of each refinement as they arrive in any order, drops
// duplicates, synchronizes the two channels and hands a refinement to the
// StreamReader when it is ready:
//   - both channels have signalled its END (reliable: its control block has
//     arrived; unreliable: its END datagram has arrived) and every datagram
//     the END announces has arrived; or
//   - its control block arrived at least `straggler_timeout_us` ago by the
//     caller's clock (stragglers, and a lost END datagram, are too late); or
//   - its control block has arrived and the caller declared what is missing
//     lost (Declare: the client's packet numbers show later datagrams arrived);
// except that a refinement the sender announced parity for (ExpectParity)
// is held, while incomplete, as long as that parity may still rebuild it
// (parity_hold_us below).
// Refinements are decoded in order; a refinement whose data is incomplete
// goes through the reader's recovery (prediction or LwoP). Datagrams of a
// refinement already decoded are counted as late and dropped.
//
// Contract: no sockets, threads or clocks (a caller's TaskRunner may run the
// reader's work on its threads): the caller passes every arrival
// and the current time (microseconds, non-decreasing). Safe on hostile
// datagrams (parsed header checked before anything is stored; malformed ones
// dropped and counted). Memory is bounded: datagrams are buffered only for
// the `window` refinements after the one being decoded, and at most
// `max_buffered_bytes` in total; what does not fit is dropped and counted.
//
// Details:
//   - A refinement is begun in the reader (BeginRefinement, then its buffered
//     datagrams, which are released) as soon as its control block has
//     arrived and the previous refinement is finished; its datagrams then go
//     straight to the reader and are not buffered.
//   - "Every datagram the END announces has arrived" is counted as: that many
//     datagrams gave the reader a unit it did not have yet. The sender's
//     datagrams carry disjoint units, so copies and datagrams made of units
//     already there never count.
//   - Datagrams are checked (DatagramHeader::Parse, stream id, refinement,
//     kind for the packing, ordinals against the split count) before anything
//     is stored; an END announcing more than twice the split count is
//     rejected. ENDs are small and kept for any refinement to decode.
//   - Duplicates: a buffered datagram byte-identical to one already buffered
//     for its refinement, or any datagram whose units the reader already has.
//   - Every buffered datagram is charged its size plus a fixed 64 bytes of
//     bookkeeping against max_buffered_bytes until its refinement is begun.
//   - With lod >= 0 only refinements [0, lod) are decoded; control blocks
//     past it are ignored and datagrams past it are counted as late.
//   - Flush counts a refinement as finished_complete when it is complete,
//     otherwise as finished_timeout.
//   - An error from the reader (a corrupt control block, a failed
//     FinishRefinement) ends the session: OnControl, Poll and Flush return
//     it again and OnDatagram ignores everything.
// Thread safety: one reconstructor per session.
#ifndef MESHSTREAM_CODEC_LOSS_RECONSTRUCTOR_H_
#define MESHSTREAM_CODEC_LOSS_RECONSTRUCTOR_H_

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <unordered_map>
#include <vector>

#include "codec/bitstream/reader.h"
#include "codec/core/erasure_code.h"
#include "codec/loss/parity_recovery.h"

namespace meshstream {

struct LossyDecodeOptions;
struct LossyDecodeReport;

struct ReconstructorOptions {
  uint64_t straggler_timeout_us = 100000;
  uint32_t window = 8;
  size_t max_buffered_bytes = size_t{16} << 20;
  Recovery recovery = Recovery::kPredict;
  int lod = -1;  // refinements to decode; -1: all
  // Workers for the reader's parallel decode of complete refinements
  // (StreamReader::SetTaskRunner; the caller's, outliving the
  // reconstructor); null: the caller's thread alone.
  TaskRunner* runner = nullptr;
  // The erasure code of parity datagrams (codec/core/erasure_code.h; the
  // caller's, outliving the reconstructor). With one, parity datagrams
  // rebuild lost data datagrams (parity_recovery.h) and a refinement decoded
  // with a prediction before its datagram was rebuilt is decoded again from
  // there; null: parity datagrams are counted and dropped.
  ErasureCode* erasure = nullptr;
  // With `erasure`: how many refinements behind the one being decoded stay
  // ready to be decoded again (their control blocks and datagrams kept, the
  // reader copied before each that missed something).
  uint32_t parity_horizon = 20;
  // With `erasure`: an incomplete refinement the sender said parity follows
  // for (ExpectParity), which would be decoded with a prediction (declared,
  // or its stragglers' wait over), is held while that parity may still come
  // (ParityRecovery::MayStillCover),
  // so that it is decoded once, rebuilt, instead of predicted and decoded
  // again with every refinement after it. The hold ends at the latest
  // `parity_hold_us` after its control block arrived, or when `window`
  // refinements wait behind it (nothing is dropped for a hold), or at
  // Flush. 0: no hold.
  uint64_t parity_hold_us = 400000;
};

struct ReconstructorStats {
  uint64_t datagrams = 0;      // data datagrams offered (END datagrams not included)
  uint64_t accepted = 0;       // carried at least one unit not seen before
  uint64_t duplicates = 0;
  uint64_t rejected = 0;       // malformed, another stream, bad ordinals
  uint64_t late = 0;           // for a refinement already decoded
  uint64_t overflow = 0;       // beyond the window or the byte budget
  uint64_t ends = 0;           // END datagrams received (duplicates included)
  uint64_t finished_complete = 0;  // refinements handed over with both ENDs and all datagrams
  uint64_t finished_timeout = 0;   // refinements handed over by the clock
  uint64_t finished_declared = 0;  // refinements handed over incomplete because the caller declared the rest lost
  uint64_t held_for_parity = 0;    // refinements whose decode waited for parity (parity_hold_us)
  uint64_t parity = 0;          // parity datagrams offered (not in `datagrams`)
  uint64_t recovered = 0;       // data datagrams parity rebuilt (then offered as arrivals)
  uint64_t redecoded = 0;       // refinements decoded again because parity rebuilt a datagram of theirs or before
  uint64_t recovered_late = 0;  // rebuilt datagrams of refinements too old to decode again
};

class StreamReconstructor {
 public:
  static StatusOr<StreamReconstructor> Create(const uint8_t* header, size_t size, uint32_t stream_id,
                                              const ReconstructorOptions& options = {});
  Status SetBase(QuantizedMesh decoded_base);

  // The reliable channel, in order: the control block of the next refinement.
  Status OnControl(const uint8_t* control, size_t size, uint64_t now_us);
  // The unreliable channel: any datagram, any order, duplicates allowed.
  void OnDatagram(const uint8_t* data, size_t size, uint64_t now_us);
  // The same with the header already read (ParsedDatagram::Parse, which only
  // makes views that passed DatagramHeader::Parse): the header is read once
  // on the receiver, and every other check above still applies. A buffered
  // datagram keeps its parsed header beside its bytes.
  void OnDatagram(const ParsedDatagram& d, uint64_t now_us);
  // The caller knows that whatever of `refinement` has not arrived will not
  // (later datagrams arrived): it is ready once its control block is in,
  // complete or not. Ignored for a refinement already decoded or beyond the
  // level of detail.
  void Declare(uint32_t refinement);
  // The sender says parity datagrams covering `refinement` follow (its
  // control block's parity_follows): with options.erasure, it is held for
  // them when incomplete (parity_hold_us). Ignored for a refinement already
  // decoded or beyond the level of detail.
  void ExpectParity(uint32_t refinement);
  // No more parity will come (the sender's stream has ended and what was in
  // flight had its time): held refinements are decoded at the next Poll.
  void StopHolding() { holds_over_ = true; }
  // Decodes every refinement that is ready at now_us; returns how many.
  StatusOr<size_t> Poll(uint64_t now_us);
  // The session is over: decodes every refinement whose control block arrived.
  Status Flush();

  size_t applied() const { return reader_.applied(); }
  bool done() const;  // every refinement to decode (lod) has been decoded
  const StreamReader& reader() const { return reader_; }
  const ReconstructorStats& stats() const { return stats_; }
  // The parity side's counters (all zero without options.erasure).
  ParityStats parity_stats() const { return parity_ ? parity_->stats() : ParityStats{}; }
  // How many times decoded levels were replaced by a decode again (a view of
  // an earlier level may now be stale).
  uint64_t decodes_again() const { return decodes_again_; }

 private:
  friend StatusOr<StreamReader> DecodeStreamLossy(const ProgressiveStream&, uint32_t, QuantizedMesh,
                                                  const LossyDecodeOptions&, LossyDecodeReport*);
  struct Buffered {
    std::vector<uint8_t> bytes;
    ParsedDatagram parsed;  // its header; points at the bytes it was parsed from (Over(bytes) to use)
  };
  struct Pending {
    std::vector<uint8_t> control;
    bool has_control = false;
    uint64_t control_time_us = 0;
    bool has_end = false;
    bool declared = false;                          // Declare: wait no longer
    bool parity_follows = false;                    // ExpectParity
    bool held = false;                              // waited for parity (counted once)
    uint32_t announced = 0;                         // data datagrams the END announced
    // Distinct data datagrams (byte-identical copies are kept once) that
    // arrived before the refinement was begun, in arrival order.
    std::vector<Buffered> seen;
    std::unordered_multimap<uint64_t, uint32_t> by_hash;  // hash of bytes -> index in seen
    uint32_t usable = 0;  // datagrams that gave the reader a unit it did not have (completeness)
  };
  StreamReconstructor() = default;
  size_t limit() const;  // refinements to decode (lod and the stream's count)
  Pending& At(size_t k);  // pending_[k], grown as needed
  // The entry of `refinement` when it is still to decode (and the session
  // has not failed); null otherwise.
  Pending* Ahead(uint32_t refinement);
  Status BeginFront();    // begins refinement applied() when its control arrived
  void Offer(Pending& p);  // hands p's buffered datagrams to the reader and releases them
  void OfferOne(Pending& p, const ParsedDatagram& d);
  bool Complete(const Pending& p) const;
  // Whether the front refinement `p`, incomplete and otherwise ready, waits
  // for parity at now_us (ReconstructorOptions::parity_hold_us).
  bool Held(Pending& p, uint64_t now_us);
  // Finishes refinement applied() if it is ready at now_us (or whenever its
  // control arrived, when flushing), then begins the next; returns whether it did.
  StatusOr<bool> DecodeNext(uint64_t now_us, bool flushing);
  // A data datagram that passed the checks of OnDatagram, new or rebuilt.
  void Arrive(const ParsedDatagram& d);
  // Rebuilt datagrams: arrivals, and a decode again from the first of them
  // that belongs to a refinement already decoded.
  void ArriveRebuilt(std::vector<std::vector<uint8_t>>& rebuilt);
  // Decodes refinements [r, applied()) again from the reader as it was
  // before refinement r finished, with every datagram kept.
  Status DecodeAgainFrom(uint32_t r);
  void ReleaseHistory();

  StreamReader reader_;
  ReconstructorOptions options_;
  uint32_t stream_id_ = 0;
  std::deque<Pending> pending_;  // pending_[k] is refinement applied() + k
  size_t buffered_bytes_ = 0;
  ReconstructorStats stats_;
  bool has_base_ = false;
  bool begun_ = false;      // refinement applied() is begun in the reader
  size_t controls_ = 0;     // control blocks received
  Status failed_;           // the first error of the reader: the session is over
  bool holds_over_ = false; // StopHolding
  // With options.erasure: the parity blocks and datagram copies, and per
  // decoded refinement within the horizon its control block and, when it
  // missed something, the reader right before it finished.
  struct Decoded {
    std::vector<uint8_t> control;
    std::optional<StreamReader> before_finish;
  };
  std::optional<ParityRecovery> parity_;
  std::map<uint32_t, Decoded> history_;
  uint64_t decodes_again_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_RECONSTRUCTOR_H_
