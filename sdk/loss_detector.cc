#include "sdk/loss_detector.h"

#include <algorithm>
#include <cstdint>

namespace meshstream::sdk {

void LossDetector::OnPacket(uint64_t packet_number, uint64_t at_us) {
  if (!Seen(packet_number)) {
    rises_.emplace_back(packet_number, at_us);
    if (rises_.size() > kRiseHistory) {
      rises_.pop_front();
      rises_forgotten_ = true;
    }
    return;
  }
  // Reordered: it comes after the first datagram numbered above it (long
  // ago when that one is forgotten: the window then goes to its cap).
  const auto later = std::upper_bound(rises_.begin(), rises_.end(), std::make_pair(packet_number, UINT64_MAX));
  uint64_t since = later == rises_.end() || at_us < later->second ? 0 : at_us - later->second;
  if (later == rises_.begin() && rises_forgotten_) since = UINT64_MAX / 2;
  reorder_seen_us_ = std::max(reorder_seen_us_, since);
  if (Seen(packet_number + kPacketThreshold)) packet_rule_ = false;
}

void LossDetector::OnSpurious() {
  packet_rule_ = false;
  grown_window_us_ = std::min(2 * WindowUs(), straggler_us_);
}

uint64_t LossDetector::WindowUs() const {
  if (!active()) return straggler_us_;
  // Reordering seen widens it at once, with RFC 9002's 9/8 margin.
  const uint64_t seen = reorder_seen_us_ + reorder_seen_us_ / 8;
  const uint64_t base = std::clamp<uint64_t>(std::max(rtt_us_ / 8, seen), kMinReorderWindowUs, straggler_us_);
  return std::min(std::max(base, grown_window_us_), straggler_us_);
}

}  // namespace meshstream::sdk
