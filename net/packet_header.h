// The fixed 20-byte header of every meshstream UDP datagram
// (docs/spec/streaming-protocol.md, "Datagram"), without any cryptography: the
// receiver parses it to find the session, and with it the key, before it
// authenticates the rest.
//
// Contract: ParseHeader is safe on untrusted input: it checks the datagram's
// size against kMinDatagramBytes and kMaxDatagramBytes before reading any
// byte, then each header field in order, and returns the first reason that
// applies. A parsed header is NOT authenticated: act on nothing in it but the
// session lookup until OpenPacket accepts the datagram.
// Thread safety: pure functions on plain values.
#ifndef MESHSTREAM_NET_PACKET_HEADER_H_
#define MESHSTREAM_NET_PACKET_HEADER_H_

#include <cstddef>
#include <cstdint>

#include "codec/core/byte_io.h"
#include "net/drop_reason.h"

namespace meshstream {

constexpr uint8_t kPacketMagic = 0xD3;    // no codec datagram (0x4D) nor ASCII text starts so
constexpr uint8_t kPacketVersion = 1;
constexpr size_t kPacketHeaderBytes = 20;  // magic, version, type, reserved, session id, packet number
constexpr size_t kPacketTagBytes = 16;     // the Poly1305 tag
constexpr size_t kPacketOverheadBytes = kPacketHeaderBytes + kPacketTagBytes;
constexpr size_t kMinDatagramBytes = kPacketOverheadBytes;  // an empty payload
// 1500-byte Ethernet MTU less the IPv4 (20) and UDP (8) headers: never fragmented on such paths.
constexpr size_t kMaxDatagramBytes = 1472;
constexpr size_t kMaxPacketPayloadBytes = kMaxDatagramBytes - kPacketOverheadBytes;  // 1436

enum class PacketType : uint8_t {
  kHello = 1,     // client -> server: proves the session key (net/hello.h)
  kHelloAck = 2,  // server -> client: the address challenge
  kData = 3,      // server -> client: one codec datagram, unchanged
};

// Which key seals a type: the client's (client -> server) or the server's.
enum class Direction : uint8_t { kClientToServer = 0, kServerToClient = 1 };
Direction DirectionOf(PacketType type);

struct PacketHeader {
  PacketType type = PacketType::kData;
  uint64_t session_id = 0;
  uint64_t packet_number = 0;
};

// Appends the 20 header bytes.
void WriteHeader(const PacketHeader& header, ByteWriter& out);
// The same kPacketHeaderBytes bytes into `out` (a sender's own buffer).
void EncodeHeader(const PacketHeader& header, uint8_t* out);

// kNone and *header filled, or the first reason the datagram is malformed
// (kTooShort, kTooLong, kBadMagic, kBadVersion, kBadType, kBadReserved);
// *header is untouched then.
DropReason ParseHeader(const uint8_t* data, size_t size, PacketHeader* header);

}  // namespace meshstream

#endif  // MESHSTREAM_NET_PACKET_HEADER_H_
