#include "services/store/store_checks.h"

#include <cmath>
#include <limits>

#include "codec/core/utf8.h"
#include "services/store/blob_store.h"
#include "services/store/store.h"

namespace meshstream {

namespace {

constexpr int64_t kInt64Max = std::numeric_limits<int64_t>::max();

// A file name of a version (the source, a resource): 1 or more bytes of text.
Status CheckFileName(const std::string& field, const std::string& name) {
  if (name.empty()) return InvalidArgument(field + ": must not be empty");
  return CheckText(field, name);
}

}  // namespace

Status CheckDigest(const std::string& field, const std::string& digest) {
  if (IsSha256Hex(digest)) return Status::Ok();
  return InvalidArgument(field + ": not a SHA-256 (64 lower-case hex digits)");
}

Status CheckOptionalDigest(const std::string& field, const std::string& digest) {
  return digest.empty() ? Status::Ok() : CheckDigest(field, digest);
}

Status CheckText(const std::string& field, const std::string& text) {
  if (text.find('\0') != std::string::npos) return InvalidArgument(field + ": contains a NUL byte");
  if (!IsValidUtf8(text)) return InvalidArgument(field + ": is not valid UTF-8");
  return Status::Ok();
}

Status CheckKey(const std::string& field, const std::string& key) {
  if (key.empty()) return InvalidArgument(field + ": must not be empty");
  if (key.size() > kMaxKeyBytes) {
    return InvalidArgument(field + ": " + std::to_string(key.size()) + " bytes, at most " +
                           std::to_string(kMaxKeyBytes));
  }
  return CheckText(field, key);
}

Status CheckFitsInt64(const std::string& field, uint64_t value) {
  if (value <= static_cast<uint64_t>(kInt64Max)) return Status::Ok();
  return InvalidArgument(field + ": " + std::to_string(value) + " does not fit a 64-bit signed integer");
}

Status CheckNotNegative(const std::string& field, int64_t value) {
  if (value >= 0) return Status::Ok();
  return InvalidArgument(field + ": " + std::to_string(value) + " is negative");
}

Status CheckLeaseArguments(const std::string& worker, int64_t now_ms, int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckKey("worker", worker));
  MS_RETURN_IF_ERROR(CheckNotNegative("now_ms", now_ms));
  if (lease_ms <= 0) return InvalidArgument("lease_ms: " + std::to_string(lease_ms) + " is not positive");
  if (now_ms > kInt64Max - lease_ms) return InvalidArgument("lease_ms: now_ms + lease_ms overflows");
  return Status::Ok();
}

Status CheckProgress(double progress) {
  if (progress >= 0.0 && progress <= 1.0) return Status::Ok();  // false for NaN
  return InvalidArgument("progress: must be between 0 and 1");
}

Status CheckSummary(const ArtifactSummary& s) {
  MS_RETURN_IF_ERROR(CheckDigest("summary.artifact_sha256", s.artifact_sha256));
  MS_RETURN_IF_ERROR(CheckFitsInt64("summary.progressive_bytes", s.progressive_bytes));
  MS_RETURN_IF_ERROR(CheckFitsInt64("summary.reliable_bytes", s.reliable_bytes));
  MS_RETURN_IF_ERROR(CheckFitsInt64("summary.unreliable_bytes", s.unreliable_bytes));
  MS_RETURN_IF_ERROR(CheckNotNegative("summary.vertices", s.vertices));
  MS_RETURN_IF_ERROR(CheckNotNegative("summary.faces", s.faces));
  MS_RETURN_IF_ERROR(CheckNotNegative("summary.levels", s.levels));
  MS_RETURN_IF_ERROR(CheckText("summary.encoder", s.encoder));
  MS_RETURN_IF_ERROR(CheckText("summary.layout_json", s.layout_json));
  return CheckText("summary.warnings_json", s.warnings_json);
}

Status CheckNewVersion(const NewVersion& v) {
  MS_RETURN_IF_ERROR(CheckName("tenant", v.tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", v.asset));
  MS_RETURN_IF_ERROR(CheckFileName("source.name", v.source.name));
  MS_RETURN_IF_ERROR(CheckDigest("source.sha256", v.source.sha256));
  MS_RETURN_IF_ERROR(CheckFitsInt64("source.size", v.source.size));
  for (size_t i = 0; i < v.resources.size(); ++i) {
    const std::string field = "resources[" + std::to_string(i) + "]";
    MS_RETURN_IF_ERROR(CheckFileName(field + ".name", v.resources[i].name));
    MS_RETURN_IF_ERROR(CheckDigest(field + ".sha256", v.resources[i].sha256));
    MS_RETURN_IF_ERROR(CheckFitsInt64(field + ".size", v.resources[i].size));
  }
  MS_RETURN_IF_ERROR(CheckText("options_json", v.options_json));
  MS_RETURN_IF_ERROR(CheckText("comment", v.comment));
  for (const auto& [key, value] : v.labels) {
    if (key.empty()) return InvalidArgument("labels: a key must not be empty");
    MS_RETURN_IF_ERROR(CheckText("labels: a key", key));
    MS_RETURN_IF_ERROR(CheckText("labels[" + key + "]", value));
  }
  return Status::Ok();
}

Status CheckBytes(const uint8_t* data, size_t size) {
  if (data == nullptr && size > 0) return InvalidArgument("data: null with " + std::to_string(size) + " bytes");
  return Status::Ok();
}

Status CheckAppend(uint64_t offset, const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckBytes(data, size));
  MS_RETURN_IF_ERROR(CheckFitsInt64("offset", offset));
  if (size > static_cast<uint64_t>(kInt64Max) - offset) {
    return InvalidArgument("offset: offset plus size overflows a 64-bit signed integer");
  }
  return Status::Ok();
}

}  // namespace meshstream
