#include "proto/sha256.h"

#include <vector>

#include <sodium.h>

namespace meshstream {

// sodium_init() is thread-safe and idempotent; its result is kept.
Status InitSodium() {
  static const int result = sodium_init();
  if (result < 0) return Internal("libsodium could not be initialized");
  return Status::Ok();
}

std::string ToHex(const uint8_t* bytes, size_t n) {
  static const char kDigits[] = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (size_t i = 0; i < n; ++i) {
    out[2 * i] = kDigits[bytes[i] >> 4];
    out[2 * i + 1] = kDigits[bytes[i] & 15];
  }
  return out;
}

std::string RandomHex(size_t bytes) {
  (void)InitSodium();
  std::vector<uint8_t> random(bytes);
  randombytes_buf(random.data(), random.size());
  return ToHex(random.data(), random.size());
}

std::string Sha256Hex(const uint8_t* data, size_t size) {
  if (!InitSodium().ok()) return "";
  unsigned char digest[crypto_hash_sha256_BYTES];
  crypto_hash_sha256(digest, data, size);
  return ToHex(digest, sizeof digest);
}

static_assert(sizeof(crypto_hash_sha256_state) <= 128, "Sha256Hasher::state_ is too small");

Sha256Hasher::Sha256Hasher() {
  (void)InitSodium();
  crypto_hash_sha256_init(reinterpret_cast<crypto_hash_sha256_state*>(state_));
}

void Sha256Hasher::Update(const uint8_t* data, size_t size) {
  crypto_hash_sha256_update(reinterpret_cast<crypto_hash_sha256_state*>(state_), data, size);
}

std::string Sha256Hasher::FinishHex() {
  unsigned char digest[crypto_hash_sha256_BYTES];
  crypto_hash_sha256_final(reinterpret_cast<crypto_hash_sha256_state*>(state_), digest);
  return ToHex(digest, sizeof digest);
}

bool IsSha256Hex(const std::string& digest) {
  if (digest.size() != 64) return false;
  for (char c : digest) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace meshstream
