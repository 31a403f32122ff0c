// PgStore against a real PostgreSQL (testing/pg_cluster.h): one
// throwaway cluster per test binary, a fresh database per test. What only a
// shared database can show is tested here with two stores on one database
// (two OpenPgStore calls are two servers): migrations racing, version
// numbers and job claims under concurrency, lease takeover, uploads appended
// from both, orphan removal's age rule, damaged chunks and killed sessions.
// PgBackend() is the hook for the backend-independent suite
// (tests/services/store_suite.h).
#include "services/store/pg_store.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <pqxx/pqxx>

#include "services/store/blob_store.h"
#include "services/store/pg_schema.h"
#include "testing/pg_cluster.h"

#include "tests/services/store_suite.h"

namespace meshstream {


namespace {

// The cluster of this test binary, started by the first test that needs it
// and stopped at exit.
struct ClusterHolder {
  std::unique_ptr<test_util::PgCluster> cluster;
  Status status;
};

ClusterHolder& Cluster() {
  static ClusterHolder holder = [] {
    ClusterHolder h;
    auto started = test_util::PgCluster::Start();
    if (started.ok()) {
      h.cluster = std::move(started).value();
    } else {
      h.status = started.status();
    }
    return h;
  }();
  return holder;
}

std::atomic<int> g_next_database{0};

// Runs `update(tx)` in a transaction of its own connection to `conninfo`
// and commits it when exactly one row changed.
template <typename Update>
Status UpdateOneRow(const std::string& conninfo, Update update) {
  try {
    pqxx::connection c(conninfo);
    pqxx::work tx(c);
    const pqxx::result r = update(tx);
    if (r.affected_rows() != 1) return NotFound("changed " + std::to_string(r.affected_rows()) + " rows");
    tx.commit();
    return Status::Ok();
  } catch (const std::exception& e) {
    return Internal(std::string("raw update: ") + e.what());
  }
}

}  // namespace

// A new, empty database on the cluster: its conninfo.
StatusOr<std::string> FreshPgDatabase() {
  ClusterHolder& holder = Cluster();
  if (!holder.status.ok()) return holder.status;
  const std::string name = "t" + std::to_string(g_next_database++);
  try {
    pqxx::connection admin(holder.cluster->connection_string());
    pqxx::nontransaction tx(admin);
    tx.exec("CREATE DATABASE " + name);  // a generated name, not user data
  } catch (const std::exception& e) {
    return Internal("CREATE DATABASE " + name + ": " + e.what());
  }
  return holder.cluster->connection_string(name);
}

// The PostgreSQL backend for the shared suite: open() makes a fresh database
// and opens a store on it; reopen() opens another store on the same one.
StoreBackend PgBackend() {
  auto conninfo = std::make_shared<std::string>();
  StoreBackend backend;
  backend.name = "postgresql";
  backend.open = [conninfo]() -> StatusOr<std::unique_ptr<Store>> {
    MS_ASSIGN_OR_RETURN(*conninfo, FreshPgDatabase());
    return OpenPgStore(*conninfo);
  };
  backend.reopen = [conninfo]() -> StatusOr<std::unique_ptr<Store>> {
    if (conninfo->empty()) return FailedPrecondition("reopen before open");
    return OpenPgStore(*conninfo);
  };
  // Writes a state behind the store's back. A state outside the enum needs
  // the table's CHECK constraint gone first, as in a database restored from
  // a damaged dump: the store's range check is the defence that remains.
  backend.set_version_state = [conninfo](const std::string& tenant, const std::string& asset, int64_t version,
                                         int64_t state) {
    return UpdateOneRow(*conninfo, [&](pqxx::work& tx) {
      if (state < static_cast<int64_t>(VersionState::kProcessing) ||
          state > static_cast<int64_t>(VersionState::kFailed)) {
        tx.exec("ALTER TABLE meshstream.versions DROP CONSTRAINT IF EXISTS versions_state_check");
      }
      return tx.exec_params(
          "UPDATE meshstream.versions SET state = $1 WHERE tenant = $2 AND asset = $3 AND version = $4", state,
          tenant, asset, version);
    });
  };
  backend.set_job_state = [conninfo](const std::string& job_id, int64_t state) {
    return UpdateOneRow(*conninfo, [&](pqxx::work& tx) {
      if (state < static_cast<int64_t>(JobState::kPending) || state > static_cast<int64_t>(JobState::kFailed)) {
        tx.exec("ALTER TABLE meshstream.jobs DROP CONSTRAINT IF EXISTS jobs_state_check");
      }
      return tx.exec_params("UPDATE meshstream.jobs SET state = $1 WHERE id = $2", state, job_id);
    });
  };
  return backend;
}

namespace {

constexpr size_t kMiB = size_t{1} << 20;

std::string RandomBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng() & 0xFF);
  return s;
}

const uint8_t* Bytes(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

std::string Digest(const std::string& s) { return Sha256Hex(Bytes(s), s.size()); }

std::string AsString(const std::vector<uint8_t>& v) { return std::string(v.begin(), v.end()); }

class PgStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto db = FreshPgDatabase();
    ASSERT_TRUE(db.ok()) << db.status().ToString();
    conninfo_ = *db;
    auto store = OpenPgStore(conninfo_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
  }

  std::unique_ptr<Store> OpenAnother(const PgStoreOptions& options = {}) {
    auto store = OpenPgStore(conninfo_, options);
    EXPECT_TRUE(store.ok()) << store.status().ToString();
    return store.ok() ? std::move(store).value() : nullptr;
  }

  // SQL straight on the test database (to inspect or damage rows).
  pqxx::result Sql(const std::string& query) {
    pqxx::connection c(conninfo_);
    pqxx::work tx(c);
    pqxx::result r = tx.exec(query);
    tx.commit();
    return r;
  }
  int64_t SqlInt(const std::string& query) { return Sql(query)[0][0].as<int64_t>(); }
  // Rows in the blob sinks' staging table (of one staging id, or all).
  int64_t StagingRows(const std::string& staging_id = "") {
    return SqlInt("SELECT count(*) FROM meshstream.blob_staging" +
                  (staging_id.empty() ? std::string() : " WHERE staging_id = '" + staging_id + "'"));
  }
  // A sink of `store` as the concrete type, for its test hooks.
  std::unique_ptr<PgBlobSink> NewPgSink(Store& store) {
    auto sink = store.NewBlob();
    EXPECT_TRUE(sink.ok()) << sink.status().ToString();
    if (!sink.ok()) return nullptr;
    auto* pg = dynamic_cast<PgBlobSink*>(sink->get());
    EXPECT_NE(pg, nullptr);
    if (pg == nullptr) return nullptr;
    sink->release();
    return std::unique_ptr<PgBlobSink>(pg);
  }
  std::unique_ptr<PgBlobSink> NewPgSink() { return NewPgSink(*store_); }

  std::string PutBlob(Store& store, const std::string& bytes) {
    auto sink = store.NewBlob();
    EXPECT_TRUE(sink.ok()) << sink.status().ToString();
    if (!sink.ok()) return "";
    EXPECT_TRUE((*sink)->Append(Bytes(bytes), bytes.size()).ok());
    auto digest = (*sink)->Commit();
    EXPECT_TRUE(digest.ok()) << digest.status().ToString();
    return digest.ok() ? *digest : "";
  }
  std::string PutBlob(const std::string& bytes) { return PutBlob(*store_, bytes); }

  NewVersion MakeVersion(const std::string& tenant, const std::string& asset, const std::string& source_bytes) {
    NewVersion v;
    v.tenant = tenant;
    v.asset = asset;
    v.source.name = "model.glb";
    v.source.sha256 = Digest(source_bytes);
    v.source.size = source_bytes.size();
    v.options_json = "{\"levels\":4}";
    return v;
  }

  ArtifactSummary MakeSummary(const std::string& artifact_digest) {
    ArtifactSummary s;
    s.artifact_sha256 = artifact_digest;
    s.progressive_bytes = 1234;
    s.encoder = "meshstream-progressive/1 test";
    s.vertices = 100;
    s.faces = 190;
    s.levels = 3;
    s.level_vertices = {10, 40, 100};
    s.reliable_bytes = 800;
    s.unreliable_bytes = 434;
    s.layout_json = "{\"primitives\":[]}";
    s.warnings_json = "[\"a warning\"]";
    return s;
  }

  std::string conninfo_;
  std::unique_ptr<Store> store_;
};

