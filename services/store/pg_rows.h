// Rows of the shared store (services/store/pg_store.h) and the statements
// several of its parts share: parameters (bytea, text[] of digests,
// bigint[]), rows to records (states range-checked, labels through
// store_records.h), the blobs a transaction locks or inserts, and the lease
// check. Internal to services/store/pg_*.cc.
//
// Contract: the Read* functions read what the database holds: a state that
// is not a known value, or a column they cannot parse, is DataLoss. The
// functions taking a transaction throw libpqxx's exceptions, which RunPg
// (pg_pool.h) maps to a Status. Thread safety: as the transaction given.
#ifndef MESHSTREAM_SERVICES_STORE_PG_ROWS_H_
#define MESHSTREAM_SERVICES_STORE_PG_ROWS_H_

#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include <pqxx/pqxx>

#include "codec/core/status.h"
#include "services/store/store.h"

namespace meshstream {

// The states as the database stores them (the enum's values).
constexpr int kPgPending = static_cast<int>(JobState::kPending);
constexpr int kPgRunning = static_cast<int>(JobState::kRunning);
constexpr int kPgSucceeded = static_cast<int>(JobState::kSucceeded);
constexpr int kPgJobFailed = static_cast<int>(JobState::kFailed);
constexpr int kPgProcessing = static_cast<int>(VersionState::kProcessing);
constexpr int kPgReady = static_cast<int>(VersionState::kReady);
constexpr int kPgVersionFailed = static_cast<int>(VersionState::kFailed);

// --- parameters ------------------------------------------------------------
// Decodes `n` hex digits (n even) into out[0 .. n/2); false on a non-digit.
bool DecodeHex(const char* hex, size_t n, uint8_t* out);
// A bytea parameter sent in binary (no escaping, no doubling on the wire).
// libpqxx 6.4 takes binarystring; a port to libpqxx 7 changes only this.
pqxx::binarystring Bytea(const uint8_t* data, size_t size);
// A text[] parameter of digests (checked hex: nothing to quote).
std::string DigestArray(const std::vector<std::string>& digests);
// A bigint[] parameter.
std::string BigintArray(const std::vector<int64_t>& values);

// --- rows to records -----------------------------------------------------------
extern const char kPgArtifactColumns[];  // the summary columns, in `versions` and `artifacts`
extern const char kPgJobColumns[];
extern const char kPgTokenColumns[];
const std::string& PgVersionColumns();

StatusOr<ArtifactSummary> ReadArtifact(const pqxx::row& row);
StatusOr<VersionRecord> ReadVersion(const pqxx::row& row);
StatusOr<JobRecord> ReadJob(const pqxx::row& row);
TokenRecord ReadToken(const pqxx::row& row);
// Fills the resources of `versions` (all of one asset) from version_resources.
void LoadResources(pqxx::transaction_base& tx, std::vector<VersionRecord>* versions);
// One version: ReadVersion of `row`, then its resources (LoadResources) in `tx`.
StatusOr<VersionRecord> ReadVersionWithResources(pqxx::transaction_base& tx, const pqxx::row& row);

// --- blobs and leases ------------------------------------------------------------
// Locks blob rows against removal for the rest of the transaction (the
// orphan sweep skips rows locked so) and returns the digests that exist.
std::set<std::string> LockBlobs(pqxx::transaction_base& tx, const std::vector<std::string>& digests);
// Inserts the row of blob `sha256` unless it exists. True when inserted (the
// caller then writes the chunks in the same transaction); false when the same
// bytes were stored already, whose created_ms is then refreshed so that the
// orphan sweep gives the caller min_age_ms to name them again.
StatusOr<bool> InsertBlobRow(pqxx::transaction_base& tx, const std::string& sha256, int64_t size, int64_t chunks);
// Why `worker` could not act on job `job_id` (an UPDATE guarded by owner and
// state matched no row): store_records.h's CheckLeaseHolder on the job's row.
Status LeaseError(pqxx::transaction_base& tx, const std::string& job_id, const std::string& worker);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_ROWS_H_
