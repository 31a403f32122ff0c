// Shared helpers of the net/ tests.
#ifndef MESHSTREAM_TESTS_NET_TEST_UTIL_H_
#define MESHSTREAM_TESTS_NET_TEST_UTIL_H_

#include <cstdint>
#include <string>
#include <vector>

#include "net/packet_crypto.h"

namespace meshstream::net_test {

inline std::vector<uint8_t> FromHex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

inline PacketKey CountingKey(uint8_t first) {
  PacketKey k;
  for (size_t i = 0; i < k.size(); ++i) k[i] = static_cast<uint8_t>(first + i);
  return k;
}

}  // namespace meshstream::net_test

#endif  // MESHSTREAM_TESTS_NET_TEST_UTIL_H_