// --- schema ---------------------------------------------------------------

using PgStoreSchema = PgStoreTest;

TEST_F(PgStoreSchema, MigratesAtOpenAndReopenIsIdempotent) {
  EXPECT_EQ(store_->backend(), "postgresql");
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.meshstream_schema"),
            static_cast<int64_t>(PgMigrations().size()));
  EXPECT_EQ(SqlInt("SELECT max(version) FROM meshstream.meshstream_schema"), PgSchemaVersion());
  for (const char* table : {"tokens", "assets", "versions", "version_resources", "jobs", "artifacts", "uploads",
                            "upload_chunks", "blobs", "blob_chunks", "blob_staging"}) {
    EXPECT_EQ(SqlInt(std::string("SELECT count(*) FROM pg_tables WHERE schemaname = 'meshstream' AND tablename = '") +
                     table + "'"),
              1)
        << table;
  }
  auto token = store_->CreateToken("acme", false, "hash-1");
  ASSERT_TRUE(token.ok()) << token.status().ToString();
  store_.reset();

  for (int i = 0; i < 2; ++i) {
    auto again = OpenPgStore(conninfo_);
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    auto found = (*again)->FindToken("hash-1");
    ASSERT_TRUE(found.ok()) << found.status().ToString();
    EXPECT_EQ(found->id, token->id);
  }
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.meshstream_schema"),
            static_cast<int64_t>(PgMigrations().size()));
}

TEST_F(PgStoreSchema, ServersStartingTogetherMigrateOnce) {
  auto db = FreshPgDatabase();
  ASSERT_TRUE(db.ok()) << db.status().ToString();
  conninfo_ = *db;
  constexpr int kServers = 6;
  std::vector<Status> results(kServers);
  std::vector<std::thread> threads;
  for (int i = 0; i < kServers; ++i) {
    threads.emplace_back([&, i] {
      auto store = OpenPgStore(conninfo_);
      results[i] = store.ok() ? Status::Ok() : store.status();
    });
  }
  for (auto& t : threads) t.join();
  for (const Status& s : results) EXPECT_TRUE(s.ok()) << s.ToString();
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.meshstream_schema"),
            static_cast<int64_t>(PgMigrations().size()));
}

TEST_F(PgStoreSchema, AVersion1DatabaseGainsTheUnloggedStagingTable) {
  // A database as a version-1 build left it, with a blob in it.
  const std::string old_bytes = RandomBytes(kMiB + 9, 40);
  const std::string old_digest = PutBlob(old_bytes);
  store_.reset();
  Sql("DROP TABLE meshstream.blob_staging");
  Sql("DELETE FROM meshstream.meshstream_schema WHERE version > 1");
  ASSERT_EQ(SqlInt("SELECT max(version) FROM meshstream.meshstream_schema"), 1);

  auto store = OpenPgStore(conninfo_);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  EXPECT_EQ(SqlInt("SELECT max(version) FROM meshstream.meshstream_schema"), PgSchemaVersion());
  // Version 3: chunks are stored uncompressed ('e': external).
  EXPECT_EQ(Sql("SELECT attstorage FROM pg_attribute WHERE attrelid = 'meshstream.blob_chunks'::regclass AND "
                "attname = 'data'")[0][0]
                .as<std::string>(),
            "e");
  EXPECT_EQ(Sql("SELECT relpersistence FROM pg_class WHERE oid = 'meshstream.blob_staging'::regclass")[0][0]
                .as<std::string>(),
            "u");
  auto read = (*store)->GetBlob(old_digest, old_bytes.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == old_bytes);
  const std::string bytes = RandomBytes(2 * kMiB + 3, 41);
  EXPECT_EQ(PutBlob(**store, bytes), Digest(bytes));
  EXPECT_EQ(StagingRows(), 0);
}

TEST_F(PgStoreSchema, NewerDatabaseIsFailedPrecondition) {
  store_.reset();
  Sql("INSERT INTO meshstream.meshstream_schema (version, description, applied_ms) VALUES (" +
      std::to_string(PgSchemaVersion() + 1) + ", 'from the future', 0)");
  auto store = OpenPgStore(conninfo_);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kFailedPrecondition) << store.status().ToString();
  EXPECT_NE(store.status().message().find("newer than this build"), std::string::npos) << store.status().ToString();
}

TEST_F(PgStoreSchema, UnreachableServerIsUnavailableAndTheMessageHasNoPassword) {
  auto store = OpenPgStore("host=/nonexistent-meshstream-socket-dir user=postgres dbname=x password=hunter2");
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kUnavailable) << store.status().ToString();
  EXPECT_EQ(store.status().message().find("hunter2"), std::string::npos) << store.status().ToString();
}

