// Spaces a sender's datagrams at a rate (docs/spec/streaming-protocol.md,
// "Pacing and congestion control"): a leaky bucket of bytes that drains at
// the rate. Each datagram is due when the backlog ahead of it leaves room
// for it within `burst_bytes`, so a rate change applies at once; a burst
// of at most `burst_bytes` may go at once after an idle spell, so that the
// sender can batch a few datagrams per system call without building a queue
// in the network.
//
// Contract: times are microseconds of one non-decreasing clock of the
// caller's; the rate is bits per second, clamped to >= 1000.
// Thread safety: none (one per session); RateShare is thread-safe.
#ifndef MESHSTREAM_NET_PACER_H_
#define MESHSTREAM_NET_PACER_H_

#include <cstddef>
#include <cstdint>
#include <mutex>

namespace meshstream {

class Pacer {
 public:
  Pacer(double rate_bps, size_t burst_bytes) : burst_bytes_(burst_bytes) { SetRate(rate_bps); }
  void SetRate(double rate_bps);
  double rate_bps() const { return rate_bps_; }
  // When a datagram of `bytes` may leave (<= now_us: now).
  uint64_t DueUs(uint64_t now_us, size_t bytes) const;
  // Records a datagram that left at now_us.
  void OnSent(uint64_t now_us, size_t bytes);

 private:
  double BacklogAt(uint64_t now_us) const;
  double rate_bps_ = 0;
  size_t burst_bytes_ = 0;
  double backlog_bytes_ = 0;  // at updated_us_
  uint64_t updated_us_ = 0;
};

// One budget shared by every session of a server (--max-rate): a pacer in
// virtual time that sessions reserve slots of.
class RateShare {
 public:
  explicit RateShare(double rate_bps) : pacer_(rate_bps, 64 * 1024) {}
  // Reserves `bytes` and returns when they may leave.
  uint64_t Reserve(uint64_t now_us, size_t bytes);
  double rate_bps() const { return pacer_.rate_bps(); }

 private:
  std::mutex mutex_;
  Pacer pacer_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_PACER_H_
