// The one clock of the streaming code: microseconds of std::chrono's steady
// clock, the unit net/pacer.h, net/rate_controller.h and the codec's stream
// reconstructor take their times in.
#ifndef MESHSTREAM_NET_STEADY_CLOCK_H_
#define MESHSTREAM_NET_STEADY_CLOCK_H_

#include <chrono>
#include <cstdint>

namespace meshstream {

inline uint64_t SteadyNowUs() {
  return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                   std::chrono::steady_clock::now().time_since_epoch())
                                   .count());
}

}  // namespace meshstream

#endif  // MESHSTREAM_NET_STEADY_CLOCK_H_