TEST_F(PgStoreSchema, OpensAPostgresqlUri) {
  const std::string db = conninfo_.substr(conninfo_.rfind('=') + 1);
  auto store = OpenPgStore("postgresql:///" + db + "?host=" + Cluster().cluster->socket_dir() + "&user=postgres");
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  ASSERT_TRUE((*store)->CreateToken("acme", true, "uri-token").ok());
  EXPECT_TRUE(store_->FindToken("uri-token").ok());
}

TEST_F(PgStoreSchema, BadOptionsAreInvalidArgument) {
  PgStoreOptions options;
  options.pool_size = 0;
  auto store = OpenPgStore(conninfo_, options);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kInvalidArgument);
}

// --- blobs ------------------------------------------------------------------

using PgStoreBlobs = PgStoreTest;

TEST_F(PgStoreBlobs, RoundTripAcrossChunksStoredOnce) {
  const std::string bytes = RandomBytes(2 * kMiB + kMiB / 2 + 17, 1);
  auto sink = store_->NewBlob();
  ASSERT_TRUE(sink.ok());
  for (size_t at = 0; at < bytes.size(); at += 300001) {
    const size_t n = std::min<size_t>(300001, bytes.size() - at);
    ASSERT_TRUE((*sink)->Append(Bytes(bytes) + at, n).ok());
  }
  EXPECT_EQ((*sink)->size(), bytes.size());
  auto digest = (*sink)->Commit(Digest(bytes));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(*digest, Digest(bytes));

  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 3);
  EXPECT_EQ(SqlInt("SELECT max(octet_length(data)) FROM meshstream.blob_chunks"), static_cast<int64_t>(kMiB));
  EXPECT_EQ(SqlInt("SELECT sum(octet_length(data)) FROM meshstream.blob_chunks"), static_cast<int64_t>(bytes.size()));
  EXPECT_EQ(SqlInt("SELECT size FROM meshstream.blobs"), static_cast<int64_t>(bytes.size()));

  auto read = store_->GetBlob(*digest, bytes.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == bytes);
  auto has = store_->HasBlob(*digest);
  ASSERT_TRUE(has.ok());
  EXPECT_TRUE(*has);

  // The same bytes from another server: one row, one set of chunks.
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  EXPECT_EQ(PutBlob(*other, bytes), *digest);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 1);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 3);

  // The empty blob has no chunks and reads back empty.
  const std::string empty_digest = PutBlob("");
  EXPECT_EQ(empty_digest, Digest(""));
  auto empty = store_->GetBlob(empty_digest, 0);
  ASSERT_TRUE(empty.ok()) << empty.status().ToString();
  EXPECT_TRUE(empty->empty());
}

TEST_F(PgStoreBlobs, MismatchedExpectedDigestStoresNothing) {
  const std::string bytes = RandomBytes(1000, 2);
  auto sink = store_->NewBlob();
  ASSERT_TRUE(sink.ok());
  ASSERT_TRUE((*sink)->Append(Bytes(bytes), bytes.size()).ok());
  auto digest = (*sink)->Commit(Digest("something else"));
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), StatusCode::kDataLoss) << digest.status().ToString();
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 0);
  EXPECT_CODE((*sink)->Commit().status(), StatusCode::kFailedPrecondition);
  EXPECT_CODE((*sink)->Append(Bytes(bytes), 1), StatusCode::kFailedPrecondition);

  // A blob of several chunks has staged some before Commit finds the
  // mismatch: they are gone when Commit returns, not when the sink is.
  const std::string large = RandomBytes(3 * kMiB + 1000, 2);
  auto staged = NewPgSink();
  ASSERT_NE(staged, nullptr);
  ASSERT_TRUE(staged->Append(Bytes(large), large.size()).ok());
  EXPECT_EQ(StagingRows(staged->staging_id()), 3);
  auto mismatch = staged->Commit(Digest(large + "x"));
  ASSERT_FALSE(mismatch.ok());
  EXPECT_EQ(mismatch.status().code(), StatusCode::kDataLoss) << mismatch.status().ToString();
  EXPECT_EQ(StagingRows(), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 0);
}

TEST_F(PgStoreBlobs, SinkDestroyedWithoutCommitLeavesNothing) {
  {
    auto sink = store_->NewBlob();
    ASSERT_TRUE(sink.ok());
    const std::string bytes = RandomBytes(kMiB + 5, 3);
    ASSERT_TRUE((*sink)->Append(Bytes(bytes), bytes.size()).ok());
  }
  {
    auto sink = NewPgSink();
    ASSERT_NE(sink, nullptr);
    const std::string bytes = RandomBytes(4 * kMiB + 5, 3);
    ASSERT_TRUE(sink->Append(Bytes(bytes), bytes.size()).ok());
    EXPECT_EQ(StagingRows(sink->staging_id()), 4);
  }
  EXPECT_EQ(StagingRows(), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 0);
}

TEST_F(PgStoreBlobs, ALargeBlobIsStagedChunkByChunkInBoundedMemory) {
  const std::string bytes = RandomBytes(8 * kMiB + 17, 42);
  constexpr size_t kAppend = 64 * 1024;
  auto sink = NewPgSink();
  ASSERT_NE(sink, nullptr);
  size_t peak = 0;
  for (size_t at = 0; at < bytes.size(); at += kAppend) {
    const size_t n = std::min(kAppend, bytes.size() - at);
    ASSERT_TRUE(sink->Append(Bytes(bytes) + at, n).ok()) << at;
    peak = std::max(peak, sink->buffered_bytes());
    ASSERT_LE(sink->buffered_bytes(), PgBlobSink::kChunkBytes) << at;
    // A full chunk is staged when the byte after it arrives.
    const int64_t full = static_cast<int64_t>((at + n - 1) / kMiB);
    ASSERT_EQ(sink->staged_chunks(), full) << at;
    if (at % kMiB == 0) {
      ASSERT_EQ(StagingRows(sink->staging_id()), full) << at;
    }
  }
  EXPECT_EQ(peak, PgBlobSink::kChunkBytes);
  EXPECT_EQ(sink->size(), bytes.size());
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0) << "nothing is visible before Commit";
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 0);

  auto digest = sink->Commit(Digest(bytes));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(*digest, Digest(bytes));
  EXPECT_EQ(sink->buffered_bytes(), 0u);
  EXPECT_EQ(StagingRows(), 0);
  EXPECT_EQ(SqlInt("SELECT chunks FROM meshstream.blobs"), 9);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 9);
  EXPECT_EQ(SqlInt("SELECT min(seq) + 8 - max(seq) FROM meshstream.blob_chunks"), 0);
  EXPECT_EQ(SqlInt("SELECT octet_length(data) FROM meshstream.blob_chunks WHERE seq = 8"), 17);
  auto read = store_->GetBlob(*digest, bytes.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == bytes);

  // Exactly one chunk, and a whole number of them: the last full chunk
  // goes straight to blob_chunks, a blob of one chunk never touches staging.
  for (const size_t n : {kMiB, 3 * kMiB}) {
    const std::string whole = RandomBytes(n, static_cast<uint32_t>(n));
    auto exact = NewPgSink();
    ASSERT_NE(exact, nullptr);
    ASSERT_TRUE(exact->Append(Bytes(whole), whole.size()).ok());
    EXPECT_EQ(exact->staged_chunks(), static_cast<int64_t>(n / kMiB) - 1);
    auto d = exact->Commit();
    ASSERT_TRUE(d.ok()) << d.status().ToString();
    auto back = store_->GetBlob(*d, n);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_TRUE(AsString(*back) == whole);
    EXPECT_EQ(SqlInt("SELECT chunks FROM meshstream.blobs WHERE sha256 = '" + *d + "'"),
              static_cast<int64_t>(n / kMiB));
  }
  EXPECT_EQ(StagingRows(), 0);
}

