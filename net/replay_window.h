// The receiver's replay window over 64-bit packet numbers
// (docs/spec/streaming-protocol.md, "Replay window").
//
// Remembers the highest packet number accepted and which of the kWindow
// numbers at and below it were accepted. Accept takes each number at most
// once, in any order within the window; a number kWindow or more below the
// highest is refused as kTooOld (it may be new, but the window can no longer
// tell). 0 and UINT64_MAX are ordinary numbers.
//
// Contract: call Accept only for a packet that OpenPacket authenticated. An
// unauthenticated packet number is attacker-chosen: one forged datagram with
// number 2^63 would otherwise slide the window past every genuine packet and
// make the receiver drop the whole session as kTooOld.
// Thread safety: none; one receiver owns a window per session and direction.
#ifndef MESHSTREAM_NET_REPLAY_WINDOW_H_
#define MESHSTREAM_NET_REPLAY_WINDOW_H_

#include <cstdint>

#include "net/drop_reason.h"

namespace meshstream {

class ReplayWindow {
 public:
  static constexpr uint64_t kWindow = 128;

  // Whether Accept would take the number, without recording it.
  DropReason Check(uint64_t packet_number) const;
  // kNone and the number recorded, or kReplayed / kTooOld and nothing changes.
  DropReason Accept(uint64_t packet_number);

  bool empty() const { return !any_; }
  uint64_t highest() const { return highest_; }  // meaningful when !empty()

 private:
  bool any_ = false;
  uint64_t highest_ = 0;
  // Bit i of the 128 (low_ bits 0..63, high_ bits 64..127): number highest_ - i was accepted.
  uint64_t low_ = 0;
  uint64_t high_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_REPLAY_WINDOW_H_
