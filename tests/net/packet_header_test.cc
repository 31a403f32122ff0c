#include "net/packet_header.h"

#include <gtest/gtest.h>

#include <vector>

namespace meshstream {
namespace {

std::vector<uint8_t> Datagram(size_t size) {
  ByteWriter w;
  WriteHeader(PacketHeader{PacketType::kData, 0x0123456789ABCDEFull, 0x1122334455667788ull}, w);
  w.bytes().resize(size, 0xEE);
  return w.bytes();
}

TEST(PacketHeader, WritesTheDocumentedBytes) {
  ByteWriter w;
  WriteHeader(PacketHeader{PacketType::kData, 0x0123456789ABCDEFull, 0x1122334455667788ull}, w);
  const std::vector<uint8_t> expected = {0xD3, 0x01, 0x03, 0x00, 0xEF, 0xCD, 0xAB, 0x89, 0x67, 0x45,
                                         0x23, 0x01, 0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11};
  EXPECT_EQ(w.bytes(), expected);
  EXPECT_EQ(w.size(), kPacketHeaderBytes);
}

TEST(PacketHeader, ParsesWhatItWrites) {
  for (PacketType type : {PacketType::kHello, PacketType::kHelloAck, PacketType::kData}) {
    for (uint64_t n : {uint64_t{0}, uint64_t{1}, uint64_t{0x8000000000000000}, UINT64_MAX}) {
      ByteWriter w;
      WriteHeader(PacketHeader{type, ~n, n}, w);
      w.bytes().resize(kMinDatagramBytes);
      PacketHeader h;
      ASSERT_EQ(ParseHeader(w.bytes().data(), w.size(), &h), DropReason::kNone);
      EXPECT_EQ(h.type, type);
      EXPECT_EQ(h.session_id, ~n);
      EXPECT_EQ(h.packet_number, n);
    }
  }
}

TEST(PacketHeader, SizeLimits) {
  PacketHeader h;
  EXPECT_EQ(ParseHeader(nullptr, 0, &h), DropReason::kTooShort);
  for (size_t size = 0; size < kMinDatagramBytes; ++size) {
    const auto d = Datagram(size);
    EXPECT_EQ(ParseHeader(d.data(), size, &h), DropReason::kTooShort) << size;
  }
  auto d = Datagram(kMaxDatagramBytes + 1);
  EXPECT_EQ(ParseHeader(d.data(), d.size(), &h), DropReason::kTooLong);
  EXPECT_EQ(ParseHeader(d.data(), kMaxDatagramBytes, &h), DropReason::kNone);
  EXPECT_EQ(ParseHeader(d.data(), kMinDatagramBytes, &h), DropReason::kNone);
}

TEST(PacketHeader, EachFieldItsReason) {
  PacketHeader h;
  h.session_id = 42;
  auto d = Datagram(kMinDatagramBytes);
  d[0] = 0x4D;  // a codec datagram's magic
  EXPECT_EQ(ParseHeader(d.data(), d.size(), &h), DropReason::kBadMagic);
  d = Datagram(kMinDatagramBytes);
  d[1] = 2;
  EXPECT_EQ(ParseHeader(d.data(), d.size(), &h), DropReason::kBadVersion);
  for (int type : {0, 4, 255}) {
    d = Datagram(kMinDatagramBytes);
    d[2] = static_cast<uint8_t>(type);
    EXPECT_EQ(ParseHeader(d.data(), d.size(), &h), DropReason::kBadType);
  }
  d = Datagram(kMinDatagramBytes);
  d[3] = 1;
  EXPECT_EQ(ParseHeader(d.data(), d.size(), &h), DropReason::kBadReserved);
  EXPECT_EQ(h.session_id, 42u);  // untouched on a refusal
}

TEST(PacketHeader, Directions) {
  EXPECT_EQ(DirectionOf(PacketType::kHello), Direction::kClientToServer);
  EXPECT_EQ(DirectionOf(PacketType::kHelloAck), Direction::kServerToClient);
  EXPECT_EQ(DirectionOf(PacketType::kData), Direction::kServerToClient);
}

}  // namespace
}  // namespace meshstream
