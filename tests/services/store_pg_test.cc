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

#define EXPECT_CODE(expr, code_)                                             \
  do {                                                                       \
    const ::meshstream::Status ms_s_ = (expr);                               \
    EXPECT_EQ(ms_s_.code(), ::meshstream::StatusCode::code_) << ms_s_.ToString(); \
  } while (false)

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
  EXPECT_CODE((*sink)->Commit().status(), kFailedPrecondition);
  EXPECT_CODE((*sink)->Append(Bytes(bytes), 1), kFailedPrecondition);

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

  auto malformed = store_->NewBlob();
  ASSERT_TRUE(malformed.ok());
  EXPECT_CODE((*malformed)->Commit("not-a-digest").status(), kInvalidArgument);
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

TEST_F(PgStoreBlobs, ReadsAreCappedAndNamesChecked) {
  const std::string bytes = RandomBytes(5000, 4);
  const std::string digest = PutBlob(bytes);
  EXPECT_CODE(store_->GetBlob(digest, bytes.size() - 1).status(), kResourceExhausted);
  EXPECT_TRUE(store_->GetBlob(digest, bytes.size()).ok());
  EXPECT_CODE(store_->GetBlob(Digest("absent"), 1 << 20).status(), kNotFound);
  EXPECT_CODE(store_->GetBlob("../etc/passwd", 1 << 20).status(), kInvalidArgument);
  EXPECT_CODE(store_->HasBlob("ABC").status(), kInvalidArgument);
  auto has = store_->HasBlob(Digest("absent"));
  ASSERT_TRUE(has.ok());
  EXPECT_FALSE(*has);
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
  EXPECT_CODE(store_->UploadSize("acme", "u1").status(), kNotFound);
  const Status early = store_->AppendUpload("acme", "u1", 5, Bytes(head), head.size());
  EXPECT_EQ(early.code(), StatusCode::kFailedPrecondition) << early.ToString();

  ASSERT_TRUE(store_->AppendUpload("acme", "u1", 0, Bytes(head), head.size()).ok());
  const Status again = store_->AppendUpload("acme", "u1", 0, Bytes(head), head.size());
  EXPECT_EQ(again.code(), StatusCode::kFailedPrecondition) << again.ToString();
  EXPECT_NE(again.message().find("offset 0"), std::string::npos) << again.ToString();
  EXPECT_NE(again.message().find("1000 bytes"), std::string::npos) << again.ToString();
  EXPECT_CODE(store_->AppendUpload("acme", "u1", 2000, Bytes(head), 1), kFailedPrecondition);

  ASSERT_TRUE(store_->AppendUpload("acme", "u1", head.size(), Bytes(tail), tail.size()).ok());
  auto size = store_->UploadSize("acme", "u1");
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, head.size() + tail.size());
  EXPECT_LE(SqlInt("SELECT max(octet_length(data)) FROM meshstream.upload_chunks"), static_cast<int64_t>(kMiB));

  const std::string whole = head + tail;
  auto digest = store_->CommitUpload("acme", "u1", Digest(whole));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(*digest, Digest(whole));
  EXPECT_CODE(store_->UploadSize("acme", "u1").status(), kNotFound);
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
  EXPECT_CODE(store_->CommitUpload("acme", "u2", "").status(), kNotFound);
}

TEST_F(PgStoreUploads, MismatchedDigestDiscardsTheUpload) {
  const std::string bytes = RandomBytes(3000, 12);
  ASSERT_TRUE(store_->AppendUpload("acme", "u", 0, Bytes(bytes), bytes.size()).ok());
  auto digest = store_->CommitUpload("acme", "u", Digest("other bytes"));
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), StatusCode::kDataLoss) << digest.status().ToString();
  EXPECT_CODE(store_->UploadSize("acme", "u").status(), kNotFound);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 0);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.upload_chunks"), 0);
  EXPECT_CODE(store_->CommitUpload("acme", "u", "xyz").status(), kInvalidArgument);
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

