#include "services/store/store.h"

#include <algorithm>
#include <chrono>

#include "codec/core/utf8.h"

#include "services/store/page_token.h"
#include "services/store/store_checks.h"
#include "services/store/store_records.h"

namespace meshstream {

// --- BlobSink ----------------------------------------------------------------

Status BlobSink::Append(const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckBytes(data, size));
  return DoAppend(data, size);
}

StatusOr<std::string> BlobSink::Commit(const std::string& expected_sha256) {
  MS_RETURN_IF_ERROR(CheckOptionalDigest("expected_sha256", expected_sha256));
  return DoCommit(expected_sha256);
}

// --- Store: the checks, then the backend -----------------------------------------

StatusOr<std::unique_ptr<BlobSink>> Store::NewBlob() { return DoNewBlob(); }

StatusOr<std::vector<uint8_t>> Store::GetBlob(const std::string& sha256, uint64_t max_bytes) {
  MS_RETURN_IF_ERROR(CheckDigest("sha256", sha256));
  return DoGetBlob(sha256, max_bytes);
}

StatusOr<bool> Store::HasBlob(const std::string& sha256) {
  MS_RETURN_IF_ERROR(CheckDigest("sha256", sha256));
  return DoHasBlob(sha256);
}

StatusOr<uint64_t> Store::RemoveOrphanBlobs(int64_t min_age_ms) {
  MS_RETURN_IF_ERROR(CheckNotNegative("min_age_ms", min_age_ms));
  return DoRemoveOrphanBlobs(min_age_ms);
}

StatusOr<uint64_t> Store::UploadSize(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  return DoUploadSize(tenant, upload_id);
}

Status Store::AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                           const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  MS_RETURN_IF_ERROR(CheckAppend(offset, data, size));
  return DoAppendUpload(tenant, upload_id, offset, data, size);
}

StatusOr<std::string> Store::CommitUpload(const std::string& tenant, const std::string& upload_id,
                                          const std::string& expected_sha256) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  MS_RETURN_IF_ERROR(CheckOptionalDigest("expected_sha256", expected_sha256));
  return DoCommitUpload(tenant, upload_id, expected_sha256);
}

Status Store::DiscardUpload(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  return DoDiscardUpload(tenant, upload_id);
}

StatusOr<uint64_t> Store::ExpireUploads(int64_t max_idle_ms) {
  MS_RETURN_IF_ERROR(CheckNotNegative("max_idle_ms", max_idle_ms));
  return DoExpireUploads(max_idle_ms);
}

StatusOr<VersionRecord> Store::CreateVersion(const NewVersion& version) {
  MS_RETURN_IF_ERROR(CheckNewVersion(version));
  return DoCreateVersion(version);
}

StatusOr<VersionRecord> Store::GetVersion(const std::string& tenant, const std::string& asset, int64_t version) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  MS_RETURN_IF_ERROR(CheckNotNegative("version", version));
  return DoGetVersion(tenant, asset, version);
}

StatusOr<VersionRecord> Store::GetLatestReadyVersion(const std::string& tenant, const std::string& asset) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  return DoGetLatestReadyVersion(tenant, asset);
}

StatusOr<Page<AssetRecord>> Store::ListAssets(const std::string& tenant, int32_t page_size,
                                              const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const std::string after, DecodeAssetsPageToken(page_token));
  MS_ASSIGN_OR_RETURN(PageRows<AssetRecord> rows, DoListAssets(tenant, after, size));
  return MakePage(std::move(rows), [](const AssetRecord& a) { return EncodeAssetsPageToken(a.name); });
}

StatusOr<Page<VersionRecord>> Store::ListVersions(const std::string& tenant, const std::string& asset,
                                                  int32_t page_size, const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const int64_t after, DecodeVersionsPageToken(page_token));
  MS_ASSIGN_OR_RETURN(PageRows<VersionRecord> rows, DoListVersions(tenant, asset, after, size));
  return MakePage(std::move(rows), [](const VersionRecord& v) { return EncodeVersionsPageToken(v.version); });
}

StatusOr<JobRecord> Store::GetJob(const std::string& tenant, const std::string& job_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  return DoGetJob(tenant, job_id);
}

StatusOr<std::optional<JobRecord>> Store::ClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckLeaseArguments(worker, now_ms, lease_ms));
  return DoClaimJob(worker, now_ms, lease_ms);
}

Status Store::RenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                         double progress, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckLeaseArguments(worker, now_ms, lease_ms));
  MS_RETURN_IF_ERROR(CheckProgress(progress));
  MS_RETURN_IF_ERROR(CheckText("message", message));
  return DoRenewLease(job_id, worker, now_ms, lease_ms, progress, message);
}

Status Store::CompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckKey("worker", worker));
  MS_RETURN_IF_ERROR(CheckSummary(summary));
  return DoCompleteJob(job_id, worker, summary);
}

Status Store::FailJob(const std::string& job_id, const std::string& worker, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckKey("worker", worker));
  MS_RETURN_IF_ERROR(CheckText("message", message));
  return DoFailJob(job_id, worker, message);
}

StatusOr<int64_t> Store::ReleaseAllLeases() { return DoReleaseAllLeases(); }

StatusOr<int64_t> Store::CountUnfinishedJobs() { return DoCountUnfinishedJobs(); }

StatusOr<std::optional<ArtifactSummary>> Store::FindArtifact(const std::string& cache_key) {
  MS_RETURN_IF_ERROR(CheckKey("cache_key", cache_key));
  return DoFindArtifact(cache_key);
}

Status Store::PutArtifact(const std::string& cache_key, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckKey("cache_key", cache_key));
  MS_RETURN_IF_ERROR(CheckSummary(summary));
  return DoPutArtifact(cache_key, summary);
}

StatusOr<TokenRecord> Store::CreateToken(const std::string& tenant, bool read_only, const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckKey("token_hash", token_hash));
  return DoCreateToken(tenant, read_only, token_hash);
}

StatusOr<TokenRecord> Store::FindToken(const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckKey("token_hash", token_hash));
  return DoFindToken(token_hash);
}

StatusOr<std::vector<TokenRecord>> Store::ListTokens() { return DoListTokens(); }

Status Store::RevokeToken(const std::string& id) {
  MS_RETURN_IF_ERROR(CheckName("id", id));
  return DoRevokeToken(id);
}

// --- helpers -------------------------------------------------------------------

namespace {

// `message` cut to at most `max_bytes` at a UTF-8 boundary, with "..." when cut.
std::string TruncateMessage(const std::string& message, size_t max_bytes) {
  if (message.size() <= max_bytes) return message;
  const std::string ellipsis = "...";
  size_t cut = max_bytes > ellipsis.size() ? max_bytes - ellipsis.size() : 0;
  // Back to the start of a UTF-8 sequence (continuation bytes are 10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(message[cut]) & 0xC0) == 0x80) --cut;
  return message.substr(0, cut) + ellipsis;
}

}  // namespace

std::string StorableMessage(const std::string& message, size_t max_bytes) {
  std::string text = ToValidUtf8(message);
  std::replace(text.begin(), text.end(), '\0', ' ');
  return TruncateMessage(text, max_bytes);
}

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace meshstream
