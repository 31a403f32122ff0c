#include "services/export/export_version.h"

#include "proto/sha256.h"

namespace meshstream {

namespace {

std::string ExportCacheKey(const std::string& artifact_sha256, ExportFormat format, std::optional<int> lod) {
  const std::string text = "meshstream-export/" + std::to_string(kExporterRevision) + "\n" + artifact_sha256 + "\n" + InfoOf(format).name + "\n" +
                           (lod ? std::to_string(*lod) : std::string("full"));
  return Sha256Hex(reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

}  // namespace

StatusOr<ExportedVersion> ExportVersion(Store& store, const std::string& tenant, const std::string& asset,
                                        int64_t version, ExportFormat format, std::optional<int> lod,
                                        uint64_t max_bytes, const std::function<Status()>& before_decode) {
  auto record = ResolveReadyVersion(store, tenant, asset, version);
  if (!record.ok()) return record.status();
  ExportedVersion out;
  out.version = std::move(record).value();
  const std::string& artifact = out.version.artifact.artifact_sha256;
  const bool as_stored = !InfoOf(format).decodes && !lod.has_value();
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
    return ResourceExhausted("the " + std::string(InfoOf(format).name) + " export has " +
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
