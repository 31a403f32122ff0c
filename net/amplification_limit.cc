#include "net/amplification_limit.h"

namespace meshstream {

bool AmplificationLimit::MaySend(PacketType type, size_t datagram_bytes) const {
  if (proven_) return true;
  if (type == PacketType::kData) return false;  // fragments go only to a proven address
  // sent_ <= received_ always holds here, so the subtraction does not wrap.
  return sent_ <= received_ && datagram_bytes <= received_ - sent_;
}

}  // namespace meshstream
