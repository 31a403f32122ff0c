// The server's send budget towards one UDP address of a session
// (docs/spec/streaming-protocol.md, "Anti-amplification").
//
// Until the address is proven (an authenticated HELLO from it echoed the
// challenge the server sent it), the server sends it at most as many bytes as
// it received from it in authenticated HELLOs, and never DATA; after, no
// limit from here (congestion control is another layer's).
//
// Contract: OnReceived only for datagrams that OpenPacket accepted from this
// address (an unauthenticated datagram must earn no budget, or a spoofer
// could buy reflection with garbage); MaySend before every send to the
// address, OnSent after it.
// Thread safety: none; the session's socket thread owns it.
#ifndef MESHSTREAM_NET_AMPLIFICATION_LIMIT_H_
#define MESHSTREAM_NET_AMPLIFICATION_LIMIT_H_

#include <cstddef>
#include <cstdint>

#include "net/packet_header.h"

namespace meshstream {

class AmplificationLimit {
 public:
  void OnReceived(size_t datagram_bytes) { received_ += datagram_bytes; }
  void OnSent(size_t datagram_bytes) { sent_ += datagram_bytes; }
  void MarkProven() { proven_ = true; }

  bool proven() const { return proven_; }
  // Whether a datagram of this type and size may go to the address now.
  bool MaySend(PacketType type, size_t datagram_bytes) const;

 private:
  bool proven_ = false;
  uint64_t received_ = 0;
  uint64_t sent_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_AMPLIFICATION_LIMIT_H_
