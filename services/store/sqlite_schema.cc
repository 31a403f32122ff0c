#include "services/store/sqlite_schema.h"

#include <sqlite3.h>

#include "services/store/sqlite_db.h"

namespace meshstream {

namespace {

constexpr int kBusyTimeoutMs = 5000;

// What processing produced, the same columns in `versions` and `artifacts`.
#define MS_SUMMARY_COLUMNS_DDL                     \
  "artifact_sha256     TEXT NOT NULL DEFAULT '',"  \
  "progressive_bytes   INTEGER NOT NULL DEFAULT 0," \
  "encoder             TEXT NOT NULL DEFAULT '',"  \
  "vertices            INTEGER NOT NULL DEFAULT 0," \
  "faces               INTEGER NOT NULL DEFAULT 0," \
  "levels              INTEGER NOT NULL DEFAULT 0," \
  "level_vertices_json TEXT NOT NULL DEFAULT '[]'," \
  "reliable_bytes      INTEGER NOT NULL DEFAULT 0," \
  "unreliable_bytes    INTEGER NOT NULL DEFAULT 0," \
  "layout_json         TEXT NOT NULL DEFAULT '',"  \
  "warnings_json       TEXT NOT NULL DEFAULT ''"

// Schema version 1. States are the integer values of VersionState and
// JobState. uint64 figures are stored as the int64 with the same bits.
constexpr char kSchemaV1[] =
    "CREATE TABLE tokens ("
    "  id          TEXT PRIMARY KEY,"
    "  tenant      TEXT NOT NULL,"
    "  token_hash  TEXT NOT NULL UNIQUE,"
    "  read_only   INTEGER NOT NULL,"
    "  created_ms  INTEGER NOT NULL,"
    "  revoked     INTEGER NOT NULL DEFAULT 0);"
    "CREATE TABLE assets ("
    "  tenant          TEXT NOT NULL,"
    "  name            TEXT NOT NULL,"
    "  latest_version  INTEGER NOT NULL,"
    "  updated_ms      INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, name)) WITHOUT ROWID;"
    "CREATE TABLE versions ("
    "  tenant        TEXT NOT NULL,"
    "  asset         TEXT NOT NULL,"
    "  version       INTEGER NOT NULL,"
    "  state         INTEGER NOT NULL,"
    "  source_name   TEXT NOT NULL,"
    "  source_sha256 TEXT NOT NULL,"
    "  source_size   INTEGER NOT NULL,"
    "  options_json  TEXT NOT NULL,"
    "  comment       TEXT NOT NULL,"
    "  labels_json   TEXT NOT NULL,"
    "  created_ms    INTEGER NOT NULL,"
    "  job_id        TEXT NOT NULL,"
    "  error         TEXT NOT NULL DEFAULT '',"
    MS_SUMMARY_COLUMNS_DDL ","
    "  PRIMARY KEY (tenant, asset, version),"
    "  FOREIGN KEY (tenant, asset) REFERENCES assets (tenant, name)) WITHOUT ROWID;"
    "CREATE TABLE version_resources ("
    "  tenant    TEXT NOT NULL,"
    "  asset     TEXT NOT NULL,"
    "  version   INTEGER NOT NULL,"
    "  position  INTEGER NOT NULL,"
    "  name      TEXT NOT NULL,"
    "  sha256    TEXT NOT NULL,"
    "  size      INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, asset, version, position),"
    "  FOREIGN KEY (tenant, asset, version) REFERENCES versions (tenant, asset, version)) WITHOUT ROWID;"
    // seq orders jobs by creation (ClaimJob takes the oldest); it survives VACUUM.
    "CREATE TABLE jobs ("
    "  seq              INTEGER PRIMARY KEY,"
    "  id               TEXT NOT NULL UNIQUE,"
    "  tenant           TEXT NOT NULL,"
    "  asset            TEXT NOT NULL,"
    "  version          INTEGER NOT NULL,"
    "  state            INTEGER NOT NULL,"
    "  progress         REAL NOT NULL DEFAULT 0,"
    "  message          TEXT NOT NULL DEFAULT '',"
    "  attempts         INTEGER NOT NULL DEFAULT 0,"
    "  lease_owner      TEXT NOT NULL DEFAULT '',"
    "  lease_expires_ms INTEGER NOT NULL DEFAULT 0,"
    "  created_ms       INTEGER NOT NULL,"
    "  updated_ms       INTEGER NOT NULL,"
    "  FOREIGN KEY (tenant, asset, version) REFERENCES versions (tenant, asset, version));"
    "CREATE INDEX jobs_unfinished ON jobs (seq) WHERE state IN (1, 2);"
    "CREATE TABLE artifacts ("
    "  cache_key  TEXT PRIMARY KEY,"
    MS_SUMMARY_COLUMNS_DDL ","
    "  created_ms INTEGER NOT NULL);"
    // The acknowledged (fsync'd) size of each upload; the bytes are in files.
    "CREATE TABLE uploads ("
    "  tenant     TEXT NOT NULL,"
    "  upload_id  TEXT NOT NULL,"
    "  size       INTEGER NOT NULL,"
    "  updated_ms INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, upload_id)) WITHOUT ROWID;";

// kMigrations[i] takes a database from schema version i to i + 1.
constexpr const char* kMigrations[] = {kSchemaV1};
static_assert(sizeof kMigrations / sizeof kMigrations[0] == kSqliteSchemaVersion,
              "one migration per schema version");

}  // namespace

Status SetUpSqliteDatabase(sqlite3* db, const std::string& path, bool may_migrate) {
  sqlite3_extended_result_codes(db, 1);
  if (const int rc = sqlite3_busy_timeout(db, kBusyTimeoutMs); rc != SQLITE_OK) return SqlError(db, rc, path);
  {
    Stmt wal(db, "PRAGMA journal_mode = WAL");
    MS_ASSIGN_OR_RETURN(const bool row, wal.Step());
    if (!row || wal.Text(0) != "wal") {
      return FailedPrecondition(path + ": SQLite refused WAL mode (journal_mode is '" +
                                (row ? wal.Text(0) : std::string()) + "')");
    }
  }
  MS_RETURN_IF_ERROR(ExecSql(db, "PRAGMA synchronous = FULL; PRAGMA foreign_keys = ON"));

  int64_t version = 0;
  {
    Stmt read(db, "PRAGMA user_version");
    MS_ASSIGN_OR_RETURN(const bool row, read.Step());
    if (row) version = read.Int(0);
  }
  if (version > kSqliteSchemaVersion) {
    return FailedPrecondition(path + ": schema version " + std::to_string(version) + " is newer than the " +
                              std::to_string(kSqliteSchemaVersion) +
                              " this meshstream knows; run a newer meshstream");
  }
  if (version < 0) return DataLoss(path + ": schema version " + std::to_string(version));
  if (version < kSqliteSchemaVersion && !may_migrate) {
    return FailedPrecondition(path + ": schema version " + std::to_string(version) + " is older than the " +
                              std::to_string(kSqliteSchemaVersion) +
                              " this meshstream writes, and the server that has the store open migrates it "
                              "(restart that server with this meshstream first)");
  }
  for (int64_t step = version; step < kSqliteSchemaVersion; ++step) {
    Txn txn(db);
    MS_RETURN_IF_ERROR(txn.Begin());
    MS_RETURN_IF_ERROR(ExecSql(db, kMigrations[step]).WithContext(path + ": migration to schema " +
                                                              std::to_string(step + 1)));
    // PRAGMA takes no parameters; the value is our own integer.
    const std::string set = "PRAGMA user_version = " + std::to_string(step + 1);
    MS_RETURN_IF_ERROR(ExecSql(db, set.c_str()));
    MS_RETURN_IF_ERROR(txn.Commit());
  }
  return Status::Ok();
}

}  // namespace meshstream
