#include "net/rate_controller.h"

#include <algorithm>

namespace meshstream {

RateController::RateController(const RateControllerOptions& options)
    : options_(options),
      rate_bps_(std::clamp(options.initial_bps, options.min_bps, std::max(options.min_bps, options.max_bps))) {}

uint64_t RateController::RoundUs() const { return std::max<uint64_t>(srtt_us_, 1000); }

double RateController::btlbw_bps() const {
  double best = 0;
  for (const auto& [at, bps] : delivery_) best = std::max(best, bps);
  return best;
}

double RateController::Cap() const {
  const double btlbw = btlbw_bps();
  if (btlbw <= 0) return options_.max_bps;
  return std::min(options_.max_bps, (slow_start_ ? kStartupGain : kProbeGain) * btlbw);
}

void RateController::OnDeliverySample(uint64_t now_us, double bps) {
  if (!(bps > 0)) return;
  const uint64_t window = kBandwidthWindowRounds * RoundUs();
  while (!delivery_.empty() && delivery_.front().first + window < now_us) delivery_.pop_front();
  // Keep the filter small: a sample no larger than a later one never wins.
  while (!delivery_.empty() && delivery_.back().second <= bps) delivery_.pop_back();
  delivery_.emplace_back(now_us, bps);
  // Slow start ends once the pipe is full: btlbw not a quarter up in
  // kFullPipeRounds rounds (BBR's test, one check per round); the rate then
  // drains to btlbw.
  if (slow_start_ && (last_growth_check_us_ == 0 || now_us >= last_growth_check_us_ + RoundUs())) {
    last_growth_check_us_ = now_us;
    const double btlbw = btlbw_bps();
    if (btlbw >= 1.25 * full_pipe_bps_) {
      full_pipe_bps_ = btlbw;
      rounds_without_growth_ = 0;
    } else if (++rounds_without_growth_ >= kFullPipeRounds) {
      slow_start_ = false;
      rate_bps_ = std::min(rate_bps_, btlbw);
    }
  }
  // Never past what the path delivers (BBR paces at a gain over btlbw).
  rate_bps_ = std::clamp(std::min(rate_bps_, Cap()), options_.min_bps, std::max(options_.min_bps, options_.max_bps));
}

void RateController::OnRttSample(uint64_t rtt_us) {
  if (rtt_us == 0) return;
  if (min_rtt_us_ == 0 || rtt_us < min_rtt_us_) min_rtt_us_ = rtt_us;
  srtt_us_ = srtt_us_ == 0 ? rtt_us : (7 * srtt_us_ + rtt_us) / 8;
}

void RateController::OnReport(uint64_t now_us, uint32_t received, uint32_t lost, uint64_t rtt_us) {
  bool queue = false;
  if (rtt_us > 0) {
    // The floor is judged against the minimum before this sample.
    if (min_rtt_us_ != 0) {
      const uint64_t allowed = min_rtt_us_ + std::max<uint64_t>(kQueueDelayFloorUs, min_rtt_us_ / 2);
      queue = rtt_us > allowed;
    }
    OnRttSample(rtt_us);
  }
  const uint32_t total = received + lost;
  if (total > 0) {
    const double fraction = static_cast<double>(lost) / total;
    loss_ = has_loss_ ? 0.875 * loss_ + 0.125 * fraction : fraction;
    has_loss_ = true;
  }
  const bool congested = queue || (has_loss_ && loss_ > options_.loss_ceiling);
  const bool round_over = !changed_ || now_us >= last_change_us_ + RoundUs();
  if (!round_over) return;
  if (congested) {
    rate_bps_ *= kDecrease;
    slow_start_ = false;
    ++decreases_;
  } else if (total > 0) {
    const double grown = slow_start_ ? rate_bps_ * 2 : rate_bps_ + std::max(kAdditiveMinBps, 0.05 * rate_bps_);
    rate_bps_ = std::min(grown, Cap());  // never past what the path delivers
  } else {
    return;
  }
  rate_bps_ = std::clamp(rate_bps_, options_.min_bps, std::max(options_.min_bps, options_.max_bps));
  last_change_us_ = now_us;
  changed_ = true;
}

}  // namespace meshstream
