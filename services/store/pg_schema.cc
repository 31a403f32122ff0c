#include "services/store/pg_schema.h"

#include <pqxx/pqxx>

#include "services/store/store.h"

namespace meshstream {

namespace {

// Version 1: the whole store. Names (tenants, assets, ids, digests) are
// COLLATE "C" so that "ascending by name" is byte order on every database,
// whatever its default collation. Every row that names a blob has a foreign
// key to it: PostgreSQL itself refuses a row naming a missing blob and the
// removal of a blob a row names.
PgMigration Migration1() {
  PgMigration m;
  m.version = 1;
  m.description = "blobs, tokens, assets, versions, jobs, the artifact cache, resumable uploads";
  m.statements = {
      R"sql(CREATE TABLE meshstream.blobs (
        sha256     text COLLATE "C" PRIMARY KEY CHECK (sha256 ~ '^[0-9a-f]{64}$'),
        size       bigint  NOT NULL CHECK (size >= 0),
        chunks     integer NOT NULL CHECK (chunks >= 0),
        created_ms bigint  NOT NULL))sql",
      R"sql(CREATE INDEX blobs_by_created ON meshstream.blobs (created_ms))sql",
      R"sql(CREATE TABLE meshstream.blob_chunks (
        sha256 text COLLATE "C" NOT NULL REFERENCES meshstream.blobs (sha256) ON DELETE CASCADE,
        seq    integer NOT NULL CHECK (seq >= 0),
        data   bytea   NOT NULL CHECK (octet_length(data) <= 1048576),
        PRIMARY KEY (sha256, seq)))sql",

      R"sql(CREATE TABLE meshstream.tokens (
        id         text COLLATE "C" PRIMARY KEY,
        tenant     text COLLATE "C" NOT NULL,
        read_only  boolean NOT NULL,
        token_hash text COLLATE "C" NOT NULL UNIQUE,
        created_ms bigint  NOT NULL,
        revoked    boolean NOT NULL DEFAULT false))sql",

      R"sql(CREATE TABLE meshstream.assets (
        tenant         text COLLATE "C" NOT NULL,
        name           text COLLATE "C" NOT NULL,
        latest_version bigint NOT NULL CHECK (latest_version >= 1),
        created_ms     bigint NOT NULL,
        updated_ms     bigint NOT NULL,
        PRIMARY KEY (tenant, name)))sql",

      R"sql(CREATE TABLE meshstream.versions (
        tenant            text COLLATE "C" NOT NULL,
        asset             text COLLATE "C" NOT NULL,
        version           bigint   NOT NULL CHECK (version >= 1),
        state             smallint NOT NULL CHECK (state IN (1, 2, 3)),
        source_name       text     NOT NULL,
        source_sha256     text COLLATE "C" NOT NULL REFERENCES meshstream.blobs (sha256),
        source_size       bigint   NOT NULL CHECK (source_size >= 0),
        options_json      text     NOT NULL,
        comment           text     NOT NULL,
        labels            jsonb    NOT NULL,
        created_ms        bigint   NOT NULL,
        job_id            text COLLATE "C" NOT NULL UNIQUE,
        error             text     NOT NULL DEFAULT '',
        artifact_sha256   text COLLATE "C" REFERENCES meshstream.blobs (sha256),
        progressive_bytes bigint   NOT NULL DEFAULT 0,
        encoder           text     NOT NULL DEFAULT '',
        vertices          bigint   NOT NULL DEFAULT 0,
        faces             bigint   NOT NULL DEFAULT 0,
        levels            integer  NOT NULL DEFAULT 0,
        level_vertices    bigint[] NOT NULL DEFAULT '{}',
        reliable_bytes    bigint   NOT NULL DEFAULT 0,
        unreliable_bytes  bigint   NOT NULL DEFAULT 0,
        layout_json       text     NOT NULL DEFAULT '',
        warnings_json     text     NOT NULL DEFAULT '',
        PRIMARY KEY (tenant, asset, version),
        FOREIGN KEY (tenant, asset) REFERENCES meshstream.assets (tenant, name)))sql",
      R"sql(CREATE INDEX versions_by_source ON meshstream.versions (source_sha256))sql",
      R"sql(CREATE INDEX versions_by_artifact ON meshstream.versions (artifact_sha256))sql",
      R"sql(CREATE TABLE meshstream.version_resources (
        tenant  text COLLATE "C" NOT NULL,
        asset   text COLLATE "C" NOT NULL,
        version bigint  NOT NULL,
        idx     integer NOT NULL CHECK (idx >= 0),
        name    text    NOT NULL,
        sha256  text COLLATE "C" NOT NULL REFERENCES meshstream.blobs (sha256),
        size    bigint  NOT NULL CHECK (size >= 0),
        PRIMARY KEY (tenant, asset, version, idx),
        FOREIGN KEY (tenant, asset, version) REFERENCES meshstream.versions (tenant, asset, version)
          ON DELETE CASCADE))sql",
      R"sql(CREATE INDEX version_resources_by_blob ON meshstream.version_resources (sha256))sql",

      R"sql(CREATE TABLE meshstream.jobs (
        id               text COLLATE "C" PRIMARY KEY,
        seq              bigint GENERATED ALWAYS AS IDENTITY,
        tenant           text COLLATE "C" NOT NULL,
        asset            text COLLATE "C" NOT NULL,
        version          bigint   NOT NULL,
        state            smallint NOT NULL CHECK (state IN (1, 2, 3, 4)),
        progress         double precision NOT NULL DEFAULT 0,
        message          text     NOT NULL DEFAULT '',
        attempts         integer  NOT NULL DEFAULT 0,
        lease_owner      text     NOT NULL DEFAULT '',
        lease_expires_ms bigint   NOT NULL DEFAULT 0,
        created_ms       bigint   NOT NULL,
        updated_ms       bigint   NOT NULL,
        FOREIGN KEY (tenant, asset, version) REFERENCES meshstream.versions (tenant, asset, version)))sql",
      // What ClaimJob scans: only unfinished jobs, oldest first.
      R"sql(CREATE INDEX jobs_claimable ON meshstream.jobs (created_ms, seq) WHERE state IN (1, 2))sql",

      R"sql(CREATE TABLE meshstream.artifacts (
        cache_key         text COLLATE "C" PRIMARY KEY,
        artifact_sha256   text COLLATE "C" NOT NULL REFERENCES meshstream.blobs (sha256),
        progressive_bytes bigint   NOT NULL,
        encoder           text     NOT NULL,
        vertices          bigint   NOT NULL,
        faces             bigint   NOT NULL,
        levels            integer  NOT NULL,
        level_vertices    bigint[] NOT NULL,
        reliable_bytes    bigint   NOT NULL,
        unreliable_bytes  bigint   NOT NULL,
        layout_json       text     NOT NULL,
        warnings_json     text     NOT NULL,
        created_ms        bigint   NOT NULL))sql",
      R"sql(CREATE INDEX artifacts_by_blob ON meshstream.artifacts (artifact_sha256))sql",

      R"sql(CREATE TABLE meshstream.uploads (
        tenant     text COLLATE "C" NOT NULL,
        upload_id  text COLLATE "C" NOT NULL,
        size       bigint NOT NULL CHECK (size >= 0),
        created_ms bigint NOT NULL,
        updated_ms bigint NOT NULL,
        PRIMARY KEY (tenant, upload_id)))sql",
      R"sql(CREATE INDEX uploads_by_updated ON meshstream.uploads (updated_ms))sql",
      R"sql(CREATE TABLE meshstream.upload_chunks (
        tenant      text COLLATE "C" NOT NULL,
        upload_id   text COLLATE "C" NOT NULL,
        byte_offset bigint NOT NULL CHECK (byte_offset >= 0),
        data        bytea  NOT NULL CHECK (octet_length(data) <= 1048576),
        PRIMARY KEY (tenant, upload_id, byte_offset),
        FOREIGN KEY (tenant, upload_id) REFERENCES meshstream.uploads (tenant, upload_id) ON DELETE CASCADE))sql",
  };
  return m;
}