// VmHWM of this process, in KiB (Linux).
int64_t PeakRssKiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6));
  }
  return -1;
}

TEST_F(PgStoreBlobs, A64MiBBlobRaisesThePeakMemoryByLittle) {
  // The bytes are made as they are appended, so that the test holds none of
  // them: the peak grows by what the sink, libpqxx and libpq hold. (Run with
  // other tests first, the peak may have been higher already: the check can
  // then only pass; alone, it measures.) Before blobs were staged the growth
  // was the whole blob, 66 MiB.
  const int64_t before = PeakRssKiB();
  ASSERT_GT(before, 0);
  auto sink = NewPgSink();
  ASSERT_NE(sink, nullptr);
  std::mt19937 rng(43);
  std::string piece(64 * 1024, '\0');
  Sha256Hasher hash;
  for (int i = 0; i < 64 * 16; ++i) {
    for (char& c : piece) c = static_cast<char>(rng() & 0xFF);
    hash.Update(Bytes(piece), piece.size());
    ASSERT_TRUE(sink->Append(Bytes(piece), piece.size()).ok()) << i;
    ASSERT_LE(sink->buffered_bytes(), PgBlobSink::kChunkBytes);
  }
  auto digest = sink->Commit(hash.FinishHex());
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  const int64_t growth_kib = PeakRssKiB() - before;
  std::printf("64 MiB blob: VmHWM grew by %lld KiB\n", static_cast<long long>(growth_kib));
  RecordProperty("vmhwm_growth_kib", std::to_string(growth_kib));
  EXPECT_LT(growth_kib, 16 * 1024);
  EXPECT_EQ(SqlInt("SELECT size FROM meshstream.blobs WHERE sha256 = '" + *digest + "'"),
            static_cast<int64_t>(64 * kMiB));
  EXPECT_EQ(StagingRows(), 0);
}

TEST_F(PgStoreBlobs, TwoSinksOfTheSameBytesBothCommitAndStoreOnce) {
  const std::string bytes = RandomBytes(3 * kMiB + 5, 44);
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  // Interleaved on two servers, then committed one after the other.
  auto first = NewPgSink(), second = NewPgSink(*other);
  ASSERT_NE(first, nullptr);
  ASSERT_NE(second, nullptr);
  EXPECT_NE(first->staging_id(), second->staging_id());
  for (size_t at = 0; at < bytes.size(); at += 500000) {
    const size_t n = std::min<size_t>(500000, bytes.size() - at);
    ASSERT_TRUE(first->Append(Bytes(bytes) + at, n).ok());
    ASSERT_TRUE(second->Append(Bytes(bytes) + at, n).ok());
  }
  EXPECT_EQ(StagingRows(), 6);
  auto d1 = first->Commit(Digest(bytes));
  ASSERT_TRUE(d1.ok()) << d1.status().ToString();
  auto d2 = second->Commit(Digest(bytes));
  ASSERT_TRUE(d2.ok()) << d2.status().ToString();
  EXPECT_EQ(*d1, *d2);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 1);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 4);
  EXPECT_EQ(StagingRows(), 0);

  // And committing at the same moment, several times.
  for (int round = 0; round < 5; ++round) {
    const std::string same = RandomBytes(2 * kMiB + 7, 45 + round);
    auto a = NewPgSink(), b = NewPgSink(*other);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    ASSERT_TRUE(a->Append(Bytes(same), same.size()).ok());
    ASSERT_TRUE(b->Append(Bytes(same), same.size()).ok());
    StatusOr<std::string> ra = Internal("not run"), rb = Internal("not run");
    std::thread ta([&] { ra = a->Commit(); });
    std::thread tb([&] { rb = b->Commit(); });
    ta.join();
    tb.join();
    ASSERT_TRUE(ra.ok()) << ra.status().ToString();
    ASSERT_TRUE(rb.ok()) << rb.status().ToString();
    EXPECT_EQ(*ra, Digest(same));
    EXPECT_EQ(*rb, Digest(same));
    EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks WHERE sha256 = '" + *ra + "'"), 3);
    auto read = store_->GetBlob(*ra, same.size());
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    EXPECT_TRUE(AsString(*read) == same);
  }
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 6);
  EXPECT_EQ(StagingRows(), 0);
}

TEST_F(PgStoreBlobs, DamagedChunksAreDataLossNeverWrongBytes) {
  const std::string flipped = PutBlob(RandomBytes(2 * kMiB + 100, 5));
  const std::string missing = PutBlob(RandomBytes(2 * kMiB + 100, 6));
  const std::string shortened = PutBlob(RandomBytes(2 * kMiB + 100, 7));
  const std::string lengthened = PutBlob(RandomBytes(2 * kMiB + 100, 8));
  const uint64_t cap = 4 * kMiB;
  for (const std::string& d : {flipped, missing, shortened, lengthened}) ASSERT_TRUE(store_->GetBlob(d, cap).ok());

  Sql("UPDATE meshstream.blob_chunks SET data = overlay(data placing '\\xff'::bytea from 10 for 1) "
      "WHERE seq = 1 AND sha256 = '" + flipped + "'");
  Sql("DELETE FROM meshstream.blob_chunks WHERE seq = 2 AND sha256 = '" + missing + "'");
  Sql("UPDATE meshstream.blob_chunks SET data = substring(data from 1 for 100) WHERE seq = 0 AND sha256 = '" +
      shortened + "'");
  Sql("UPDATE meshstream.blob_chunks SET data = data || '\\x00'::bytea WHERE seq = 2 AND sha256 = '" + lengthened +
      "'");

  for (const std::string& d : {flipped, missing, shortened, lengthened}) {
    auto read = store_->GetBlob(d, cap);
    ASSERT_FALSE(read.ok()) << d;
    EXPECT_EQ(read.status().code(), StatusCode::kDataLoss) << read.status().ToString();
    EXPECT_NE(read.status().message().find(d), std::string::npos) << read.status().ToString();
  }
}