TEST_F(PgStoreUploads, TenantsAreIsolated) {
  const std::string a = "tenant a bytes", b = "tenant b";
  ASSERT_TRUE(store_->AppendUpload("a", "same-id", 0, Bytes(a), a.size()).ok());
  EXPECT_CODE(store_->UploadSize("b", "same-id").status(), kNotFound);
  EXPECT_CODE(store_->AppendUpload("b", "same-id", a.size(), Bytes(b), b.size()), kFailedPrecondition);
  EXPECT_CODE(store_->CommitUpload("b", "same-id", "").status(), kNotFound);
  EXPECT_CODE(store_->DiscardUpload("b", "same-id"), kNotFound);
  ASSERT_TRUE(store_->AppendUpload("b", "same-id", 0, Bytes(b), b.size()).ok());
  EXPECT_EQ(*store_->UploadSize("a", "same-id"), a.size());
  EXPECT_EQ(*store_->UploadSize("b", "same-id"), b.size());
  ASSERT_TRUE(store_->DiscardUpload("b", "same-id").ok());
  EXPECT_CODE(store_->UploadSize("b", "same-id").status(), kNotFound);
  EXPECT_EQ(*store_->UploadSize("a", "same-id"), a.size());
  EXPECT_CODE(store_->UploadSize("../a", "same-id").status(), kInvalidArgument);
  EXPECT_CODE(store_->UploadSize("a", "").status(), kInvalidArgument);
}

TEST_F(PgStoreUploads, ExpireRemovesOnlyIdleUploads) {
  ASSERT_TRUE(store_->AppendUpload("acme", "idle", 0, Bytes("x"), 1).ok());
  ASSERT_TRUE(store_->AppendUpload("acme", "busy", 0, Bytes("y"), 1).ok());
  Sql("UPDATE meshstream.uploads SET updated_ms = updated_ms - 3600000 WHERE upload_id = 'idle'");
  auto removed = store_->ExpireUploads(60000);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 1u);
  EXPECT_CODE(store_->UploadSize("acme", "idle").status(), kNotFound);
  EXPECT_TRUE(store_->UploadSize("acme", "busy").ok());
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.upload_chunks"), 1);
  EXPECT_CODE(store_->ExpireUploads(-1).status(), kInvalidArgument);
}

// --- versions ---------------------------------------------------------------

using PgStoreVersions = PgStoreTest;

TEST_F(PgStoreVersions, CreateGetAndTenantIsolation) {
  const std::string source = "glTF source", buffer = "external buffer";
  NewVersion nv = MakeVersion("acme", "chair", source);
  nv.resources.push_back({"chair.bin", Digest(buffer), buffer.size()});
  nv.comment = "first";
  nv.labels = {{"team", "props"}, {"stage", "review"}};

  // No blobs yet: FailedPrecondition naming the file.
  auto missing = store_->CreateVersion(nv);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kFailedPrecondition) << missing.status().ToString();
  EXPECT_NE(missing.status().message().find("model.glb"), std::string::npos) << missing.status().ToString();
  PutBlob(source);
  auto missing_resource = store_->CreateVersion(nv);
  ASSERT_FALSE(missing_resource.ok());
  EXPECT_NE(missing_resource.status().message().find("chair.bin"), std::string::npos);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.assets"), 0);
  PutBlob(buffer);

  auto v1 = store_->CreateVersion(nv);
  ASSERT_TRUE(v1.ok()) << v1.status().ToString();
  EXPECT_EQ(v1->version, 1);
  EXPECT_EQ(v1->state, VersionState::kProcessing);
  EXPECT_FALSE(v1->job_id.empty());
  nv.comment = "second";
  nv.labels.clear();
  auto v2 = store_->CreateVersion(nv);
  ASSERT_TRUE(v2.ok()) << v2.status().ToString();
  EXPECT_EQ(v2->version, 2);
  EXPECT_NE(v2->job_id, v1->job_id);

  auto latest = store_->GetVersion("acme", "chair", 0);
  ASSERT_TRUE(latest.ok()) << latest.status().ToString();
  EXPECT_EQ(latest->version, 2);
  EXPECT_EQ(latest->comment, "second");
  auto first = store_->GetVersion("acme", "chair", 1);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  EXPECT_EQ(first->comment, "first");
  EXPECT_EQ(first->source.name, "model.glb");
  EXPECT_EQ(first->source.sha256, Digest(source));
  EXPECT_EQ(first->source.size, source.size());
  ASSERT_EQ(first->resources.size(), 1u);
  EXPECT_EQ(first->resources[0].name, "chair.bin");
  EXPECT_EQ(first->resources[0].sha256, Digest(buffer));
  EXPECT_EQ(first->options_json, "{\"levels\":4}");
  EXPECT_EQ(first->labels.size(), 2u);
  EXPECT_EQ(first->labels.at("team"), "props");
  EXPECT_EQ(first->job_id, v1->job_id);
  EXPECT_EQ(first->created_ms, v1->created_ms);

  EXPECT_CODE(store_->GetVersion("acme", "chair", 3).status(), kNotFound);
  EXPECT_CODE(store_->GetVersion("acme", "table", 0).status(), kNotFound);
  EXPECT_CODE(store_->GetVersion("other", "chair", 1).status(), kNotFound);
  EXPECT_CODE(store_->GetLatestReadyVersion("acme", "chair").status(), kNotFound);
  EXPECT_CODE(store_->ListVersions("other", "chair", 0, "").status(), kNotFound);

  auto job = store_->GetJob("acme", v1->job_id);
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->state, JobState::kPending);
  EXPECT_EQ(job->asset, "chair");
  EXPECT_EQ(job->version, 1);
  EXPECT_CODE(store_->GetJob("other", v1->job_id).status(), kNotFound);
}

