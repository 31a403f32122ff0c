// The PostgreSQL schema of the shared store (docs/design/store.md, "The shared
// store"): every table lives in the schema `meshstream`; the table
// `meshstream.meshstream_schema` holds one row per applied migration.
//
// Migrations are an ordered list (version 1, 2, ...). Each is applied in its
// own transaction that first takes `pg_advisory_xact_lock(kPgMigrationLock)`,
// so servers starting together apply each migration once and in order; a
// migration's statements and its version row commit together or not at all.
// A database whose version is newer than the code is FailedPrecondition
// (an older build must not write to a schema it does not know).
//
// Privileges: the schema is created only when it is missing, so a role with
// just CREATE on an existing `meshstream` schema (made by a DBA) can migrate.
#ifndef MESHSTREAM_SERVICES_STORE_PG_SCHEMA_H_
#define MESHSTREAM_SERVICES_STORE_PG_SCHEMA_H_

#include <cstdint>
#include <string>
#include <vector>

#include <pqxx/connection_base>

#include "codec/core/status.h"

namespace meshstream {

struct PgMigration {
  int version = 0;
  std::string description;
  std::vector<std::string> statements;
};

// The migrations in order; the last one's version is the code's version.
const std::vector<PgMigration>& PgMigrations();
int PgSchemaVersion();

// The advisory lock key the migrations take ("meshstre" in ASCII).
constexpr int64_t kPgMigrationLock = 0x6d65736873747265;

// Brings the database to PgSchemaVersion(). OK when it is there already;
// FailedPrecondition when the database is newer. Throws the pqxx exceptions
// of the connection (the caller maps them to a Status).
Status MigratePgSchema(pqxx::connection_base& connection);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_SCHEMA_H_