// --- uploads -------------------------------------------------------------

using PgStoreUploads = PgStoreTest;

TEST_F(PgStoreUploads, OffsetsAreExactAndCommitMakesABlob) {
  const std::string head = RandomBytes(1000, 10), tail = RandomBytes(kMiB + kMiB / 2, 11);
  EXPECT_CODE(store_->UploadSize("acme", "u1").status(), StatusCode::kNotFound);
  const Status early = store_->AppendUpload("acme", "u1", 5, Bytes(head), head.size());
  EXPECT_EQ(early.code(), StatusCode::kFailedPrecondition) << early.ToString();

  ASSERT_TRUE(store_->AppendUpload("acme", "u1", 0, Bytes(head), head.size()).ok());
  const Status again = store_->AppendUpload("acme", "u1", 0, Bytes(head), head.size());
  EXPECT_EQ(again.code(), StatusCode::kFailedPrecondition) << again.ToString();
  EXPECT_NE(again.message().find("offset 0"), std::string::npos) << again.ToString();
  EXPECT_NE(again.message().find("1000 durable bytes"), std::string::npos) << again.ToString();
  EXPECT_CODE(store_->AppendUpload("acme", "u1", 2000, Bytes(head), 1), StatusCode::kFailedPrecondition);

  ASSERT_TRUE(store_->AppendUpload("acme", "u1", head.size(), Bytes(tail), tail.size()).ok());
  auto size = store_->UploadSize("acme", "u1");
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, head.size() + tail.size());
  EXPECT_LE(SqlInt("SELECT max(octet_length(data)) FROM meshstream.upload_chunks"), static_cast<int64_t>(kMiB));

  const std::string whole = head + tail;
  auto digest = store_->CommitUpload("acme", "u1", Digest(whole));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(*digest, Digest(whole));
  EXPECT_CODE(store_->UploadSize("acme", "u1").status(), StatusCode::kNotFound);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.upload_chunks"), 0);
  auto read = store_->GetBlob(*digest, whole.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == whole);
  EXPECT_LE(SqlInt("SELECT max(octet_length(data)) FROM meshstream.blob_chunks"), static_cast<int64_t>(kMiB));

  // Committing bytes that are stored already keeps one copy.
  ASSERT_TRUE(store_->AppendUpload("acme", "u2", 0, Bytes(whole), whole.size()).ok());
  auto same = store_->CommitUpload("acme", "u2", "");
  ASSERT_TRUE(same.ok()) << same.status().ToString();
  EXPECT_EQ(*same, *digest);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 1);
  EXPECT_CODE(store_->CommitUpload("acme", "u2", "").status(), StatusCode::kNotFound);
}

TEST_F(PgStoreUploads, AMissingChunkIsDataLossAtCommit) {
  const std::string bytes = RandomBytes(2 * kMiB + 1, 13);
  ASSERT_TRUE(store_->AppendUpload("acme", "holey", 0, Bytes(bytes), bytes.size()).ok());
  Sql("DELETE FROM meshstream.upload_chunks WHERE byte_offset = " + std::to_string(kMiB));
  auto digest = store_->CommitUpload("acme", "holey", "");
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), StatusCode::kDataLoss) << digest.status().ToString();
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
}

TEST_F(PgStoreUploads, ConcurrentAppendersFromTwoServersNeverOverlap) {
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  constexpr int kThreads = 8, kTries = 25;
  constexpr size_t kBlock = 100;
  std::atomic<int> appended{0}, refused{0}, unexpected{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Store& store = t % 2 == 0 ? *store_ : *other;
      const std::string block(kBlock, static_cast<char>('A' + t));
      for (int i = 0; i < kTries; ++i) {
        auto size = store.UploadSize("acme", "shared");
        const uint64_t offset = size.ok() ? *size : 0;
        const Status s = store.AppendUpload("acme", "shared", offset, Bytes(block), block.size());
        if (s.ok()) {
          ++appended;
        } else if (s.code() == StatusCode::kFailedPrecondition) {
          ++refused;
        } else {
          ++unexpected;
          ADD_FAILURE() << s.ToString();
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(unexpected.load(), 0);
  EXPECT_EQ(appended + refused, kThreads * kTries);
  auto size = store_->UploadSize("acme", "shared");
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, appended * kBlock);
  auto digest = other->CommitUpload("acme", "shared", "");
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  auto bytes = store_->GetBlob(*digest, 1 << 20);
  ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
  ASSERT_EQ(bytes->size(), appended * kBlock);
  // Every block is one appender's: no append landed inside another.
  for (size_t at = 0; at < bytes->size(); at += kBlock) {
    EXPECT_TRUE(std::all_of(bytes->begin() + at, bytes->begin() + at + kBlock,
                            [&](uint8_t b) { return b == (*bytes)[at]; }))
        << "block at " << at;
  }
}

TEST_F(PgStoreUploads, ExpireRemovesOnlyIdleUploads) {
  ASSERT_TRUE(store_->AppendUpload("acme", "idle", 0, Bytes("x"), 1).ok());
  ASSERT_TRUE(store_->AppendUpload("acme", "busy", 0, Bytes("y"), 1).ok());
  Sql("UPDATE meshstream.uploads SET updated_ms = updated_ms - 3600000 WHERE upload_id = 'idle'");
  auto removed = store_->ExpireUploads(60000);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 1u);
  EXPECT_CODE(store_->UploadSize("acme", "idle").status(), StatusCode::kNotFound);
  EXPECT_TRUE(store_->UploadSize("acme", "busy").ok());
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.upload_chunks"), 1);
  EXPECT_CODE(store_->ExpireUploads(-1).status(), StatusCode::kInvalidArgument);
}

// --- versions ---------------------------------------------------------------

using PgStoreVersions = PgStoreTest;

TEST_F(PgStoreVersions, TwoServersIngestingOneAssetGetConsecutiveNumbers) {
  const std::string source = "shared source";
  PutBlob(source);
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  constexpr int kThreads = 8, kEach = 10;
  std::mutex mu;
  std::vector<int64_t> numbers;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Store& store = t % 2 == 0 ? *store_ : *other;
      for (int i = 0; i < kEach; ++i) {
        auto v = store.CreateVersion(MakeVersion("acme", "hot", source));
        if (!v.ok()) {
          ADD_FAILURE() << v.status().ToString();
          continue;
        }
        std::lock_guard<std::mutex> lock(mu);
        numbers.push_back(v->version);
      }
    });
  }
  for (auto& t : threads) t.join();
  std::sort(numbers.begin(), numbers.end());
  std::vector<int64_t> expected(kThreads * kEach);
  for (size_t i = 0; i < expected.size(); ++i) expected[i] = static_cast<int64_t>(i) + 1;
  EXPECT_EQ(numbers, expected);
  auto latest = other->GetVersion("acme", "hot", 0);
  ASSERT_TRUE(latest.ok());
  EXPECT_EQ(latest->version, kThreads * kEach);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.jobs"), kThreads * kEach);
}

