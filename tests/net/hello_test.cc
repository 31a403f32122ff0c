#include "net/hello.h"

#include <gtest/gtest.h>

#include "net/amplification_limit.h"
#include "net/drop_reason.h"
#include "net/packet_crypto.h"

namespace meshstream {
namespace {

TEST(Hello, PayloadRoundTripAndSizes) {
  const auto c = NewChallenge();
  ASSERT_TRUE(c.ok());
  const auto payload = HelloPayload(*c);
  EXPECT_EQ(payload.size() + kPacketOverheadBytes, kHelloDatagramBytes);
  const auto echo = ParseHelloPayload(payload);
  ASSERT_TRUE(echo.ok());
  EXPECT_TRUE(SameChallenge(*echo, *c));
  const auto ack = ParseHelloAckPayload(HelloAckPayload(*c));
  ASSERT_TRUE(ack.ok());
  EXPECT_TRUE(SameChallenge(*ack, *c));
  // The anti-amplification rule holds by construction: the answer is smaller than the question.
  static_assert(kHelloAckDatagramBytes <= kHelloDatagramBytes, "HELLO_ACK must not amplify");
}

TEST(Hello, RefusesWrongSizesAndPadding) {
  Challenge zero{};
  auto payload = HelloPayload(zero);
  payload.back() = 1;
  EXPECT_EQ(ParseHelloPayload(payload).status().code(), StatusCode::kInvalidInput);
  payload.pop_back();
  EXPECT_EQ(ParseHelloPayload(payload).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(ParseHelloPayload({}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(ParseHelloAckPayload(std::vector<uint8_t>(15)).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(ParseHelloAckPayload(std::vector<uint8_t>(17)).status().code(), StatusCode::kInvalidInput);
}

TEST(Hello, ChallengesDiffer) {
  const auto a = NewChallenge();
  const auto b = NewChallenge();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_FALSE(SameChallenge(*a, *b));
  Challenge c = *a;
  c[15] ^= 0x80;
  EXPECT_FALSE(SameChallenge(*a, c));
}

TEST(AmplificationLimit, NeverMoreThanReceivedBeforeProof) {
  AmplificationLimit limit;
  EXPECT_FALSE(limit.MaySend(PacketType::kHelloAck, 1));  // nothing received yet
  limit.OnReceived(kHelloDatagramBytes);
  EXPECT_TRUE(limit.MaySend(PacketType::kHelloAck, kHelloAckDatagramBytes));
  EXPECT_FALSE(limit.MaySend(PacketType::kHelloAck, kHelloDatagramBytes + 1));
  EXPECT_FALSE(limit.MaySend(PacketType::kData, 10));  // fragments only to a proven address
  size_t sent = 0;
  while (limit.MaySend(PacketType::kHelloAck, kHelloAckDatagramBytes)) {
    limit.OnSent(kHelloAckDatagramBytes);
    sent += kHelloAckDatagramBytes;
  }
  EXPECT_LE(sent, kHelloDatagramBytes);
  EXPECT_GT(sent + kHelloAckDatagramBytes, kHelloDatagramBytes);
  limit.MarkProven();
  EXPECT_TRUE(limit.proven());
  EXPECT_TRUE(limit.MaySend(PacketType::kData, kMaxDatagramBytes));
}

TEST(DropCounters, CountsByReason) {
  DropCounters c;
  c.Count(DropReason::kNone);
  c.Count(DropReason::kAuthFailed);
  c.Count(DropReason::kAuthFailed);
  c.Count(DropReason::kBadPayload);
  EXPECT_EQ(c.accepted(), 1u);
  EXPECT_EQ(c.Get(DropReason::kAuthFailed), 2u);
  EXPECT_EQ(c.dropped(), 3u);
  EXPECT_STREQ(DropReasonName(DropReason::kAuthFailed), "auth_failed");
  EXPECT_STREQ(DropReasonName(DropReason::kBadPayload), "bad_payload");
  EXPECT_EQ(static_cast<size_t>(DropReason::kBadPayload) + 1, kDropReasonCount);
}

}  // namespace
}  // namespace meshstream
