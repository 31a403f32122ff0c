#include "net/pacer.h"

#include <algorithm>

namespace meshstream {

void Pacer::SetRate(double rate_bps) { rate_bps_ = std::max(1000.0, rate_bps); }

double Pacer::BacklogAt(uint64_t now_us) const {
  if (now_us <= updated_us_) return backlog_bytes_;
  const double drained = static_cast<double>(now_us - updated_us_) * rate_bps_ / 8e6;
  return std::max(0.0, backlog_bytes_ - drained);
}

uint64_t Pacer::DueUs(uint64_t now_us, size_t bytes) const {
  // A datagram may go when the backlog ahead of it leaves room for it in the burst.
  // The bucket's latest state may lie ahead of now (RateShare reserves
  // future slots): judge from whichever is later.
  const uint64_t from = std::max(now_us, updated_us_);
  const double excess = BacklogAt(from) + static_cast<double>(bytes) - static_cast<double>(burst_bytes_);
  if (excess <= 0) return now_us;
  return from + static_cast<uint64_t>(excess * 8e6 / rate_bps_ + 0.999);
}

void Pacer::OnSent(uint64_t now_us, size_t bytes) {
  backlog_bytes_ = BacklogAt(now_us) + static_cast<double>(bytes);
  updated_us_ = std::max(updated_us_, now_us);
}

uint64_t RateShare::Reserve(uint64_t now_us, size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  const uint64_t due = pacer_.DueUs(now_us, bytes);
  pacer_.OnSent(due, bytes);
  return due;
}

}  // namespace meshstream
