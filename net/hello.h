// The payloads of HELLO and HELLO_ACK, the handshake by which a client's UDP
// address proves it holds the session key (docs/spec/streaming-protocol.md,
// "HELLO and address validation").
//
// HELLO (client -> server) is exactly kHelloDatagramBytes on the wire: a
// 16-byte echo of the server's challenge (all zero before the client has
// one), then zero padding. HELLO_ACK (server -> client) carries a fresh
// 16-byte challenge for the address the HELLO came from. An address is proven
// when an authenticated HELLO from it echoes the challenge last sent to it.
//
// Contract: the parsers take the plaintext of a packet OpenPacket accepted;
// they are safe on any bytes and return InvalidInput (the caller counts
// kBadPayload) for a wrong size or non-zero padding.
// Thread safety: pure functions; NewChallenge uses libsodium's CSPRNG.
#ifndef MESHSTREAM_NET_HELLO_H_
#define MESHSTREAM_NET_HELLO_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "net/packet_header.h"

namespace meshstream {

constexpr size_t kChallengeBytes = 16;
using Challenge = std::array<uint8_t, kChallengeBytes>;

// A HELLO is padded to this, so that it is at least as large as anything the
// server sends an unproven address in reply (a HELLO_ACK, 52 bytes).
constexpr size_t kHelloDatagramBytes = 1200;
constexpr size_t kHelloPayloadBytes = kHelloDatagramBytes - kPacketOverheadBytes;   // 1164
constexpr size_t kHelloAckPayloadBytes = kChallengeBytes;                           // 16
constexpr size_t kHelloAckDatagramBytes = kHelloAckPayloadBytes + kPacketOverheadBytes;  // 52

// A random challenge; Internal if libsodium cannot initialise.
StatusOr<Challenge> NewChallenge();

// HELLO's plaintext: `echo` (zero for the first HELLO) and the padding.
std::vector<uint8_t> HelloPayload(const Challenge& echo);
// The echo of a HELLO's plaintext.
StatusOr<Challenge> ParseHelloPayload(const std::vector<uint8_t>& payload);

// HELLO_ACK's plaintext: the challenge.
std::vector<uint8_t> HelloAckPayload(const Challenge& challenge);
StatusOr<Challenge> ParseHelloAckPayload(const std::vector<uint8_t>& payload);

// Constant-time equality (the challenge is a secret until echoed).
bool SameChallenge(const Challenge& a, const Challenge& b);

}  // namespace meshstream

#endif  // MESHSTREAM_NET_HELLO_H_