// Version 2: where a blob sink puts its bytes while they arrive, so that a
// sink holds one chunk in memory instead of the whole blob (pg_store.h,
// PgBlobSink). Rows are keyed by the sink's random staging id (32 hex
// digits) and the chunk's number; Commit moves them into blob_chunks in the
// transaction that inserts the blobs row. `created_ms` is when the chunk was
// written: a staging id whose newest chunk is old enough is a leftover of a
// process that died, removed by RemoveOrphanBlobs and ExpireUploads.
//
// UNLOGGED: staging bytes are written once more when they are committed (to
// blob_chunks, which is logged), so logging them here too would double the
// WAL of every blob for nothing a crash needs; after a crash of the
// database PostgreSQL empties the table, and a sink whose rows are gone
// fails its Commit (it counts what it moves). STORAGE EXTERNAL: staged bytes
// are read once, so they are not compressed on the way in.
PgMigration Migration2() {
  PgMigration m;
  m.version = 2;
  m.description = "blob_staging: chunks of blobs being written";
  m.statements = {
      R"sql(CREATE UNLOGGED TABLE meshstream.blob_staging (
        staging_id text COLLATE "C" NOT NULL CHECK (staging_id ~ '^[0-9a-f]{32}$'),
        seq        integer NOT NULL CHECK (seq >= 0),
        data       bytea   NOT NULL CHECK (octet_length(data) <= 1048576),
        created_ms bigint  NOT NULL,
        PRIMARY KEY (staging_id, seq)))sql",
      R"sql(ALTER TABLE meshstream.blob_staging ALTER COLUMN data SET STORAGE EXTERNAL)sql",
  };
  return m;
}

