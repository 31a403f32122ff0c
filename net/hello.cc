#include "net/hello.h"

#include <sodium.h>

#include <string>

namespace meshstream {

StatusOr<Challenge> NewChallenge() {
  if (sodium_init() < 0) return Internal("libsodium failed to initialise");
  Challenge c;
  randombytes_buf(c.data(), c.size());
  return c;
}

std::vector<uint8_t> HelloPayload(const Challenge& echo) {
  std::vector<uint8_t> payload(kHelloPayloadBytes, 0);
  for (size_t i = 0; i < echo.size(); ++i) payload[i] = echo[i];
  return payload;
}

StatusOr<Challenge> ParseHelloPayload(const std::vector<uint8_t>& payload) {
  if (payload.size() != kHelloPayloadBytes) {
    return InvalidInput("HELLO payload of " + std::to_string(payload.size()) + " bytes, expected " +
                        std::to_string(kHelloPayloadBytes));
  }
  for (size_t i = kChallengeBytes; i < payload.size(); ++i) {
    if (payload[i] != 0) return InvalidInput("HELLO padding byte " + std::to_string(i) + " is not zero");
  }
  Challenge echo;
  for (size_t i = 0; i < echo.size(); ++i) echo[i] = payload[i];
  return echo;
}

std::vector<uint8_t> HelloAckPayload(const Challenge& challenge) {
  return std::vector<uint8_t>(challenge.begin(), challenge.end());
}

StatusOr<Challenge> ParseHelloAckPayload(const std::vector<uint8_t>& payload) {
  if (payload.size() != kHelloAckPayloadBytes) {
    return InvalidInput("HELLO_ACK payload of " + std::to_string(payload.size()) + " bytes, expected " +
                        std::to_string(kHelloAckPayloadBytes));
  }
  Challenge c;
  for (size_t i = 0; i < c.size(); ++i) c[i] = payload[i];
  return c;
}

bool SameChallenge(const Challenge& a, const Challenge& b) {
  uint8_t diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<uint8_t>(a[i] ^ b[i]);
  return diff == 0;
}

}  // namespace meshstream
