#include "net/packet_crypto.h"

#include <sodium.h>

#include <algorithm>

namespace meshstream {

namespace {

bool SodiumReady() {
  // sodium_init is idempotent and thread-safe: 0 first time, 1 after, -1 on failure.
  static const bool ready = sodium_init() >= 0;
  return ready;
}

}  // namespace

StatusOr<SessionKeys> NewSessionKeys() {
  if (!SodiumReady()) return Internal("libsodium failed to initialise");
  SessionKeys keys;
  crypto_aead_chacha20poly1305_ietf_keygen(keys.client_to_server.data());
  crypto_aead_chacha20poly1305_ietf_keygen(keys.server_to_client.data());
  return keys;
}

const PacketKey& KeyFor(const SessionKeys& keys, PacketType type) {
  return DirectionOf(type) == Direction::kClientToServer ? keys.client_to_server : keys.server_to_client;
}

std::array<uint8_t, kPacketNonceBytes> PacketNonce(PacketType type, uint64_t packet_number) {
  std::array<uint8_t, kPacketNonceBytes> nonce{};
  const auto& prefix =
      DirectionOf(type) == Direction::kClientToServer ? kClientToServerNonce : kServerToClientNonce;
  for (size_t i = 0; i < prefix.size(); ++i) nonce[i] = prefix[i];
  for (size_t i = 0; i < 8; ++i) nonce[4 + i] = static_cast<uint8_t>(packet_number >> (8 * i));
  return nonce;
}

StatusOr<size_t> SealPacketInto(PacketType type, uint64_t session_id, uint64_t packet_number, const PacketKey& key,
                                const uint8_t* payload, size_t payload_size, uint8_t* out, size_t capacity) {
  static_assert(crypto_aead_chacha20poly1305_ietf_KEYBYTES == kPacketKeyBytes, "key size");
  static_assert(crypto_aead_chacha20poly1305_ietf_NPUBBYTES == kPacketNonceBytes, "nonce size");
  static_assert(crypto_aead_chacha20poly1305_ietf_ABYTES == kPacketTagBytes, "tag size");
  if (type != PacketType::kHello && type != PacketType::kHelloAck && type != PacketType::kData) {
    return InvalidArgument("SealPacket: packet type " + std::to_string(static_cast<int>(type)) + " does not exist");
  }
  if (payload_size > kMaxPacketPayloadBytes) {
    return InvalidArgument("SealPacket: payload of " + std::to_string(payload_size) + " bytes exceeds " +
                           std::to_string(kMaxPacketPayloadBytes));
  }
  if (payload == nullptr && payload_size != 0) return InvalidArgument("SealPacket: null payload");
  const size_t size = kPacketOverheadBytes + payload_size;
  if (out == nullptr || capacity < size) {
    return InvalidArgument("SealPacket: a buffer of " + std::to_string(capacity) + " bytes for " +
                           std::to_string(size));
  }
  if (!SodiumReady()) return Internal("libsodium failed to initialise");
  EncodeHeader(PacketHeader{type, session_id, packet_number}, out);
  const auto nonce = PacketNonce(type, packet_number);
  unsigned long long sealed = 0;
  static const uint8_t kEmpty = 0;
  if (crypto_aead_chacha20poly1305_ietf_encrypt(out + kPacketHeaderBytes, &sealed, payload_size ? payload : &kEmpty,
                                                payload_size, out, kPacketHeaderBytes, nullptr, nonce.data(),
                                                key.data()) != 0 ||
      sealed != payload_size + kPacketTagBytes) {
    return Internal("SealPacket: libsodium refused to encrypt");
  }
  return size;
}

StatusOr<std::vector<uint8_t>> SealPacket(PacketType type, uint64_t session_id, uint64_t packet_number,
                                          const PacketKey& key, const uint8_t* payload, size_t payload_size) {
  std::vector<uint8_t> out(kPacketOverheadBytes + std::min(payload_size, kMaxPacketPayloadBytes));
  auto size = SealPacketInto(type, session_id, packet_number, key, payload, payload_size, out.data(), out.size());
  if (!size.ok()) return size.status();
  out.resize(size.value());
  return out;
}

DropReason OpenPacket(const uint8_t* data, size_t size, Direction incoming, const PacketKey& key, OpenedPacket* out) {
  PacketHeader header;
  const DropReason parsed = ParseHeader(data, size, &header);
  if (parsed != DropReason::kNone) return parsed;
  if (DirectionOf(header.type) != incoming) return DropReason::kBadType;
  if (!SodiumReady()) return DropReason::kAuthFailed;  // never accept what could not be checked
  const size_t sealed = size - kPacketHeaderBytes;     // >= kPacketTagBytes: ParseHeader checked the size
  std::vector<uint8_t> plain(sealed - kPacketTagBytes);
  const auto nonce = PacketNonce(header.type, header.packet_number);
  uint8_t scratch = 0;
  unsigned long long opened = 0;
  if (crypto_aead_chacha20poly1305_ietf_decrypt(plain.empty() ? &scratch : plain.data(), &opened, nullptr,
                                                data + kPacketHeaderBytes, sealed, data, kPacketHeaderBytes,
                                                nonce.data(), key.data()) != 0 ||
      opened != plain.size()) {
    return DropReason::kAuthFailed;
  }
  out->header = header;
  out->payload = std::move(plain);
  return DropReason::kNone;
}

}  // namespace meshstream