TEST_F(PgStoreVersions, PagesOfAssetsAndVersions) {
  const std::string source = "bytes";
  PutBlob(source);
  // Byte order: upper case before lower case, whatever the database's collation.
  const std::vector<std::string> names = {"b", "A", "c.2", "a", "B", "c-1", "Z"};
  for (const std::string& name : names) ASSERT_TRUE(store_->CreateVersion(MakeVersion("acme", name, source)).ok());
  ASSERT_TRUE(store_->CreateVersion(MakeVersion("elsewhere", "zzz", source)).ok());

  std::vector<std::string> listed;
  std::string token;
  int pages = 0;
  do {
    auto page = store_->ListAssets("acme", 3, token);
    ASSERT_TRUE(page.ok()) << page.status().ToString();
    EXPECT_LE(page->items.size(), 3u);
    for (const AssetRecord& a : page->items) {
      EXPECT_EQ(a.tenant, "acme");
      EXPECT_EQ(a.latest_version, 1);
      listed.push_back(a.name);
    }
    token = page->next_page_token;
    ++pages;
  } while (!token.empty() && pages < 10);
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(listed, sorted);
  EXPECT_EQ(pages, 3);

  for (int i = 0; i < 4; ++i) ASSERT_TRUE(store_->CreateVersion(MakeVersion("acme", "a", source)).ok());
  std::vector<int64_t> numbers;
  token.clear();
  do {
    auto page = store_->ListVersions("acme", "a", 2, token);
    ASSERT_TRUE(page.ok()) << page.status().ToString();
    for (const VersionRecord& v : page->items) numbers.push_back(v.version);
    token = page->next_page_token;
  } while (!token.empty() && numbers.size() < 20);
  EXPECT_EQ(numbers, (std::vector<int64_t>{1, 2, 3, 4, 5}));

  auto all = store_->ListVersions("acme", "a", 0, "");
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->items.size(), 5u);
  EXPECT_TRUE(all->next_page_token.empty());

  auto first = store_->ListVersions("acme", "a", 2, "");
  ASSERT_TRUE(first.ok());
  EXPECT_CODE(store_->ListAssets("acme", 2, first->next_page_token).status(), kInvalidArgument);
  EXPECT_CODE(store_->ListAssets("acme", 2, "garbage!").status(), kInvalidArgument);
  EXPECT_CODE(store_->ListAssets("acme", -1, "").status(), kInvalidArgument);
  EXPECT_CODE(store_->ListVersions("acme", "nope", 0, "").status(), kNotFound);
}

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

