#include "services/export/version_export.h"

#include "services/store/blob_store.h"

namespace meshstream {

namespace {

const char* StateName(VersionState state) {
  switch (state) {
    case VersionState::kProcessing: return "PROCESSING";
    case VersionState::kReady: return "READY";
    case VersionState::kFailed: return "FAILED";
  }
  return "UNKNOWN";
}

std::string ExportCacheKey(const std::string& artifact_sha256, ExportFormat format, std::optional<int> lod) {
  const std::string text = "meshstream-export/" + std::to_string(kExporterRevision) + "\n" + artifact_sha256 + "\n" + ExportFormatName(format) + "\n" +
                           (lod ? std::to_string(*lod) : std::string("full"));
  return Sha256Hex(reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

}  // namespace

const char* ExportFormatName(ExportFormat format) {
  switch (format) {
    case ExportFormat::kGlb: return "glb";
    case ExportFormat::kDracoGlb: return "draco";
    case ExportFormat::kProgressiveGlb: return "progressive";
    case ExportFormat::kObj: return "obj";
    case ExportFormat::kPly: return "ply";
  }
  return "unknown";
}

StatusOr<VersionRecord> ResolveReadyVersion(Store& store, const std::string& tenant, const std::string& asset,
                                            int64_t version) {
  if (version < 0) return InvalidArgument("version: must not be negative (0 is the latest READY)");
  if (version == 0) {
    auto latest = store.GetVersion(tenant, asset, 0);  // NotFound for an unknown asset
    if (!latest.ok()) return latest.status();
    auto ready = store.GetLatestReadyVersion(tenant, asset);
    if (ready.ok() || ready.status().code() != StatusCode::kNotFound) return ready;
    return FailedPrecondition("asset " + asset + " has no READY version yet (version " +
                              std::to_string(latest->version) + " is " + StateName(latest->state) + ")");
  }
  auto record = store.GetVersion(tenant, asset, version);
  if (!record.ok()) return record.status();
  if (record->state != VersionState::kReady) {
    std::string message = "asset " + asset + " version " + std::to_string(version) + " is " + StateName(record->state);
    if (record->state == VersionState::kFailed && !record->error.empty()) message += ": " + record->error;
    if (record->state == VersionState::kProcessing) message += " (job " + record->job_id + ")";
    return FailedPrecondition(message);
  }
  return record;
}

StatusOr<ExportedVersion> ExportVersion(Store& store, const std::string& tenant, const std::string& asset,
                                        int64_t version, ExportFormat format, std::optional<int> lod,
                                        uint64_t max_bytes, const std::function<Status()>& before_decode) {
  auto record = ResolveReadyVersion(store, tenant, asset, version);
  if (!record.ok()) return record.status();
  ExportedVersion out;
  out.version = std::move(record).value();
  const std::string& artifact = out.version.artifact.artifact_sha256;
  const bool as_stored = format == ExportFormat::kProgressiveGlb && !lod.has_value();
  // Only full-detail exports are cached: one blob per format, not one per
  // level a client may ask for.
  const bool cacheable = !as_stored && !lod.has_value();
  const std::string key = cacheable ? ExportCacheKey(artifact, format, lod) : "";
  if (cacheable) {
    auto cached = store.FindArtifact(key);
    if (!cached.ok()) return cached.status();
    if (cached->has_value()) {
      auto bytes = store.GetBlob((*cached)->artifact_sha256, max_bytes);
      if (bytes.ok()) {
        out.bytes = std::move(bytes).value();
        out.sha256 = (*cached)->artifact_sha256;
        out.cached = true;
        return out;
      }
      if (bytes.status().code() != StatusCode::kNotFound) return bytes.status();
      // The cached export was removed: make it again.
    }
  }
  auto glb = store.GetBlob(artifact, max_bytes);
  if (!glb.ok()) return glb.status().WithContext("asset " + asset + " version " + std::to_string(out.version.version));
  if (as_stored) {
    out.bytes = std::move(glb).value();
    out.sha256 = artifact;
    return out;
  }
  if (before_decode) {
    Status gate = before_decode();
    if (!gate.ok()) return gate;
  }
  auto exported = ExportArtifact(glb.value(), format, lod);
  if (!exported.ok()) return exported.status();
  out.bytes = std::move(exported).value();
  if (out.bytes.size() > max_bytes) {
    return ResourceExhausted("the " + std::string(ExportFormatName(format)) + " export has " +
                             std::to_string(out.bytes.size()) + " bytes, more than the server's limit of " +
                             std::to_string(max_bytes));
  }
  if (!cacheable) {
    out.sha256 = Sha256Hex(out.bytes.data(), out.bytes.size());
    return out;
  }
  auto sink = store.NewBlob();
  if (!sink.ok()) return sink.status();
  Status s = (*sink)->Append(out.bytes.data(), out.bytes.size());
  if (!s.ok()) return s;
  auto digest = (*sink)->Commit();
  if (!digest.ok()) return digest.status();
  out.sha256 = digest.value();
  ArtifactSummary summary;
  summary.artifact_sha256 = out.sha256;
  summary.progressive_bytes = out.bytes.size();
  summary.encoder = out.version.artifact.encoder;
  s = store.PutArtifact(key, summary);
  if (!s.ok()) return s;
  return out;
}

}  // namespace meshstream
