#include "net/packet_crypto.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "net/hello.h"
#include "tests/net/test_util.h"

namespace meshstream {
namespace {

using net_test::CountingKey;
using net_test::FromHex;

constexpr uint64_t kSession = 0x0123456789ABCDEFull;

std::vector<uint8_t> Bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

std::vector<uint8_t> Seal(PacketType type, uint64_t pn, const PacketKey& key, const std::vector<uint8_t>& payload) {
  auto sealed = SealPacket(type, kSession, pn, key, payload.data(), payload.size());
  EXPECT_TRUE(sealed.ok()) << sealed.status().ToString();
  return sealed.ok() ? *sealed : std::vector<uint8_t>{};
}

// docs/spec/streaming-protocol.md, "Test vectors" (computed independently with
// Python's cryptography package, not with this code).
TEST(PacketCrypto, DataTestVector) {
  const auto sealed = Seal(PacketType::kData, 0x1122334455667788ull, CountingKey(0x00), Bytes("meshstream"));
  EXPECT_EQ(sealed, FromHex("d3010300efcdab896745230188776655443322112d84548d74e536cbfcd231d4363063676bd7bce0784d"
                            "11322e92"));
  OpenedPacket opened;
  ASSERT_EQ(OpenPacket(sealed.data(), sealed.size(), Direction::kServerToClient, CountingKey(0x00), &opened),
            DropReason::kNone);
  EXPECT_EQ(opened.payload, Bytes("meshstream"));
  EXPECT_EQ(opened.header.packet_number, 0x1122334455667788ull);
}

TEST(PacketCrypto, HelloTestVector) {
  Challenge echo;
  for (size_t i = 0; i < echo.size(); ++i) echo[i] = static_cast<uint8_t>(0xA0 + i);
  const auto sealed = Seal(PacketType::kHello, 1, CountingKey(0x20), HelloPayload(echo));
  ASSERT_EQ(sealed.size(), kHelloDatagramBytes);
  EXPECT_EQ(std::vector<uint8_t>(sealed.begin(), sealed.begin() + 36),
            FromHex("d3010100efcdab89674523010100000000000000e3183efa9e1eb8d9f85b0e6094a40dd5"));
  EXPECT_EQ(std::vector<uint8_t>(sealed.end() - 16, sealed.end()), FromHex("b376303d4e9e5f3d760013a4377aa6d2"));
}

TEST(PacketCrypto, HelloAckTestVector) {
  Challenge challenge;
  for (size_t i = 0; i < challenge.size(); ++i) challenge[i] = static_cast<uint8_t>(0xA0 + i);
  const auto sealed = Seal(PacketType::kHelloAck, 0, CountingKey(0x00), HelloAckPayload(challenge));
  EXPECT_EQ(sealed.size(), kHelloAckDatagramBytes);
  EXPECT_EQ(sealed, FromHex("d3010200efcdab8967452301000000000000000061ed76e6e30fe70e41227fe98db72162f6d5ac7eddab8a"
                            "f3df645479fb8ccde1"));
}

TEST(PacketCrypto, RoundTripEveryTypeAndSize) {
  const auto keys = NewSessionKeys();
  ASSERT_TRUE(keys.ok());
  for (PacketType type : {PacketType::kHello, PacketType::kHelloAck, PacketType::kData}) {
    for (size_t size : {size_t{0}, size_t{1}, size_t{1200}, kMaxPacketPayloadBytes}) {
      std::vector<uint8_t> payload(size);
      for (size_t i = 0; i < size; ++i) payload[i] = static_cast<uint8_t>(i * 7);
      const auto sealed = Seal(type, 77, KeyFor(*keys, type), payload);
      ASSERT_EQ(sealed.size(), size + kPacketOverheadBytes);
      OpenedPacket opened;
      ASSERT_EQ(OpenPacket(sealed.data(), sealed.size(), DirectionOf(type), KeyFor(*keys, type), &opened),
                DropReason::kNone);
      EXPECT_EQ(opened.header.type, type);
      EXPECT_EQ(opened.header.session_id, kSession);
      EXPECT_EQ(opened.header.packet_number, 77u);
      EXPECT_EQ(opened.payload, payload);
    }
  }
}

TEST(PacketCrypto, EveryBitFlipIsRefused) {
  const auto sealed = Seal(PacketType::kData, 5, CountingKey(0x00), Bytes("refinement datagram"));
  for (size_t bit = 0; bit < sealed.size() * 8; ++bit) {
    auto flipped = sealed;
    flipped[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    OpenedPacket opened;
    opened.payload = {9};
    const DropReason r = OpenPacket(flipped.data(), flipped.size(), Direction::kServerToClient, CountingKey(0x00), &opened);
    EXPECT_NE(r, DropReason::kNone) << "bit " << bit;
    if (bit / 8 >= 4) {
      EXPECT_EQ(r, DropReason::kAuthFailed) << "bit " << bit;
    }
    EXPECT_EQ(opened.payload, std::vector<uint8_t>{9}) << "touched on refusal, bit " << bit;
  }
}

TEST(PacketCrypto, WrongKeyOrDirectionIsRefused) {
  const auto keys = NewSessionKeys();
  ASSERT_TRUE(keys.ok());
  const auto data = Seal(PacketType::kData, 1, keys->server_to_client, Bytes("x"));
  OpenedPacket opened;
  // The other direction's key.
  EXPECT_EQ(OpenPacket(data.data(), data.size(), Direction::kServerToClient, keys->client_to_server, &opened),
            DropReason::kAuthFailed);
  // A server never accepts its own DATA reflected back at it.
  EXPECT_EQ(OpenPacket(data.data(), data.size(), Direction::kClientToServer, keys->server_to_client, &opened),
            DropReason::kBadType);
  // A HELLO sealed with the server's key, or retyped: the nonce prefix and the additional data differ.
  const auto hello = Seal(PacketType::kHello, 1, keys->server_to_client, Bytes("x"));
  EXPECT_EQ(OpenPacket(hello.data(), hello.size(), Direction::kClientToServer, keys->client_to_server, &opened),
            DropReason::kAuthFailed);
  auto retyped = Seal(PacketType::kHelloAck, 1, keys->server_to_client, Bytes("x"));
  retyped[2] = static_cast<uint8_t>(PacketType::kData);
  EXPECT_EQ(OpenPacket(retyped.data(), retyped.size(), Direction::kServerToClient, keys->server_to_client, &opened),
            DropReason::kAuthFailed);
  // Another session id with the same key and packet number.
  auto other = data;
  other[4] ^= 1;
  EXPECT_EQ(OpenPacket(other.data(), other.size(), Direction::kServerToClient, keys->server_to_client, &opened),
            DropReason::kAuthFailed);
}

TEST(PacketCrypto, TruncatedAndOversized) {
  const auto sealed = Seal(PacketType::kData, 1, CountingKey(0), std::vector<uint8_t>(100, 1));
  OpenedPacket opened;
  for (size_t size = 0; size < sealed.size(); ++size) {
    const DropReason r = OpenPacket(sealed.data(), size, Direction::kServerToClient, CountingKey(0), &opened);
    EXPECT_EQ(r, size < kMinDatagramBytes ? DropReason::kTooShort : DropReason::kAuthFailed) << size;
  }
  std::vector<uint8_t> big(kMaxDatagramBytes + 1, 0);
  for (size_t i = 0; i < kPacketHeaderBytes; ++i) big[i] = sealed[i];
  EXPECT_EQ(OpenPacket(big.data(), big.size(), Direction::kServerToClient, CountingKey(0), &opened), DropReason::kTooLong);

  const std::vector<uint8_t> too_much(kMaxPacketPayloadBytes + 1);
  const auto refused = SealPacket(PacketType::kData, 1, 1, CountingKey(0), too_much.data(), too_much.size());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(SealPacket(PacketType::kData, 1, 1, CountingKey(0), nullptr, 3).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(SealPacket(static_cast<PacketType>(9), 1, 1, CountingKey(0), nullptr, 0).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(PacketCrypto, KeysAreRandomAndDistinct) {
  const auto a = NewSessionKeys();
  const auto b = NewSessionKeys();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE(a->client_to_server, a->server_to_client);
  EXPECT_NE(a->client_to_server, b->client_to_server);
  EXPECT_NE(a->server_to_client, b->server_to_client);
  EXPECT_NE(a->client_to_server, PacketKey{});
  EXPECT_EQ(&KeyFor(*a, PacketType::kHello), &a->client_to_server);
  EXPECT_EQ(&KeyFor(*a, PacketType::kData), &a->server_to_client);
  EXPECT_EQ(&KeyFor(*a, PacketType::kHelloAck), &a->server_to_client);
}

TEST(PacketCrypto, NonceLayout) {
  const auto n = PacketNonce(PacketType::kHello, 0x0102030405060708ull);
  const std::array<uint8_t, 12> expected = {'M', 'S', 'C', 'S', 8, 7, 6, 5, 4, 3, 2, 1};
  EXPECT_EQ(n, expected);
  EXPECT_EQ(PacketNonce(PacketType::kData, 0)[2], 'S');
}

}  // namespace
}  // namespace meshstream

namespace meshstream {
namespace {

// The fuzz seeds are real packets under the vectors' keys, so the replay
// exercises the accepting path (all but codec_magic, which must be refused).
TEST(PacketCrypto, FuzzSeedsAuthenticate) {
  const SessionKeys keys{net_test::CountingKey(0x20), net_test::CountingKey(0x00)};
  size_t opened_count = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(MESHSTREAM_SOURCE_DIR) + "/tests/fuzz/corpus/net_packet")) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    PacketHeader header;
    const DropReason parsed = ParseHeader(bytes.data(), bytes.size(), &header);
    if (entry.path().filename() == "codec_magic") {
      EXPECT_EQ(parsed, DropReason::kBadMagic);
      continue;
    }
    ASSERT_EQ(parsed, DropReason::kNone) << entry.path();
    OpenedPacket opened;
    EXPECT_EQ(OpenPacket(bytes.data(), bytes.size(), DirectionOf(header.type), KeyFor(keys, header.type), &opened),
              DropReason::kNone)
        << entry.path();
    ++opened_count;
  }
  EXPECT_GE(opened_count, 5u);
}

}  // namespace
}  // namespace meshstream