TEST_F(PgStoreJobs, OldestJobIsClaimedFirst) {
  const std::string source = "source";
  PutBlob(source);
  auto v1 = store_->CreateVersion(MakeVersion("acme", "x", source));
  auto v2 = store_->CreateVersion(MakeVersion("acme", "y", source));
  ASSERT_TRUE(v1.ok() && v2.ok());
  auto first = store_->ClaimJob("w", NowMs(), 1000);
  auto second = store_->ClaimJob("w", NowMs(), 1000);
  ASSERT_TRUE(first.ok() && first->has_value() && second.ok() && second->has_value());
  EXPECT_EQ((*first)->id, v1->job_id);
  EXPECT_EQ((*second)->id, v2->job_id);
}

TEST_F(PgStoreJobs, ExpiredLeaseIsTakenOverAndTheOldOwnerIsAborted) {
  const std::string source = "source", artifact = "progressive glb";
  PutBlob(source);
  auto version = store_->CreateVersion(MakeVersion("acme", "chair", source));
  ASSERT_TRUE(version.ok());
  auto other = OpenAnother();
  ASSERT_NE(other, nullptr);
  const int64_t now = NowMs();

  auto mine = store_->ClaimJob("w1", now, 1000);
  ASSERT_TRUE(mine.ok() && mine->has_value()) << mine.status().ToString();
  EXPECT_EQ((*mine)->id, version->job_id);
  EXPECT_EQ((*mine)->lease_expires_ms, now + 1000);
  auto early = other->ClaimJob("w2", now + 500, 1000);
  ASSERT_TRUE(early.ok());
  EXPECT_FALSE(early->has_value());

  ASSERT_TRUE(store_->RenewLease(version->job_id, "w1", now + 600, 1000, 0.5, "encoding").ok());
  auto job = store_->GetJob("acme", version->job_id);
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->lease_expires_ms, now + 1600);
  EXPECT_DOUBLE_EQ(job->progress, 0.5);
  EXPECT_EQ(job->message, "encoding");
  auto still_early = other->ClaimJob("w2", now + 1500, 1000);
  ASSERT_TRUE(still_early.ok());
  EXPECT_FALSE(still_early->has_value());

  // w1's server "died": the lease expires and w2 takes the job over.
  auto taken = other->ClaimJob("w2", now + 1700, 1000);
  ASSERT_TRUE(taken.ok() && taken->has_value()) << taken.status().ToString();
  EXPECT_EQ((*taken)->id, version->job_id);
  EXPECT_EQ((*taken)->attempts, 2);
  EXPECT_EQ((*taken)->lease_owner, "w2");

  const Status renew = store_->RenewLease(version->job_id, "w1", now + 1800, 1000, 0.9, "");
  EXPECT_EQ(renew.code(), StatusCode::kAborted) << renew.ToString();
  EXPECT_EQ(renew.message(), "job " + version->job_id + ": the lease is held by another worker");
  const std::string artifact_digest = Digest(artifact);
  EXPECT_CODE(store_->CompleteJob(version->job_id, "w1", MakeSummary(artifact_digest)), kAborted);
  EXPECT_CODE(store_->FailJob(version->job_id, "w1", "gave up"), kAborted);
  EXPECT_CODE(store_->RenewLease("0123456789abcdef", "w1", now, 1000, 0, ""), kNotFound);

  // The artifact must exist before the version names it.
  EXPECT_CODE(other->CompleteJob(version->job_id, "w2", MakeSummary(artifact_digest)), kFailedPrecondition);
  EXPECT_EQ(other->GetJob("acme", version->job_id)->state, JobState::kRunning);
  PutBlob(artifact);
  ASSERT_TRUE(other->CompleteJob(version->job_id, "w2", MakeSummary(artifact_digest)).ok());
  EXPECT_CODE(other->CompleteJob(version->job_id, "w2", MakeSummary(artifact_digest)), kAborted);

  job = store_->GetJob("acme", version->job_id);
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->state, JobState::kSucceeded);
  EXPECT_DOUBLE_EQ(job->progress, 1.0);
  auto ready = store_->GetLatestReadyVersion("acme", "chair");
  ASSERT_TRUE(ready.ok()) << ready.status().ToString();
  EXPECT_EQ(ready->version, 1);
  EXPECT_EQ(ready->state, VersionState::kReady);
  const ArtifactSummary expected = MakeSummary(artifact_digest);
  EXPECT_EQ(ready->artifact.artifact_sha256, artifact_digest);
  EXPECT_EQ(ready->artifact.progressive_bytes, expected.progressive_bytes);
  EXPECT_EQ(ready->artifact.encoder, expected.encoder);
  EXPECT_EQ(ready->artifact.vertices, expected.vertices);
  EXPECT_EQ(ready->artifact.faces, expected.faces);
  EXPECT_EQ(ready->artifact.levels, expected.levels);
  EXPECT_EQ(ready->artifact.level_vertices, expected.level_vertices);
  EXPECT_EQ(ready->artifact.reliable_bytes, expected.reliable_bytes);
  EXPECT_EQ(ready->artifact.unreliable_bytes, expected.unreliable_bytes);
  EXPECT_EQ(ready->artifact.layout_json, expected.layout_json);
  EXPECT_EQ(ready->artifact.warnings_json, expected.warnings_json);
  auto unfinished = store_->CountUnfinishedJobs();
  ASSERT_TRUE(unfinished.ok());
  EXPECT_EQ(*unfinished, 0);
  auto none = store_->ClaimJob("w3", now + 100000, 1000);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
}

