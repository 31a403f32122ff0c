#include "services/auth/api_token.h"

#include <sodium.h>

#include <cstdint>

#include "services/store/blob_store.h"

namespace meshstream {

std::string NewApiToken() {
  if (sodium_init() < 0) return "";  // only when the kernel has no entropy source; callers check LooksLikeApiToken
  uint8_t bytes[32];
  randombytes_buf(bytes, sizeof bytes);
  char hex[2 * sizeof bytes + 1];
  sodium_bin2hex(hex, sizeof hex, bytes, sizeof bytes);
  sodium_memzero(bytes, sizeof bytes);
  return std::string(kApiTokenPrefix) + hex;
}

std::string HashApiToken(const std::string& token) {
  return Sha256Hex(reinterpret_cast<const uint8_t*>(token.data()), token.size());
}

bool LooksLikeApiToken(const std::string& token) {
  const std::string prefix = kApiTokenPrefix;
  if (token.size() != prefix.size() + 64 || token.compare(0, prefix.size(), prefix) != 0) return false;
  return IsSha256Hex(token.substr(prefix.size()));
}

}  // namespace meshstream
