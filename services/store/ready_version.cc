#include "services/store/ready_version.h"

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

}  // namespace

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

}  // namespace meshstream
