// SHA-256 digests and random ids as the API writes them: 64 lower-case hex
// digits for a digest (every sha256 field of the API, blob names in the
// store), hex for random ids and tokens. The server (services/), the SDK
// and the CLI hash with these, so a digest means the same bytes everywhere.
//
// Contract: pure functions over caller-owned bytes (libsodium underneath,
// initialized once per process). Thread safety: every function may be called
// from any thread; one Sha256Hasher belongs to one thread at a time.
#ifndef MESHSTREAM_PROTO_SHA256_H_
#define MESHSTREAM_PROTO_SHA256_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "codec/core/status.h"

namespace meshstream {

// sodium_init() once per process: Internal when libsodium cannot start
// (then nothing here produces a digest).
Status InitSodium();

// SHA-256 of `size` bytes, as 64 lower-case hex digits ("" when libsodium
// could not be initialized).
std::string Sha256Hex(const uint8_t* data, size_t size);
// True when `digest` is 64 lower-case hex digits.
bool IsSha256Hex(const std::string& digest);
// Lower-case hex of `size` bytes.
std::string ToHex(const uint8_t* data, size_t size);
// `bytes` random bytes from libsodium, as hex (ids, temporary names, tokens).
std::string RandomHex(size_t bytes);

// Incremental SHA-256, for every reader and sink that hashes as bytes pass.
class Sha256Hasher {
 public:
  Sha256Hasher();
  void Update(const uint8_t* data, size_t size);
  // The digest as 64 lower-case hex digits; the hasher is spent afterwards.
  std::string FinishHex();

 private:
  alignas(16) unsigned char state_[128];  // crypto_hash_sha256_state (checked in the .cc)
};

}  // namespace meshstream

#endif  // MESHSTREAM_PROTO_SHA256_H_