TEST_F(PgStoreJobs, FailJobFailsTheVersion) {
  const std::string source = "source";
  PutBlob(source);
  auto version = store_->CreateVersion(MakeVersion("acme", "broken", source));
  ASSERT_TRUE(version.ok());
  auto job = store_->ClaimJob("w", NowMs(), 1000);
  ASSERT_TRUE(job.ok() && job->has_value());
  ASSERT_TRUE(store_->FailJob((*job)->id, "w", "import: accessor 3 out of range").ok());
  auto v = store_->GetVersion("acme", "broken", 1);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(v->state, VersionState::kFailed);
  EXPECT_EQ(v->error, "import: accessor 3 out of range");
  auto j = store_->GetJob("acme", (*job)->id);
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(j->state, JobState::kFailed);
  EXPECT_EQ(j->message, "import: accessor 3 out of range");
  EXPECT_CODE(store_->GetLatestReadyVersion("acme", "broken").status(), kNotFound);
  EXPECT_CODE(store_->FailJob((*job)->id, "w", "again"), kAborted);
}

TEST_F(PgStoreJobs, ReleaseAllLeasesReturnsRunningJobsToPending) {
  const std::string source = "source";
  PutBlob(source);
  auto v1 = store_->CreateVersion(MakeVersion("acme", "x", source));
  auto v2 = store_->CreateVersion(MakeVersion("acme", "y", source));
  ASSERT_TRUE(v1.ok() && v2.ok());
  auto running = store_->ClaimJob("w1", NowMs(), 3600000);
  ASSERT_TRUE(running.ok() && running->has_value());
  auto released = static_cast<PgStore*>(store_.get())->ReleaseAllLeases();
  ASSERT_TRUE(released.ok()) << released.status().ToString();
  EXPECT_EQ(*released, 1);
  auto job = store_->GetJob("acme", (*running)->id);
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->state, JobState::kPending);
  EXPECT_EQ(job->lease_owner, "");
  EXPECT_CODE(store_->RenewLease((*running)->id, "w1", NowMs(), 1000, 0.1, ""), kAborted);
  // Claimable again at once, oldest first, without waiting for the lease.
  auto again = store_->ClaimJob("w2", NowMs(), 1000);
  ASSERT_TRUE(again.ok() && again->has_value());
  EXPECT_EQ((*again)->id, (*running)->id);
  EXPECT_EQ((*again)->attempts, 2);
}