// Version 3: blob chunks are stored uncompressed. Meshes compress poorly
// (a third at best) and pglz cost the benchmark's bunny 75 ms of a 94 ms
// ingest (docs/results/service-benchmarks.md). Applies to rows written from now on.
PgMigration Migration3() {
  PgMigration m;
  m.version = 3;
  m.description = "blob_chunks.data stored uncompressed (STORAGE EXTERNAL)";
  m.statements = {
      R"sql(ALTER TABLE meshstream.blob_chunks ALTER COLUMN data SET STORAGE EXTERNAL)sql",
      R"sql(ALTER TABLE meshstream.upload_chunks ALTER COLUMN data SET STORAGE EXTERNAL)sql",
  };
  return m;
}

}  // namespace

const std::vector<PgMigration>& PgMigrations() {
  static const std::vector<PgMigration> migrations = {Migration1(), Migration2(), Migration3()};
  return migrations;
}

int PgSchemaVersion() { return PgMigrations().back().version; }

Status MigratePgSchema(pqxx::connection_base& connection) {
  const std::vector<PgMigration>& migrations = PgMigrations();
  for (;;) {
    pqxx::work tx(connection);
    // Held until this transaction ends: one server migrates at a time.
    tx.exec_params("SELECT pg_advisory_xact_lock($1)", kPgMigrationLock);
    // Existence is checked before creating, because CREATE ... IF NOT EXISTS
    // still needs the privilege to create.
    if (tx.exec("SELECT 1 FROM pg_namespace WHERE nspname = 'meshstream'").empty()) {
      tx.exec("CREATE SCHEMA meshstream");
    }
    if (tx.exec1("SELECT to_regclass('meshstream.meshstream_schema') IS NULL")[0].as<bool>()) {
      tx.exec(R"sql(CREATE TABLE meshstream.meshstream_schema (
                      version     integer PRIMARY KEY,
                      description text   NOT NULL,
                      applied_ms  bigint NOT NULL))sql");
    }
    const int current = tx.exec1("SELECT coalesce(max(version), 0) FROM meshstream.meshstream_schema")[0].as<int>();
    if (current > PgSchemaVersion()) {
      return FailedPrecondition("the database has meshstream schema version " + std::to_string(current) +
                                ", newer than this build's " + std::to_string(PgSchemaVersion()) +
                                " (run a newer meshstream)");
    }
    if (current == PgSchemaVersion()) {
      tx.commit();
      return Status::Ok();
    }
    const PgMigration& next = migrations[static_cast<size_t>(current)];
    if (next.version != current + 1) {
      return Internal("meshstream schema migration list is out of order at version " + std::to_string(next.version));
    }
    for (const std::string& statement : next.statements) tx.exec(statement);
    tx.exec_params("INSERT INTO meshstream.meshstream_schema (version, description, applied_ms) VALUES ($1, $2, $3)",
                   next.version, next.description, NowMs());
    tx.commit();
  }
}

}  // namespace meshstream
