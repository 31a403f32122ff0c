// What both store backends share about rows (docs/design/store.md, "One contract,
// two backends"): the JSON columns, the range check of stored states, the
// messages of every refusal a backend decides (a missing asset, version, job,
// upload, token or blob; an upload offset; a lost or finished lease; a
// version no longer PROCESSING), and the token of a page. A backend maps
// its rows with these, so both backends answer with one code and one
// message. The refusals about blobs (missing, too large, damaged, a digest
// mismatch) are the blob folder's too: they are declared in blob_store.h,
// the lowest layer, which this header includes.
//
// Contract: the *FromRow and *FromJson functions read what the database
// holds, which may be damaged: anything they cannot read is DataLoss naming
// the column. Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_STORE_STORE_RECORDS_H_
#define MESHSTREAM_SERVICES_STORE_STORE_RECORDS_H_

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "services/store/blob_store.h"  // BlobNotFound, BlobTooLarge, BlobDamaged, DigestMismatch
#include "services/store/store.h"

namespace meshstream {

// --- JSON columns ----------------------------------------------------------
// Labels as a JSON object of strings (keys and values are checked text).
std::string LabelsToJson(const std::map<std::string, std::string>& labels);
StatusOr<std::map<std::string, std::string>> LabelsFromJson(const std::string& text);
// level_vertices as a JSON array of integers (SQLite's column).
std::string LevelsToJson(const std::vector<int64_t>& levels);
StatusOr<std::vector<int64_t>> LevelsFromJson(const std::string& text);

// --- states ----------------------------------------------------------------
// A stored state: DataLoss "<table> row has the unknown state N" when it is
// not a value of the enum.
StatusOr<VersionState> VersionStateFromRow(int64_t state);
StatusOr<JobState> JobStateFromRow(int64_t state);

// --- refusals a backend decides ------------------------------------------------
Status AssetNotFound(const std::string& asset);                      // NotFound
Status VersionNotFound(const std::string& asset, int64_t version);  // NotFound
Status NoReadyVersion(const std::string& asset);                     // NotFound
Status JobNotFound(const std::string& job_id);                       // NotFound
Status UploadNotFound(const std::string& upload_id);                 // NotFound
Status TokenNotFound(const std::string& id);                         // NotFound
Status NoLiveToken();                                                // NotFound
Status TokenHashExists();                                            // AlreadyExists
// A row would name blob `sha256`, which does not exist: FailedPrecondition
// "<field>: blob X does not exist (store the bytes first)".
Status BlobMissing(const std::string& field, const std::string& sha256);
// An append at `offset` to an upload with `durable` bytes: FailedPrecondition
// naming both.
Status UploadOffsetMismatch(const std::string& upload_id, uint64_t durable, uint64_t offset);
// CommitUpload found bytes that can never become the blob (`why`: a digest
// mismatch, missing bytes) and discarded the upload: DataLoss
// "upload U: <why>; the upload is discarded".
Status UploadDiscarded(const std::string& upload_id, const Status& why);

// The lease check of RenewLease, CompleteJob and FailJob, from what the
// backend read of job `job_id` (a missing job is the backend's JobNotFound,
// before this check): a job RUNNING under another owner, or no longer RUNNING under another owner (taken and
// released), is Aborted "job J: the lease is held by another worker"; a job
// of this worker that is no longer RUNNING (finished, or released to
// PENDING) is Aborted "job J: already SUCCEEDED, the lease is over". OK only
// when `worker` holds the RUNNING job.
Status CheckLeaseHolder(const std::string& job_id, const std::string& worker, JobState state,
                        const std::string& lease_owner);
// CompleteJob or FailJob found the job's version no longer PROCESSING:
// FailedPrecondition, and nothing changes.
Status VersionNotProcessing(const std::string& job_id);

// --- pages -------------------------------------------------------------------
// The page of a backend's listing (store.h, DoListAssets): its items, and
// when more rows follow them, the token `token_of(last item)`.
template <typename T, typename TokenOf>
Page<T> MakePage(PageRows<T> rows, TokenOf token_of) {
  Page<T> page;
  if (rows.more && !rows.items.empty()) page.next_page_token = token_of(rows.items.back());
  page.items = std::move(rows.items);
  return page;
}

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_STORE_RECORDS_H_