// --- jobs -------------------------------------------------------------------

using PgStoreJobs = PgStoreTest;

TEST_F(PgStoreJobs, ConcurrentClaimsFromTwoServersNeverShareAJob) {
  const std::string source = "source";
  PutBlob(source);
  constexpr int kJobs = 30;
  for (int i = 0; i < kJobs; ++i) {
    ASSERT_TRUE(store_->CreateVersion(MakeVersion("acme", "asset" + std::to_string(i % 3), source)).ok());
  }
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  std::mutex mu;
  std::vector<std::string> claimed;
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      Store& store = t % 2 == 0 ? *store_ : *other;
      const std::string worker = "worker-" + std::to_string(t);
      for (;;) {
        auto job = store.ClaimJob(worker, NowMs(), 60000);
        if (!job.ok()) {
          ADD_FAILURE() << job.status().ToString();
          return;
        }
        if (!job->has_value()) return;
        EXPECT_EQ((*job)->lease_owner, worker);
        EXPECT_EQ((*job)->state, JobState::kRunning);
        EXPECT_EQ((*job)->attempts, 1);
        std::lock_guard<std::mutex> lock(mu);
        claimed.push_back((*job)->id);
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(claimed.size(), static_cast<size_t>(kJobs));
  EXPECT_EQ(std::set<std::string>(claimed.begin(), claimed.end()).size(), static_cast<size_t>(kJobs));
  auto unfinished = store_->CountUnfinishedJobs();
  ASSERT_TRUE(unfinished.ok());
  EXPECT_EQ(*unfinished, kJobs);
}

// The suite's lease test (AnExpiredLeaseIsTakenOverAndTheFirstWorkerIsAborted)
// on one store; here the two workers are on two servers of one database, so
// the lease is enforced by the database, not by one process.
TEST_F(PgStoreJobs, ALeaseExpiredOnOneServerIsTakenOverByAnotherAndTheFirstIsAborted) {
  const std::string source = "source", artifact = "progressive glb";
  PutBlob(source);
  PutBlob(artifact);
  auto version = store_->CreateVersion(MakeVersion("acme", "chair", source));
  ASSERT_TRUE(version.ok());
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  const int64_t now = NowMs();

  auto mine = store_->ClaimJob("w1", now, 1000);
  ASSERT_TRUE(mine.ok() && mine->has_value()) << mine.status().ToString();
  auto early = other->ClaimJob("w2", now + 500, 1000);
  ASSERT_TRUE(early.ok());
  EXPECT_FALSE(early->has_value()) << "a live lease is not taken on another server";
  ASSERT_TRUE(store_->RenewLease(version->job_id, "w1", now + 600, 1000, 0.5, "encoding").ok());
  auto still_early = other->ClaimJob("w2", now + 1500, 1000);
  ASSERT_TRUE(still_early.ok());
  EXPECT_FALSE(still_early->has_value()) << "the renewal made on server 1 holds on server 2";

  // w1's server "died": the lease expires and w2, on the other server, takes the job over.
  auto taken = other->ClaimJob("w2", now + 1700, 1000);
  ASSERT_TRUE(taken.ok() && taken->has_value()) << taken.status().ToString();
  EXPECT_EQ((*taken)->id, version->job_id);
  EXPECT_EQ((*taken)->attempts, 2);
  const Status renew = store_->RenewLease(version->job_id, "w1", now + 1800, 1000, 0.9, "");
  EXPECT_EQ(renew.code(), StatusCode::kAborted) << renew.ToString();
  EXPECT_EQ(renew.message(), "job " + version->job_id + ": the lease is held by another worker");
  EXPECT_CODE(store_->CompleteJob(version->job_id, "w1", MakeSummary(Digest(artifact))), StatusCode::kAborted);
  ASSERT_TRUE(other->CompleteJob(version->job_id, "w2", MakeSummary(Digest(artifact))).ok());
  auto ready = store_->GetLatestReadyVersion("acme", "chair");
  ASSERT_TRUE(ready.ok()) << ready.status().ToString();
  EXPECT_EQ(ready->artifact.artifact_sha256, Digest(artifact));
}

// --- orphan blobs -----------------------------------------------------------

using PgStoreOrphans = PgStoreTest;

// Which blobs go is the suite's RemoveOrphanBlobsRemovesOnlyOldBlobsNoRowNames;
// here what is PostgreSQL's own: the age is the blob row's created_ms, the
// chunks go with the row, and storing bytes again renews their age.
TEST_F(PgStoreOrphans, TheAgeIsTheRowsAndRemovalTakesTheChunks) {
  const std::string orphan_old = RandomBytes(kMiB + 3, 20), orphan_new = "young orphan";
  PutBlob(orphan_old);
  PutBlob(orphan_new);
  Sql("UPDATE meshstream.blobs SET created_ms = created_ms - 3600000 WHERE sha256 = '" + Digest(orphan_old) + "'");
  auto removed = store_->RemoveOrphanBlobs(600000);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 1u);
  EXPECT_FALSE(*store_->HasBlob(Digest(orphan_old)));
  EXPECT_TRUE(*store_->HasBlob(Digest(orphan_new)));
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks WHERE sha256 = '" + Digest(orphan_old) + "'"), 0);

  // Committing bytes that are stored (an old orphan) renews their age, so
  // they survive until the row that will name them is committed.
  const std::string again = "stored again";
  PutBlob(again);
  Sql("UPDATE meshstream.blobs SET created_ms = created_ms - 3600000 WHERE sha256 = '" + Digest(again) + "'");
  PutBlob(again);
  removed = store_->RemoveOrphanBlobs(600000);
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, 0u);
  EXPECT_TRUE(*store_->HasBlob(Digest(again)));
}

