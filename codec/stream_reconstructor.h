// The client's stream reconstructor (paper, section 4.3): buffers the
// datagrams of each refinement as they arrive in any order, drops
// duplicates, synchronizes the two channels and hands a refinement to the
// StreamReader when it is ready:
//   - both channels have signalled its END (reliable: its control block has
//     arrived; unreliable: its END datagram has arrived) and every datagram
//     the END announces has arrived; or
//   - its control block arrived at least `straggler_timeout_us` ago by the
//     caller's clock (stragglers, and a lost END datagram, are too late).
// Refinements are decoded in order; a refinement whose data is incomplete
// goes through the reader's recovery (prediction or LwoP). Datagrams of a
// refinement already decoded are counted as late and dropped.
//
// Contract: no sockets, threads or clocks: the caller passes every arrival
// and the current time (microseconds, non-decreasing). Safe on hostile
// datagrams (parsed header checked before anything is stored; malformed ones
// dropped and counted). Memory is bounded: datagrams are buffered only for
// the `window` refinements after the one being decoded, and at most
// `max_buffered_bytes` in total; what does not fit is dropped and counted.
// Thread safety: one reconstructor per session.
#ifndef MESHSTREAM_CODEC_STREAM_RECONSTRUCTOR_H_
#define MESHSTREAM_CODEC_STREAM_RECONSTRUCTOR_H_

#include <cstdint>
#include <deque>
#include <vector>

#include "codec/stream_reader.h"

namespace meshstream {

struct ReconstructorOptions {
  uint64_t straggler_timeout_us = 100000;
  uint32_t window = 8;
  size_t max_buffered_bytes = size_t{16} << 20;
  Recovery recovery = Recovery::kPredict;
  int lod = -1;  // refinements to decode; -1: all
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
  // Decodes every refinement that is ready at now_us; returns how many.
  StatusOr<size_t> Poll(uint64_t now_us);
  // The session is over: decodes every refinement whose control block arrived.
  Status Flush();

  size_t applied() const { return reader_.applied(); }
  bool done() const;  // every refinement to decode (lod) has been decoded
  const StreamReader& reader() const { return reader_; }
  const ReconstructorStats& stats() const { return stats_; }

 private:
  struct Pending {
    std::vector<uint8_t> control;
    bool has_control = false;
    uint64_t control_time_us = 0;
    bool has_end = false;
    uint32_t announced = 0;                         // data datagrams the END announced
    std::vector<std::vector<uint8_t>> datagrams;    // buffered until the refinement begins
    std::vector<std::vector<uint8_t>> seen;         // distinct data datagrams (for completeness)
  };
  StreamReader reader_;
  ReconstructorOptions options_;
  uint32_t stream_id_ = 0;
  std::deque<Pending> pending_;  // pending_[k] is refinement applied() + k
  size_t buffered_bytes_ = 0;
  ReconstructorStats stats_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_STREAM_RECONSTRUCTOR_H_
