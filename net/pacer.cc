#include "net/pacer.h"

#include <algorithm>

namespace meshstream {

void Pacer::SetRate(double rate_bps) { rate_bps_ = std::max(1000.0, rate_bps); }

uint64_t Pacer::DueUs(uint64_t now_us, size_t bytes) const {
  // The bucket holds burst_bytes: a datagram may go as soon as the backlog
  // ahead of it is at most the burst.
  const double burst_us = static_cast<double>(burst_bytes_) * 8e6 / rate_bps_;
  const double due = next_us_ - burst_us + static_cast<double>(bytes) * 8e6 / rate_bps_;
  if (due <= static_cast<double>(now_us)) return now_us;
  return static_cast<uint64_t>(due);
}

void Pacer::OnSent(uint64_t now_us, size_t bytes) {
  // next_us_ - now is the backlog; after an idle spell it is zero, never
  // less (credit would allow more than one burst).
  next_us_ = std::max(next_us_, static_cast<double>(now_us));
  next_us_ += static_cast<double>(bytes) * 8e6 / rate_bps_;
}

uint64_t RateShare::Reserve(uint64_t now_us, size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  const uint64_t due = pacer_.DueUs(now_us, bytes);
  pacer_.OnSent(due, bytes);
  return due;
}

}  // namespace meshstream
