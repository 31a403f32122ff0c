// Why a received datagram was dropped, and the counters a receiver keeps of
// them (docs/spec/streaming-protocol.md, "Receiving").
//
// Contract: a receiver drops every datagram for which ParseHeader, the
// session lookup, OpenPacket or the ReplayWindow returns a reason other than
// kNone, counts it in its DropCounters, and acts on nothing in it.
// Thread safety: DropCounters is a plain value; one receiver (one socket
// thread) owns it, others read a copy.
#ifndef MESHSTREAM_NET_DROP_REASON_H_
#define MESHSTREAM_NET_DROP_REASON_H_

#include <array>
#include <cstddef>
#include <cstdint>

namespace meshstream {

enum class DropReason : uint8_t {
  kNone = 0,        // accepted
  kTooShort,        // fewer bytes than a header and a tag
  kTooLong,         // more than kMaxDatagramBytes
  kBadMagic,        // byte 0 is not kPacketMagic
  kBadVersion,      // byte 1 is not kPacketVersion
  kBadType,         // byte 2 is no PacketType
  kBadReserved,     // byte 3 is not zero
  kUnknownSession,  // the session id names no live session (the caller's lookup)
  kAuthFailed,      // the AEAD tag does not verify under the session's key
  kReplayed,        // the packet number was accepted before
  kTooOld,          // the packet number is below the replay window
  kBadPayload,      // authenticated, but the payload is not what its type carries
};
constexpr size_t kDropReasonCount = 12;

// A stable lower-case name for logs and metrics ("auth_failed").
const char* DropReasonName(DropReason reason);

struct DropCounters {
  std::array<uint64_t, kDropReasonCount> by_reason{};  // index: the reason's value; [0] counts accepted packets

  void Count(DropReason reason) { ++by_reason[static_cast<size_t>(reason)]; }
  uint64_t Get(DropReason reason) const { return by_reason[static_cast<size_t>(reason)]; }
  uint64_t accepted() const { return by_reason[0]; }
  uint64_t dropped() const;  // every reason but kNone
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_DROP_REASON_H_
