// The schema of the embedded store's metadata (docs/design/store.md, "The embedded
// store (SQLite)"), mirroring pg_schema.h: the DDL of each schema version,
// and the connection's set-up (WAL, synchronous=FULL, foreign keys, busy
// timeout) with the migration of an older database at open.
//
// Migrations: kSqliteMigrations[i] takes a database from schema version i to
// i + 1 (PRAGMA user_version), each in its own transaction. A newer database
// is FailedPrecondition (a newer meshstream wrote it). Thread safety: called
// once per connection, before the store shares it.
#ifndef MESHSTREAM_SERVICES_STORE_SQLITE_SCHEMA_H_
#define MESHSTREAM_SERVICES_STORE_SQLITE_SCHEMA_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"

struct sqlite3;

namespace meshstream {

// The schema this code writes.
constexpr int64_t kSqliteSchemaVersion = 1;

// What processing produced, the same columns in `versions` and `artifacts`
// (text for the statements of sqlite_store.cc).
#define MS_SQLITE_SUMMARY_COLUMNS                                                                     \
  "artifact_sha256, progressive_bytes, encoder, vertices, faces, levels, level_vertices_json, "        \
  "reliable_bytes, unreliable_bytes, layout_json, warnings_json"

// Sets the connection up and brings its schema to kSqliteSchemaVersion (when
// `may_migrate`; else an older schema is FailedPrecondition). `path` names
// the database in messages.
Status SetUpSqliteDatabase(sqlite3* db, const std::string& path, bool may_migrate);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_SQLITE_SCHEMA_H_
