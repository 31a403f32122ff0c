#include "services/store/page_token.h"

#include <sodium.h>

#include <cstring>
#include <vector>

#include "services/store/store.h"

namespace meshstream {

namespace {

constexpr size_t kCheckBytes = 4;
constexpr char kDomain[] = "meshstream page token v1";

// The first kCheckBytes of SHA-256(domain || payload). crypto_hash_sha256
// needs no sodium_init (it uses no random numbers and no CPU dispatch state
// that could be uninitialized).
void CheckValue(const std::string& payload, unsigned char out[kCheckBytes]) {
  crypto_hash_sha256_state state;
  crypto_hash_sha256_init(&state);
  crypto_hash_sha256_update(&state, reinterpret_cast<const unsigned char*>(kDomain), sizeof kDomain);
  crypto_hash_sha256_update(&state, reinterpret_cast<const unsigned char*>(payload.data()), payload.size());
  unsigned char digest[crypto_hash_sha256_BYTES];
  crypto_hash_sha256_final(&state, digest);
  std::memcpy(out, digest, kCheckBytes);
}

Status NotOurs() { return InvalidArgument("page_token: not a token this server issued"); }

}  // namespace

std::string EncodePageToken(const std::string& kind, const std::string& cursor) {
  std::string payload = kind;
  payload.push_back('\0');
  payload += cursor;
  unsigned char check[kCheckBytes];
  CheckValue(payload, check);
  payload.append(reinterpret_cast<const char*>(check), kCheckBytes);
  const int variant = sodium_base64_VARIANT_URLSAFE_NO_PADDING;
  std::string out(sodium_base64_ENCODED_LEN(payload.size(), variant), '\0');
  sodium_bin2base64(out.data(), out.size(), reinterpret_cast<const unsigned char*>(payload.data()), payload.size(),
                    variant);
  out.resize(std::strlen(out.c_str()));
  return out;
}

StatusOr<std::string> DecodePageToken(const std::string& kind, const std::string& token) {
  if (token.empty()) return std::string();
  if (token.size() > kMaxPageTokenChars) return NotOurs();
  // Only base64url characters: libsodium 1.0.18 reads every byte >= 0x80 as
  // '_', so a token would otherwise have many spellings (found by
  // fuzz_service_page_token).
  for (const char c : token) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
    if (!ok) return NotOurs();
  }
  std::vector<unsigned char> bytes(token.size());
  size_t length = 0;
  const char* end = nullptr;
  if (sodium_base642bin(bytes.data(), bytes.size(), token.data(), token.size(), nullptr, &length, &end,
                        sodium_base64_VARIANT_URLSAFE_NO_PADDING) != 0 ||
      end != token.data() + token.size() || length < kCheckBytes + 1) {
    return NotOurs();
  }
  const std::string payload(reinterpret_cast<const char*>(bytes.data()), length - kCheckBytes);
  unsigned char check[kCheckBytes];
  CheckValue(payload, check);
  if (std::memcmp(check, bytes.data() + payload.size(), kCheckBytes) != 0) return NotOurs();
  const size_t nul = payload.find('\0');
  if (nul == std::string::npos || payload.compare(0, nul, kind) != 0 || nul != kind.size()) return NotOurs();
  return payload.substr(nul + 1);
}

StatusOr<int32_t> EffectivePageSize(int32_t requested) {
  if (requested < 0) return InvalidArgument("page_size: must not be negative");
  if (requested == 0) return kDefaultPageSize;
  return requested > kMaxPageSize ? kMaxPageSize : requested;
}

std::string EncodeAssetsPageToken(const std::string& last_name) {
  return EncodePageToken(kAssetsPageKind, last_name);
}

StatusOr<std::string> DecodeAssetsPageToken(const std::string& token) {
  MS_ASSIGN_OR_RETURN(std::string cursor, DecodePageToken(kAssetsPageKind, token));
  if (!token.empty() && !IsValidName(cursor)) return NotOurs();
  return cursor;
}

std::string EncodeVersionsPageToken(int64_t last_version) {
  return EncodePageToken(kVersionsPageKind, std::to_string(last_version));
}

StatusOr<int64_t> DecodeVersionsPageToken(const std::string& token) {
  MS_ASSIGN_OR_RETURN(std::string cursor, DecodePageToken(kVersionsPageKind, token));
  if (token.empty()) return int64_t{0};
  // 1 to 18 decimal digits, no sign, no leading zero: always fits an int64.
  if (cursor.empty() || cursor.size() > 18 || cursor[0] == '0') return NotOurs();
  int64_t value = 0;
  for (const char c : cursor) {
    if (c < '0' || c > '9') return NotOurs();
    value = value * 10 + (c - '0');
  }
  return value;
}

}  // namespace meshstream
