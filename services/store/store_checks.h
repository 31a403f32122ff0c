// The one validating layer in front of both store backends (docs/design/store.md,
// "One contract, two backends"). Store's public methods (store.h) run these
// checks before they call a backend, so every refusal of an argument has one
// code and one message whichever backend serves the call; ingest
// (services/ingest/) calls the same functions to refuse a request before its
// bytes arrive, instead of keeping a copy of them.
//
// Every refusal here is InvalidArgument and its message starts with the
// field's name ("tenant: ...", "summary.artifact_sha256: ..."). Messages never
// quote the refused value (it may be long or not text).
//
// Contract: safe on untrusted input (any bytes, any length). Thread safety:
// pure functions.
#ifndef MESHSTREAM_SERVICES_STORE_STORE_CHECKS_H_
#define MESHSTREAM_SERVICES_STORE_STORE_CHECKS_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "codec/core/status.h"
#include "proto/api_names.h"

namespace meshstream {

struct ArtifactSummary;
struct NewVersion;

// Names (IsValidName, CheckName) are the API's rules, shared with the
// clients: proto/api_names.h.

// A digest: 64 lower-case hex digits (a SHA-256).
Status CheckDigest(const std::string& field, const std::string& digest);
// Empty, or a digest (an optional expected digest).
Status CheckOptionalDigest(const std::string& field, const std::string& digest);

// Text the store keeps: no NUL byte (PostgreSQL text cannot hold one and
// libpq would cut the value there) and well-formed UTF-8 (codec/core/utf8.h).
Status CheckText(const std::string& field, const std::string& text);

// Keys the store looks rows up by (worker names, cache keys, token hashes):
// 1 to kMaxKeyBytes bytes of text.
constexpr size_t kMaxKeyBytes = 1024;
Status CheckKey(const std::string& field, const std::string& key);

// Numbers the backends store as a signed 64-bit integer.
Status CheckFitsInt64(const std::string& field, uint64_t value);
Status CheckNotNegative(const std::string& field, int64_t value);

// ClaimJob and RenewLease: a worker key, now_ms >= 0, lease_ms > 0, and
// now_ms + lease_ms representable.
Status CheckLeaseArguments(const std::string& worker, int64_t now_ms, int64_t lease_ms);
// RenewLease's progress: within 0..1 (NaN is refused).
Status CheckProgress(double progress);

// What CompleteJob and PutArtifact store: the artifact's digest, figures
// that fit the database and are not negative, text columns.
Status CheckSummary(const ArtifactSummary& summary);

// What CreateVersion stores: names, file names and digests of the source
// and resources, sizes, options, comment and labels.
Status CheckNewVersion(const NewVersion& version);

// Bytes given as `data` and `size` (BlobSink::Append, AppendUpload):
// present when a size is announced ("data: null with N bytes" otherwise).
Status CheckBytes(const uint8_t* data, size_t size);

// AppendUpload: the bytes (CheckBytes), and offset + size representable as a
// signed 64-bit integer.
Status CheckAppend(uint64_t offset, const uint8_t* data, size_t size);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_STORE_CHECKS_H_
