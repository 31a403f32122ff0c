// Sealing and opening meshstream UDP datagrams with the IETF
// ChaCha20-Poly1305 AEAD of libsodium (docs/spec/streaming-protocol.md,
// "Datagram" and "Keys and nonces").
//
// A datagram is the 20-byte header (net/packet_header.h), the payload
// encrypted, and the 16-byte tag; the header is the additional data, so every
// header bit is authenticated too. The 12-byte nonce is a 4-byte constant of
// the type's direction followed by the 64-bit packet number, little-endian.
//
// Contract:
//  - each direction of a session has its own key (SessionKeys), made by
//    NewSessionKeys on the server and sent to the client on the gRPC stream;
//  - a sender never seals two packets with one packet number under one key
//    (one counter per session and direction, shared by HELLO_ACK and DATA);
//    reusing a nonce breaks ChaCha20-Poly1305, and SealPacket cannot check it;
//  - OpenPacket is safe on untrusted input: the header is parsed first, every
//    field checked before the payload is touched, and nothing is written to
//    *out unless the tag verifies. A packet whose type belongs to the other
//    direction is refused as kBadType before any cryptography (a server never
//    accepts its own DATA reflected back at it).
// Thread safety: pure functions; NewSessionKeys and SealPacket may be called
// from any thread (libsodium's initialisation is once and thread-safe).
#ifndef MESHSTREAM_NET_PACKET_CRYPTO_H_
#define MESHSTREAM_NET_PACKET_CRYPTO_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "net/drop_reason.h"
#include "net/packet_header.h"

namespace meshstream {

constexpr size_t kPacketKeyBytes = 32;
constexpr size_t kPacketNonceBytes = 12;
using PacketKey = std::array<uint8_t, kPacketKeyBytes>;

// The nonce's first 4 bytes by direction ("MSCS" client->server, "MSSC" server->client).
constexpr std::array<uint8_t, 4> kClientToServerNonce = {'M', 'S', 'C', 'S'};
constexpr std::array<uint8_t, 4> kServerToClientNonce = {'M', 'S', 'S', 'C'};

struct SessionKeys {
  PacketKey client_to_server{};  // seals HELLO
  PacketKey server_to_client{};  // seals HELLO_ACK and DATA
};

// Two independent random keys from libsodium's CSPRNG; Internal if libsodium
// cannot initialise.
StatusOr<SessionKeys> NewSessionKeys();

// The key of a packet type's direction.
const PacketKey& KeyFor(const SessionKeys& keys, PacketType type);

// The 12-byte nonce of a packet.
std::array<uint8_t, kPacketNonceBytes> PacketNonce(PacketType type, uint64_t packet_number);

// The whole datagram. InvalidArgument when the payload exceeds
// kMaxPacketPayloadBytes (or is null with a size), Internal if libsodium fails.
StatusOr<std::vector<uint8_t>> SealPacket(PacketType type, uint64_t session_id, uint64_t packet_number,
                                          const PacketKey& key, const uint8_t* payload, size_t payload_size);
// The same datagram written into `out` (at least kPacketOverheadBytes +
// payload_size bytes: InvalidArgument otherwise), a sender's reused buffer;
// returns its size.
StatusOr<size_t> SealPacketInto(PacketType type, uint64_t session_id, uint64_t packet_number, const PacketKey& key,
                                const uint8_t* payload, size_t payload_size, uint8_t* out, size_t capacity);

struct OpenedPacket {
  PacketHeader header;
  std::vector<uint8_t> payload;  // the plaintext
};

// kNone and *out filled when the datagram parses, its type travels
// `incoming`, and it authenticates under `key`; otherwise the reason, and
// *out is untouched. The caller checks the replay window after this (never
// before: see net/replay_window.h).
DropReason OpenPacket(const uint8_t* data, size_t size, Direction incoming, const PacketKey& key, OpenedPacket* out);

}  // namespace meshstream

#endif  // MESHSTREAM_NET_PACKET_CRYPTO_H_
