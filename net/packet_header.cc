#include "net/packet_header.h"

namespace meshstream {

Direction DirectionOf(PacketType type) {
  return type == PacketType::kHello ? Direction::kClientToServer : Direction::kServerToClient;
}

void EncodeHeader(const PacketHeader& header, uint8_t* out) {
  out[0] = kPacketMagic;
  out[1] = kPacketVersion;
  out[2] = static_cast<uint8_t>(header.type);
  out[3] = 0;
  for (int i = 0; i < 8; ++i) out[4 + i] = static_cast<uint8_t>(header.session_id >> (8 * i));
  for (int i = 0; i < 8; ++i) out[12 + i] = static_cast<uint8_t>(header.packet_number >> (8 * i));
}

void WriteHeader(const PacketHeader& header, ByteWriter& out) {
  uint8_t bytes[kPacketHeaderBytes];
  EncodeHeader(header, bytes);
  for (uint8_t b : bytes) out.U8(b);
}

namespace {

// Both halves of a little-endian 64-bit field; the size was checked before.
uint64_t U64(ByteReader& r) {
  const StatusOr<uint32_t> low = r.U32("u64 low");
  const StatusOr<uint32_t> high = r.U32("u64 high");
  if (!low.ok() || !high.ok()) return 0;  // unreachable: ParseHeader checked the size
  return (static_cast<uint64_t>(*high) << 32) | *low;
}

}  // namespace

DropReason ParseHeader(const uint8_t* data, size_t size, PacketHeader* header) {
  if (data == nullptr || size < kMinDatagramBytes) return DropReason::kTooShort;
  if (size > kMaxDatagramBytes) return DropReason::kTooLong;
  if (data[0] != kPacketMagic) return DropReason::kBadMagic;
  if (data[1] != kPacketVersion) return DropReason::kBadVersion;
  const uint8_t type = data[2];
  if (type != static_cast<uint8_t>(PacketType::kHello) && type != static_cast<uint8_t>(PacketType::kHelloAck) &&
      type != static_cast<uint8_t>(PacketType::kData)) {
    return DropReason::kBadType;
  }
  if (data[3] != 0) return DropReason::kBadReserved;
  ByteReader r(data + 4, kPacketHeaderBytes - 4);
  PacketHeader parsed;
  parsed.type = static_cast<PacketType>(type);
  parsed.session_id = U64(r);
  parsed.packet_number = U64(r);
  *header = parsed;
  return DropReason::kNone;
}

}  // namespace meshstream