TEST_F(PgStoreOrphans, StagingOfDeadSinksGoesByAgeAndLiveStagingStays) {
  const std::string dead_bytes = RandomBytes(2 * kMiB + 11, 50), live_bytes = RandomBytes(2 * kMiB + 11, 51);
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  // `dead` stands for the sink of a server that died an hour ago; `live`
  // for another server's sink whose first chunk is an hour old but whose
  // newest is not; `young` wrote a moment ago.
  auto dead = NewPgSink(), live = NewPgSink(*other), young = NewPgSink(*other);
  for (PgBlobSink* s : {dead.get(), live.get(), young.get()}) {
    ASSERT_NE(s, nullptr);
    const std::string& bytes = s == dead.get() ? dead_bytes : live_bytes;
    ASSERT_TRUE(s->Append(Bytes(bytes), bytes.size()).ok());
    ASSERT_EQ(StagingRows(s->staging_id()), 2);
  }
  Sql("UPDATE meshstream.blob_staging SET created_ms = created_ms - 3600000 WHERE staging_id = '" +
      dead->staging_id() + "' OR (staging_id = '" + live->staging_id() + "' AND seq = 0)");

  auto removed = store_->RemoveOrphanBlobs(600000);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 0u) << "staging rows are not blobs";
  EXPECT_EQ(StagingRows(dead->staging_id()), 0);
  EXPECT_EQ(StagingRows(live->staging_id()), 2);
  EXPECT_EQ(StagingRows(young->staging_id()), 2);

  // The live sink commits whole; the dead one's Commit (were it still
  // running) finds its chunks gone: ABORTED, nothing stored.
  auto committed = live->Commit(Digest(live_bytes));
  ASSERT_TRUE(committed.ok()) << committed.status().ToString();
  auto read = store_->GetBlob(*committed, live_bytes.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == live_bytes);
  auto lost = dead->Commit(Digest(dead_bytes));
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.status().code(), StatusCode::kAborted) << lost.status().ToString();
  EXPECT_NE(lost.status().message().find("staged chunks are gone"), std::string::npos) << lost.status().ToString();
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 1);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 3);

  // The periodic upload expiry takes idle staging too.
  Sql("UPDATE meshstream.blob_staging SET created_ms = created_ms - 3600000 WHERE staging_id = '" +
      young->staging_id() + "'");
  auto expired = store_->ExpireUploads(3600000 + 600000);
  ASSERT_TRUE(expired.ok()) << expired.status().ToString();
  EXPECT_EQ(StagingRows(young->staging_id()), 2) << "younger than max_idle_ms";
  expired = store_->ExpireUploads(600000);
  ASSERT_TRUE(expired.ok()) << expired.status().ToString();
  EXPECT_EQ(*expired, 0u) << "staging rows are not uploads";
  EXPECT_EQ(StagingRows(), 0);
}

TEST_F(PgStoreOrphans, AStagedChunkMissingAtCommitIsAbortedAndTheRestIsDeleted) {
  const std::string bytes = RandomBytes(3 * kMiB + 77, 55);
  auto sink = NewPgSink();
  ASSERT_NE(sink, nullptr);
  ASSERT_TRUE(sink->Append(Bytes(bytes), bytes.size()).ok());
  ASSERT_EQ(StagingRows(sink->staging_id()), 3);
  Sql("DELETE FROM meshstream.blob_staging WHERE seq = 1");
  auto digest = sink->Commit(Digest(bytes));
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), StatusCode::kAborted) << digest.status().ToString();
  EXPECT_NE(digest.status().message().find("1 of its 3 staged chunks are gone"), std::string::npos)
      << digest.status().ToString();
  // The commit's transaction was rolled back, then the sink deleted the rest.
  EXPECT_EQ(StagingRows(), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks"), 0);
  EXPECT_CODE(sink->Commit().status(), StatusCode::kFailedPrecondition);
}

TEST_F(PgStoreOrphans, ASweepRacingACommitNeverLeavesAShortBlob) {
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  int stored = 0, aborted = 0;
  for (int i = 0; i < 20; ++i) {
    const std::string bytes = RandomBytes(4 * kMiB + 3, 60 + i);
    auto sink = NewPgSink();
    ASSERT_NE(sink, nullptr);
    ASSERT_TRUE(sink->Append(Bytes(bytes), bytes.size()).ok());
    StatusOr<std::string> digest = Internal("not run");
    StatusOr<uint64_t> swept = uint64_t{0};
    // Age 0: the sweep takes the staged rows unless the commit takes them first.
    std::thread committer([&] { digest = sink->Commit(); });
    std::thread sweeper([&] { swept = other->ExpireUploads(0); });
    committer.join();
    sweeper.join();
    ASSERT_TRUE(swept.ok()) << swept.status().ToString();
    if (digest.ok()) {
      ++stored;
      auto read = store_->GetBlob(*digest, bytes.size());
      ASSERT_TRUE(read.ok()) << read.status().ToString();
      EXPECT_TRUE(AsString(*read) == bytes) << i;
    } else {
      ++aborted;
      EXPECT_EQ(digest.status().code(), StatusCode::kAborted) << digest.status().ToString();
      EXPECT_FALSE(*store_->HasBlob(Digest(bytes))) << i;
    }
    EXPECT_EQ(StagingRows(), 0) << i;
  }
  EXPECT_EQ(stored + aborted, 20);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs b WHERE b.chunks <> "
                   "(SELECT count(*) FROM meshstream.blob_chunks c WHERE c.sha256 = b.sha256)"),
            0);
  std::printf("commit first %d, sweep first %d\n", stored, aborted);
}

TEST_F(PgStoreOrphans, ManyOrphansAreRemovedInBatches) {
  for (int i = 0; i < 1200; ++i) PutBlob("orphan " + std::to_string(i));
  auto removed = store_->RemoveOrphanBlobs(0);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 1200u);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
}

TEST_F(PgStoreOrphans, ASweepRacingAnIngestNeverLeavesARowWithoutItsBlob) {
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  int named = 0, removed_first = 0;
  for (int i = 0; i < 30; ++i) {
    const std::string source = "racing source " + std::to_string(i);
    PutBlob(source);
    Sql("UPDATE meshstream.blobs SET created_ms = created_ms - 3600000");
    StatusOr<uint64_t> swept = uint64_t{0};
    StatusOr<VersionRecord> version = Internal("not run");
    std::thread sweeper([&] { swept = store_->RemoveOrphanBlobs(600000); });
    std::thread ingester([&] { version = other->CreateVersion(MakeVersion("acme", "race", source)); });
    sweeper.join();
    ingester.join();
    ASSERT_TRUE(swept.ok()) << swept.status().ToString();
    auto has = store_->HasBlob(Digest(source));
    ASSERT_TRUE(has.ok());
    if (version.ok()) {
      ++named;
      EXPECT_TRUE(*has) << i;
      EXPECT_TRUE(store_->GetBlob(Digest(source), 1 << 20).ok()) << i;
    } else {
      ++removed_first;
      EXPECT_EQ(version.status().code(), StatusCode::kFailedPrecondition) << version.status().ToString();
      EXPECT_FALSE(*has) << i;
    }
  }
  EXPECT_EQ(named + removed_first, 30);
  // Every version's blobs exist, whoever won each race.
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.versions v WHERE NOT EXISTS "
                   "(SELECT 1 FROM meshstream.blobs b WHERE b.sha256 = v.source_sha256)"),
            0);
}

