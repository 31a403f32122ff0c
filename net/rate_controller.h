// The sending rate of one session (docs/spec/streaming-protocol.md, "Pacing and
// congestion control"): a rate-based AIMD controller in the spirit of
// RFC 8085 (UDP usage guidelines: congestion-controlled, paced, backing off
// on congestion) with RFC 9002's RTT estimator, and a delay signal so that
// the random loss the codec is built to tolerate is not taken for
// congestion.
//
//  - RTT: min_rtt is the smallest sample; srtt = 7/8 srtt + 1/8 sample.
//  - Congestion is signalled by a report when its RTT sample exceeds
//    min_rtt + max(kQueueDelayFloorUs, min_rtt / 2) (a queue is building), or
//    when the smoothed loss fraction exceeds `loss_ceiling` (loss so heavy
//    that it can only be the sender's: random loss on the path is predicted
//    by the receiver, and the codec's tests go to 30 %).
//  - On congestion the rate is multiplied by kDecrease (0.7), at most once
//    per srtt, and slow start ends.
//  - Otherwise, at most once per srtt: in slow start the rate doubles,
//    after it grows by max(kAdditiveMin, 5 % of the rate).
//  - Delivery rate (BBR's bottleneck estimate, RFC 9002's pacing): each
//    delivery sample (OnDeliverySample: the bytes of a refinement's
//    datagrams over the time they took to arrive, measured by the receiver:
//    a train sent in bursts leaves a bottleneck at its rate) feeds a max
//    filter over the last kBandwidthWindowRounds rounds (btlbw). Once there
//    is one, slow start never goes past kStartupGain x btlbw, and ends when
//    btlbw has not grown by a quarter in kFullPipeRounds rounds (the pipe is
//    full; the rate drops to btlbw); after slow start the rate never goes
//    past kProbeGain x btlbw. So a sender never runs far past what the path
//    delivers, however late the queue shows (the 64-on-20 Mbit/s overshoot).
//  - The rate stays within [min_bps, max_bps].
//
// Contract: times in microseconds of the caller's non-decreasing clock;
// reports may be for any refinement in any order.
// Thread safety: none; the session's owner serialises calls.
#ifndef MESHSTREAM_NET_RATE_CONTROLLER_H_
#define MESHSTREAM_NET_RATE_CONTROLLER_H_

#include <cstdint>
#include <deque>
#include <utility>

namespace meshstream {

struct RateControllerOptions {
  double initial_bps = 16e6;
  double min_bps = 256e3;
  double max_bps = 400e6;     // the per-session cap
  double loss_ceiling = 0.4;  // smoothed loss above this is congestion
};

class RateController {
 public:
  static constexpr double kDecrease = 0.7;
  static constexpr double kAdditiveMinBps = 500e3;
  static constexpr uint64_t kQueueDelayFloorUs = 4000;
  static constexpr double kStartupGain = 2.0;
  static constexpr double kProbeGain = 1.25;
  static constexpr int kFullPipeRounds = 3;
  static constexpr int kBandwidthWindowRounds = 10;

  explicit RateController(const RateControllerOptions& options = {});

  // One report: `received` and `lost` datagrams of one refinement, and an
  // RTT sample (0: none).
  void OnReport(uint64_t now_us, uint32_t received, uint32_t lost, uint64_t rtt_us);
  // An RTT sample alone (the HELLO round trip).
  void OnRttSample(uint64_t rtt_us);
  // A delivery rate the receiver measured (bits per second; 0: none).
  void OnDeliverySample(uint64_t now_us, double bps);

  double rate_bps() const { return rate_bps_; }
  bool slow_start() const { return slow_start_; }
  uint64_t min_rtt_us() const { return min_rtt_us_; }
  uint64_t srtt_us() const { return srtt_us_; }
  double smoothed_loss() const { return loss_; }
  uint32_t decreases() const { return decreases_; }
  double btlbw_bps() const;  // the max filter of the delivery samples; 0: none yet

 private:
  uint64_t RoundUs() const;
  double Cap() const;  // what the rate may not pass now (max_bps without a delivery sample)
  RateControllerOptions options_;
  double rate_bps_;
  bool slow_start_ = true;
  uint64_t min_rtt_us_ = 0;  // 0: no sample yet
  uint64_t srtt_us_ = 0;
  double loss_ = 0;
  bool has_loss_ = false;
  uint64_t last_change_us_ = 0;
  bool changed_ = false;
  uint32_t decreases_ = 0;
  // Delivery samples: (when, bps), the last kBandwidthWindowRounds rounds.
  std::deque<std::pair<uint64_t, double>> delivery_;
  double full_pipe_bps_ = 0;  // btlbw when it last grew by a quarter
  int rounds_without_growth_ = 0;
  uint64_t last_growth_check_us_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_RATE_CONTROLLER_H_