TEST_F(PgStoreJobs, ArgumentsAreChecked) {
  EXPECT_CODE(store_->ClaimJob("", NowMs(), 1000).status(), kInvalidArgument);
  EXPECT_CODE(store_->ClaimJob("w", NowMs(), 0).status(), kInvalidArgument);
  EXPECT_CODE(store_->RenewLease("abc", "w", NowMs(), 1000, 1.5, ""), kInvalidArgument);
  EXPECT_CODE(store_->RenewLease("a/b", "w", NowMs(), 1000, 0.5, ""), kInvalidArgument);
  EXPECT_CODE(store_->GetJob("acme", "").status(), kInvalidArgument);
}

// --- the artifact cache and tokens ---------------------------------------

using PgStoreArtifacts = PgStoreTest;

TEST_F(PgStoreArtifacts, TheFirstRowOfAKeyIsKept) {
  const std::string artifact = "artifact bytes";
  const std::string digest = Digest(artifact);
  EXPECT_CODE(store_->PutArtifact("key-1", MakeSummary(digest)), kFailedPrecondition);
  auto none = store_->FindArtifact("key-1");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  PutBlob(artifact);
  ASSERT_TRUE(store_->PutArtifact("key-1", MakeSummary(digest)).ok());
  ArtifactSummary second = MakeSummary(digest);
  second.vertices = 5;
  ASSERT_TRUE(store_->PutArtifact("key-1", second).ok());
  auto found = OpenAnother()->FindArtifact("key-1");
  ASSERT_TRUE(found.ok() && found->has_value()) << found.status().ToString();
  EXPECT_EQ((*found)->vertices, 100);
  EXPECT_EQ((*found)->level_vertices, (std::vector<int64_t>{10, 40, 100}));
  EXPECT_EQ((*found)->warnings_json, "[\"a warning\"]");
  EXPECT_CODE(store_->PutArtifact("key-2", MakeSummary("nothex")), kInvalidArgument);
  EXPECT_CODE(store_->FindArtifact("").status(), kInvalidArgument);
}

using PgStoreTokens = PgStoreTest;

TEST_F(PgStoreTokens, CreateFindListRevoke) {
  auto t1 = store_->CreateToken("acme", false, "hash-a");
  auto t2 = store_->CreateToken("beta", true, "hash-b");
  ASSERT_TRUE(t1.ok() && t2.ok()) << t1.status().ToString() << t2.status().ToString();
  EXPECT_EQ(t1->id.size(), 16u);
  EXPECT_NE(t1->id, t2->id);
  EXPECT_CODE(store_->CreateToken("acme", false, "hash-a").status(), kAlreadyExists);
  EXPECT_CODE(store_->CreateToken("bad tenant", false, "hash-c").status(), kInvalidArgument);

  auto found = store_->FindToken("hash-b");
  ASSERT_TRUE(found.ok());
  EXPECT_EQ(found->tenant, "beta");
  EXPECT_TRUE(found->read_only);
  EXPECT_FALSE(found->revoked);
  EXPECT_CODE(store_->FindToken("hash-z").status(), kNotFound);

  ASSERT_TRUE(store_->RevokeToken(t2->id).ok());
  ASSERT_TRUE(store_->RevokeToken(t2->id).ok());  // twice is fine
  EXPECT_CODE(store_->FindToken("hash-b").status(), kNotFound);
  EXPECT_CODE(store_->RevokeToken("0000000000000000"), kNotFound);
  auto list = store_->ListTokens();
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 2u);
  for (const TokenRecord& t : *list) EXPECT_EQ(t.revoked, t.id == t2->id) << t.id;
}

// --- orphan blobs -----------------------------------------------------------

using PgStoreOrphans = PgStoreTest;