// --- connections ----------------------------------------------------------

using PgStoreConnections = PgStoreTest;

TEST_F(PgStoreConnections, TerminatedSessionsAreReplaced) {
  PgStoreOptions options;
  options.pool_size = 3;
  auto store = OpenAnother(options);
  ASSERT_NE(store, nullptr);
  const std::string bytes = RandomBytes(kMiB + 10, 30);
  const std::string digest = PutBlob(*store, bytes);
  size_t created = 0;
  for (int round = 0; round < 4; ++round) {
    // Open all the pool's connections, then kill every session of the database.
    std::vector<std::thread> threads;
    for (int t = 0; t < 3; ++t) threads.emplace_back([&] { EXPECT_TRUE(store->ListTokens().ok()); });
    for (auto& t : threads) t.join();
    const int64_t killed = SqlInt(
        "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
        "WHERE datname = current_database() AND pid <> pg_backend_pid()");
    EXPECT_GE(killed, 1);
    // Each round, a different kind of call meets the dead sessions first: a
    // write transaction, a single-statement read, a snapshot read.
    const std::vector<std::function<void()>> calls = {
        [&] {
          auto token = store->CreateToken("acme", false, "after-kill-" + std::to_string(round));
          EXPECT_TRUE(token.ok()) << token.status().ToString();
          ++created;
        },
        [&] {
          auto tokens = store->ListTokens();
          ASSERT_TRUE(tokens.ok()) << tokens.status().ToString();
          EXPECT_EQ(tokens->size(), created);
        },
        [&] {
          auto read = store->GetBlob(digest, bytes.size());
          ASSERT_TRUE(read.ok()) << read.status().ToString();
          EXPECT_TRUE(AsString(*read) == bytes);
        },
        [&] {
          EXPECT_TRUE(store->AppendUpload("acme", "u" + std::to_string(round), 0, Bytes(bytes), 10).ok());
        },
    };
    for (size_t i = 0; i < calls.size(); ++i) calls[(i + static_cast<size_t>(round)) % calls.size()]();
  }
}

TEST_F(PgStoreConnections, ASinkKeepsStagingAcrossTerminatedSessions) {
  const std::string bytes = RandomBytes(5 * kMiB + 123, 70);
  auto sink = NewPgSink();
  ASSERT_NE(sink, nullptr);
  for (size_t at = 0, round = 0; at < bytes.size(); at += kMiB + kMiB / 3, ++round) {
    const size_t n = std::min(kMiB + kMiB / 3, bytes.size() - at);
    ASSERT_TRUE(sink->Append(Bytes(bytes) + at, n).ok()) << at;
    if (round % 2 == 0) {
      SqlInt("SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity "
             "WHERE datname = current_database() AND pid <> pg_backend_pid()");
    }
  }
  auto digest = sink->Commit(Digest(bytes));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  auto read = store_->GetBlob(*digest, bytes.size());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(AsString(*read) == bytes);
  EXPECT_EQ(StagingRows(), 0);
}

TEST_F(PgStoreConnections, ALockTimeoutIsUnavailableNotRetried) {
  ASSERT_TRUE(store_->AppendUpload("acme", "locked", 0, Bytes("x"), 1).ok());
  auto impatient = OpenPgStore(conninfo_ + " options='-c lock_timeout=200'");
  ASSERT_TRUE(impatient.ok()) << impatient.status().ToString();
  {
    pqxx::connection holder(conninfo_);
    pqxx::work tx(holder);
    tx.exec("SELECT 1 FROM meshstream.uploads WHERE upload_id = 'locked' FOR UPDATE");
    const auto start = std::chrono::steady_clock::now();
    const Status s = (*impatient)->AppendUpload("acme", "locked", 1, Bytes("y"), 1);
    const auto waited = std::chrono::steady_clock::now() - start;
    EXPECT_EQ(s.code(), StatusCode::kUnavailable) << s.ToString();
    EXPECT_NE(s.message().find("cancelled"), std::string::npos) << s.ToString();
    EXPECT_LT(waited, std::chrono::milliseconds(2000));
  }
  EXPECT_TRUE((*impatient)->AppendUpload("acme", "locked", 1, Bytes("y"), 1).ok());
}

TEST_F(PgStoreConnections, AGoneDatabaseIsUnavailable) {
  ASSERT_TRUE(store_->ListTokens().ok());
  const std::string db = conninfo_.substr(conninfo_.rfind('=') + 1);
  {
    pqxx::connection admin(Cluster().cluster->connection_string());
    pqxx::nontransaction tx(admin);
    tx.exec("DROP DATABASE " + db + " WITH (FORCE)");
  }
  auto tokens = store_->ListTokens();
  ASSERT_FALSE(tokens.ok());
  EXPECT_EQ(tokens.status().code(), StatusCode::kUnavailable) << tokens.status().ToString();
  EXPECT_NE(tokens.status().message().find("listing tokens"), std::string::npos) << tokens.status().ToString();
}

// --- the hook for the shared suite ---------------------------------------

TEST(PgStoreBackend, OpenMakesAFreshDatabaseAndReopenKeepsIt) {
  StoreBackend backend = PgBackend();
  EXPECT_EQ(backend.name, "postgresql");
  auto first = backend.open();
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  ASSERT_TRUE((*first)->CreateToken("acme", false, "persisted").ok());
  auto again = backend.reopen();
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_TRUE((*again)->FindToken("persisted").ok());
  auto fresh = PgBackend().open();
  ASSERT_TRUE(fresh.ok()) << fresh.status().ToString();
  EXPECT_CODE((*fresh)->FindToken("persisted").status(), StatusCode::kNotFound);
}

}  // namespace
// The backend-independent suite (tests/services/store_suite_test.cc) on PostgreSQL.
INSTANTIATE_TEST_SUITE_P(Postgres, StoreSuite,
                         ::testing::Values(std::make_shared<StoreBackendFactory>(StoreBackendFactory{
                             "Postgres", []() -> StatusOr<StoreBackend> { return PgBackend(); }})),
                         StoreBackendName);

}  // namespace meshstream
