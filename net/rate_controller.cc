#include "net/rate_controller.h"

#include <algorithm>

namespace meshstream {

RateController::RateController(const RateControllerOptions& options)
    : options_(options),
      rate_bps_(std::clamp(options.initial_bps, options.min_bps, std::max(options.min_bps, options.max_bps))) {}

uint64_t RateController::RoundUs() const { return std::max<uint64_t>(srtt_us_, 1000); }

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
    rate_bps_ = slow_start_ ? rate_bps_ * 2 : rate_bps_ + std::max(kAdditiveMinBps, 0.05 * rate_bps_);
  } else {
    return;
  }
  rate_bps_ = std::clamp(rate_bps_, options_.min_bps, std::max(options_.min_bps, options_.max_bps));
  last_change_us_ = now_us;
  changed_ = true;
}

}  // namespace meshstream
