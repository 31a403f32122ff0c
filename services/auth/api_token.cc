#include "services/auth/api_token.h"

#include <cstdint>

#include "proto/sha256.h"

namespace meshstream {

std::string NewApiToken() { return std::string(kApiTokenPrefix) + RandomHex(32); }

std::string HashApiToken(const std::string& token) {
  return Sha256Hex(reinterpret_cast<const uint8_t*>(token.data()), token.size());
}

bool LooksLikeApiToken(const std::string& token) {
  const std::string prefix = kApiTokenPrefix;
  if (token.size() != prefix.size() + 64 || token.compare(0, prefix.size(), prefix) != 0) return false;
  return IsSha256Hex(token.substr(prefix.size()));
}

}  // namespace meshstream
