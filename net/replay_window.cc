#include "net/replay_window.h"

namespace meshstream {

DropReason ReplayWindow::Check(uint64_t packet_number) const {
  if (!any_ || packet_number > highest_) return DropReason::kNone;
  const uint64_t age = highest_ - packet_number;
  if (age >= kWindow) return DropReason::kTooOld;
  const bool seen = age < 64 ? (low_ >> age) & 1 : (high_ >> (age - 64)) & 1;
  return seen ? DropReason::kReplayed : DropReason::kNone;
}

DropReason ReplayWindow::Accept(uint64_t packet_number) {
  const DropReason reason = Check(packet_number);
  if (reason != DropReason::kNone) return reason;
  if (!any_) {
    any_ = true;
    highest_ = packet_number;
    low_ = 1;
    high_ = 0;
    return DropReason::kNone;
  }
  if (packet_number > highest_) {
    const uint64_t shift = packet_number - highest_;  // >= 1, no overflow: packet_number > highest_
    if (shift >= kWindow) {
      low_ = 0;
      high_ = 0;
    } else if (shift >= 64) {
      high_ = low_ << (shift - 64);
      low_ = 0;
    } else {
      high_ = (high_ << shift) | (low_ >> (64 - shift));
      low_ <<= shift;
    }
    low_ |= 1;
    highest_ = packet_number;
    return DropReason::kNone;
  }
  const uint64_t age = highest_ - packet_number;  // < kWindow: Check passed
  if (age < 64) {
    low_ |= uint64_t{1} << age;
  } else {
    high_ |= uint64_t{1} << (age - 64);
  }
  return DropReason::kNone;
}

}  // namespace meshstream