TEST_F(PgStoreOrphans, OnlyOldBlobsNoRowNamesAreRemoved) {
  const std::string orphan_old = RandomBytes(kMiB + 3, 20), orphan_new = "young orphan", source = "source",
                    resource = "resource", cached = "cached artifact", artifact = "version artifact";
  for (const std::string& b : {orphan_old, orphan_new, source, resource, cached, artifact}) PutBlob(b);
  NewVersion nv = MakeVersion("acme", "kept", source);
  nv.resources.push_back({"kept.bin", Digest(resource), resource.size()});
  ASSERT_TRUE(store_->CreateVersion(nv).ok());
  ASSERT_TRUE(store_->PutArtifact("cache-key", MakeSummary(Digest(cached))).ok());
  auto job = store_->ClaimJob("w", NowMs(), 60000);
  ASSERT_TRUE(job.ok() && job->has_value());
  ASSERT_TRUE(store_->CompleteJob((*job)->id, "w", MakeSummary(Digest(artifact))).ok());

  // Everything but the young orphan is an hour old.
  Sql("UPDATE meshstream.blobs SET created_ms = created_ms - 3600000 WHERE sha256 <> '" + Digest(orphan_new) + "'");
  auto removed = store_->RemoveOrphanBlobs(600000);
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 1u);
  EXPECT_FALSE(*store_->HasBlob(Digest(orphan_old)));
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blob_chunks WHERE sha256 = '" + Digest(orphan_old) + "'"), 0);
  for (const std::string& b : {orphan_new, source, resource, cached, artifact}) {
    EXPECT_TRUE(*store_->HasBlob(Digest(b))) << b;
    EXPECT_TRUE(store_->GetBlob(Digest(b), 1 << 20).ok()) << b;
  }

  // With no age limit, the young orphan goes too, and nothing named does.
  removed = store_->RemoveOrphanBlobs(0);
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, 1u);
  EXPECT_FALSE(*store_->HasBlob(Digest(orphan_new)));
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.blobs"), 4);

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
  EXPECT_CODE(store_->RemoveOrphanBlobs(-5).status(), kInvalidArgument);
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
  EXPECT_CODE(sink->Commit().status(), kFailedPrecondition);
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

// --- untrusted arguments --------------------------------------------------

using PgStoreArguments = PgStoreTest;

TEST_F(PgStoreArguments, BadNamesAndTextAreInvalidArgument) {
  const std::string source = "source";
  PutBlob(source);
  EXPECT_CODE(store_->CreateVersion(MakeVersion("a b", "x", source)).status(), kInvalidArgument);
  EXPECT_CODE(store_->CreateVersion(MakeVersion("acme", "x/../y", source)).status(), kInvalidArgument);
  NewVersion nul = MakeVersion("acme", "x", source);
  nul.comment = std::string("cut\0here", 8);
  auto s = store_->CreateVersion(nul);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.status().message().find("comment"), std::string::npos) << s.status().ToString();
  NewVersion utf8 = MakeVersion("acme", "x", source);
  utf8.labels["k"] = "\xC3\x28";
  EXPECT_CODE(store_->CreateVersion(utf8).status(), kInvalidArgument);
  NewVersion digest = MakeVersion("acme", "x", source);
  digest.source.sha256 = "'; DROP TABLE meshstream.blobs; --";
  EXPECT_CODE(store_->CreateVersion(digest).status(), kInvalidArgument);
  // Quotes and UTF-8 in free text are stored as they are.
  NewVersion quoted = MakeVersion("acme", "x", source);
  quoted.comment = "it's \"fine\"; DROP TABLE x; -- ünïcødé";
  quoted.labels["o'k"] = "v\"1";
  auto v = store_->CreateVersion(quoted);
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  auto back = store_->GetVersion("acme", "x", v->version);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->comment, quoted.comment);
  EXPECT_EQ(back->labels, quoted.labels);
  EXPECT_EQ(SqlInt("SELECT count(*) FROM meshstream.assets"), 1);
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
  EXPECT_CODE((*fresh)->FindToken("persisted").status(), kNotFound);
}

}  // namespace
// The backend-independent suite (tests/services/store_suite_test.cc) on PostgreSQL.
INSTANTIATE_TEST_SUITE_P(Postgres, StoreSuite,
                         ::testing::Values(std::make_shared<StoreBackendFactory>(StoreBackendFactory{
                             "Postgres", []() -> StatusOr<StoreBackend> { return PgBackend(); }})),
                         StoreBackendName);

}  // namespace meshstream
