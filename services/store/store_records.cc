#include "services/store/store_records.h"

#include <exception>

#include <nlohmann/json.hpp>

namespace meshstream {

namespace {

// The name of a job state, for messages.
const char* JobStateName(JobState state) {
  switch (state) {
    case JobState::kPending: return "PENDING";
    case JobState::kRunning: return "RUNNING";
    case JobState::kSucceeded: return "SUCCEEDED";
    case JobState::kFailed: return "FAILED";
  }
  return "in an unknown state";
}

}  // namespace

// nlohmann throws; nothing escapes these functions.

std::string LabelsToJson(const std::map<std::string, std::string>& labels) {
  try {
    return nlohmann::json(labels).dump();
  } catch (const std::exception&) {
    return "{}";  // unreachable for checked text (CheckNewVersion); only allocation could fail
  }
}

StatusOr<std::map<std::string, std::string>> LabelsFromJson(const std::string& text) {
  try {
    return nlohmann::json::parse(text).get<std::map<std::string, std::string>>();
  } catch (const std::exception&) {
    return DataLoss("versions.labels is not a JSON object of strings");
  }
}

std::string LevelsToJson(const std::vector<int64_t>& levels) {
  try {
    return nlohmann::json(levels).dump();
  } catch (const std::exception&) {
    return "[]";  // integers always serialize; only allocation could fail
  }
}

StatusOr<std::vector<int64_t>> LevelsFromJson(const std::string& text) {
  try {
    return nlohmann::json::parse(text).get<std::vector<int64_t>>();
  } catch (const std::exception&) {
    return DataLoss("level_vertices is not a JSON array of integers");
  }
}

StatusOr<VersionState> VersionStateFromRow(int64_t state) {
  if (state < static_cast<int64_t>(VersionState::kProcessing) || state > static_cast<int64_t>(VersionState::kFailed)) {
    return DataLoss("versions row has the unknown state " + std::to_string(state));
  }
  return static_cast<VersionState>(state);
}

StatusOr<JobState> JobStateFromRow(int64_t state) {
  if (state < static_cast<int64_t>(JobState::kPending) || state > static_cast<int64_t>(JobState::kFailed)) {
    return DataLoss("jobs row has the unknown state " + std::to_string(state));
  }
  return static_cast<JobState>(state);
}

Status AssetNotFound(const std::string& asset) { return NotFound("asset " + asset + " does not exist"); }

Status VersionNotFound(const std::string& asset, int64_t version) {
  return NotFound("asset " + asset + " has no version " + std::to_string(version));
}

Status NoReadyVersion(const std::string& asset) { return NotFound("asset " + asset + " has no READY version"); }

Status JobNotFound(const std::string& job_id) { return NotFound("job " + job_id + " does not exist"); }

Status UploadNotFound(const std::string& upload_id) { return NotFound("upload " + upload_id + " does not exist"); }

Status TokenNotFound(const std::string& id) { return NotFound("token " + id + " does not exist"); }

Status NoLiveToken() { return NotFound("no live token has this hash"); }

Status TokenHashExists() { return AlreadyExists("token_hash: a token with this hash exists"); }

Status BlobMissing(const std::string& field, const std::string& sha256) {
  return FailedPrecondition(field + ": blob " + sha256 + " does not exist (store the bytes first)");
}

Status UploadOffsetMismatch(const std::string& upload_id, uint64_t durable, uint64_t offset) {
  return FailedPrecondition("upload " + upload_id + " has " + std::to_string(durable) +
                            " durable bytes; an append must start there, not at offset " + std::to_string(offset));
}

Status UploadDiscarded(const std::string& upload_id, const Status& why) {
  return DataLoss("upload " + upload_id + ": " + why.message() + "; the upload is discarded");
}

Status CheckLeaseHolder(const std::string& job_id, const std::string& worker, JobState state,
                        const std::string& lease_owner) {
  if (lease_owner != worker) return Aborted("job " + job_id + ": the lease is held by another worker");
  if (state != JobState::kRunning) {
    return Aborted("job " + job_id + ": already " + JobStateName(state) + ", the lease is over");
  }
  return Status::Ok();
}

Status VersionNotProcessing(const std::string& job_id) {
  return FailedPrecondition("job " + job_id + ": its version is not PROCESSING any more");
}

}  // namespace meshstream
