// The embedded store: the store suite on a temporary folder, and what only
// SqliteStore does: one process per folder (flock, across fork and SIGKILL),
// the schema version, WAL with synchronous=FULL, upload files, orphan ages.
#include "services/store/sqlite_store.h"

#include <signal.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "services/store/blob_store.h"
#include "services/store/open_store.h"
#include "services/store/sqlite_db.h"
#include "testing/test_util.h"
#include "tests/services/store_suite.h"

namespace meshstream {
namespace {

namespace fs = std::filesystem;
using test_util::TempDir;

// Runs `sql` with `params` bound (sqlite_db.h's Stmt) on the store's
// database through a connection of its own, as a hand edit would. Exactly
// one row must change.
template <typename... Params>
Status RawUpdate(const std::string& folder, const char* sql, const Params&... params) {
  sqlite3* db = nullptr;
  const std::string path = folder + "/meta.sqlite3";
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close_v2(db);
    return IoError("cannot open " + path);
  }
  sqlite3_busy_timeout(db, 5000);
  Status status;
  {
    Stmt stmt(db, sql);
    status = stmt.Bind(params...).Run();
    if (status.ok() && stmt.Changes() != 1) {
      status = NotFound(std::string(sql) + ": changed " + std::to_string(stmt.Changes()) + " rows");
    }
  }
  sqlite3_close_v2(db);
  return status;
}

StatusOr<StoreBackend> MakeSqliteBackend() {
  auto dir = std::make_shared<TempDir>();
  if (dir->path().empty()) return IoError("mkdtemp failed");
  StoreBackend backend;
  backend.name = "sqlite";
  const std::string folder = dir->path() + "/store";  // OpenStore creates it
  backend.open = [folder] { return OpenStore(folder); };
  backend.reopen = backend.open;
  backend.keep_alive = dir;
  backend.set_version_state = [folder](const std::string& tenant, const std::string& asset, int64_t version,
                                       int64_t state) {
    return RawUpdate(folder, "UPDATE versions SET state = ?1 WHERE tenant = ?2 AND asset = ?3 AND version = ?4",
                     state, tenant, asset, version);
  };
  backend.set_job_state = [folder](const std::string& job_id, int64_t state) {
    return RawUpdate(folder, "UPDATE jobs SET state = ?1 WHERE id = ?2", state, job_id);
  };
  return backend;
}

INSTANTIATE_TEST_SUITE_P(Sqlite, StoreSuite,
                         ::testing::Values(std::make_shared<StoreBackendFactory>(
                             StoreBackendFactory{"Sqlite", &MakeSqliteBackend})),
                         StoreBackendName);

// --- helpers -------------------------------------------------------------------

const uint8_t* Data(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }
std::string Sha(const std::string& s) { return Sha256Hex(Data(s), s.size()); }

std::unique_ptr<SqliteStore> MustOpen(const std::string& dir) {
  auto store = SqliteStore::Open(dir);
  EXPECT_TRUE(store.ok()) << store.status().ToString();
  return store.ok() ? std::move(store).value() : nullptr;
}

// Raw SQL on a closed store's database, as an operator's sqlite3 shell would.
std::string RawSql(const std::string& db_path, const std::string& sql) {
  sqlite3* db = nullptr;
  std::string result;
  if (sqlite3_open_v2(db_path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return "open failed";
  }
  char* error = nullptr;
  const auto collect = [](void* out, int n, char** values, char**) {
    for (int i = 0; i < n; ++i) *static_cast<std::string*>(out) += values[i] != nullptr ? values[i] : "NULL";
    return 0;
  };
  if (sqlite3_exec(db, sql.c_str(), collect, &result, &error) != SQLITE_OK) {
    result = std::string("error: ") + (error != nullptr ? error : "?");
    sqlite3_free(error);
  }
  sqlite3_close(db);
  return result;
}

void SetMtimeHoursAgo(const std::string& path, int hours) {
  struct timeval times[2];
  gettimeofday(&times[0], nullptr);
  times[0].tv_sec -= hours * 3600;
  times[1] = times[0];
  ASSERT_EQ(utimes(path.c_str(), times), 0) << path << ": " << std::strerror(errno);
}

// A child process that runs `body` and reports one line back through a pipe.
class Child {
 public:
  template <typename Body>
  explicit Child(Body body) {
    int fds[2];
    if (pipe(fds) != 0) return;
    pid_ = fork();
    if (pid_ == 0) {
      close(fds[0]);
      const std::string line = body() + "\n";
      if (write(fds[1], line.data(), line.size()) < 0) _exit(2);
      // Stay alive holding whatever body opened until killed, when asked to.
      if (line.rfind("HOLD", 0) == 0) {
        for (;;) pause();
      }
      _exit(0);
    }
    close(fds[1]);
    read_fd_ = fds[0];
  }
  ~Child() {
    if (pid_ > 0) Kill();
    if (read_fd_ >= 0) close(read_fd_);
  }
  pid_t pid() const { return pid_; }
  // The child's report (without the newline).
  std::string ReadLine() {
    std::string line;
    char c;
    while (read_fd_ >= 0 && read(read_fd_, &c, 1) == 1 && c != '\n') line.push_back(c);
    return line;
  }
  void Kill() {
    kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
  int read_fd_ = -1;
};

// --- the factory ---------------------------------------------------------------

TEST(OpenStore, AFolderIsTheEmbeddedStoreAndAUriIsPostgres) {
  TempDir dir;
  auto store = OpenStore(dir.File("nested/store"));
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  EXPECT_EQ(store.value()->backend(), "sqlite");
  EXPECT_TRUE(fs::is_regular_file(dir.File("nested/store/meta.sqlite3")));
  EXPECT_EQ(OpenStore("").status().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(IsPostgresSpec("postgresql://user@host/db"));
  EXPECT_TRUE(IsPostgresSpec("postgres:///db?host=/run/postgresql"));
  EXPECT_FALSE(IsPostgresSpec("/var/lib/meshstream"));
  EXPECT_FALSE(IsPostgresSpec("postgresql"));
  EXPECT_FALSE(IsPostgresSpec("./postgresql://x"));
  auto pg = OpenStore("postgresql:///meshstream?host=" + dir.File("no-such-socket-dir"));
  EXPECT_FALSE(pg.ok());
#if !__has_include("services/store/pg_store.h")
  EXPECT_EQ(pg.status().code(), StatusCode::kUnsupported) << pg.status().ToString();
#endif
  EXPECT_FALSE(fs::exists("postgresql:"));  // never taken for a folder
}

// --- one process per folder ----------------------------------------------------

TEST(SqliteStore, ASecondOpenInTheSameProcessIsRefused) {
  TempDir dir;
  auto first = MustOpen(dir.path());
  ASSERT_NE(first, nullptr);
  auto second = SqliteStore::Open(dir.path());
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), StatusCode::kUnavailable);
  EXPECT_EQ(second.status().message(),
            dir.path() + " is in use by another meshstream process (pid " + std::to_string(getpid()) + ")");
  EXPECT_EQ(test_util::ReadText(dir.File("LOCK")), std::to_string(getpid()) + "\n");
  first.reset();
  EXPECT_NE(MustOpen(dir.path()), nullptr);
}

TEST(SqliteStore, AnotherProcessIsRefusedWhileThisOneHoldsTheFolder) {
  TempDir dir;
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  Child child([&] {
    auto other = SqliteStore::Open(dir.path());
    return other.ok() ? std::string("opened") : other.status().ToString();
  });
  ASSERT_GT(child.pid(), 0);
  const std::string report = child.ReadLine();
  EXPECT_NE(report.find("UNAVAILABLE"), std::string::npos) << report;
  EXPECT_NE(report.find("in use by another meshstream process (pid " + std::to_string(getpid()) + ")"),
            std::string::npos)
      << report;
}

TEST(SqliteStore, TheLockDiesWithItsProcessEvenBySigkill) {
  TempDir dir;
  Child holder([&] {
    auto store = SqliteStore::Open(dir.path());
    if (!store.ok()) return store.status().ToString();
    auto* leaked = store.value().release();  // held until the process is killed
    (void)leaked;
    return std::string("HOLD");
  });
  ASSERT_GT(holder.pid(), 0);
  ASSERT_EQ(holder.ReadLine(), "HOLD");
  auto refused = SqliteStore::Open(dir.path());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kUnavailable);
  EXPECT_NE(refused.status().message().find("(pid " + std::to_string(holder.pid()) + ")"), std::string::npos)
      << refused.status().message();
  holder.Kill();
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(test_util::ReadText(dir.File("LOCK")), std::to_string(getpid()) + "\n");
}

// --- a tool beside the server (StoreLock::kShared) -----------------------------

TEST(SqliteStore, ASharedStoreBesideTheServerReadsMetadataAndManagesTokensOnly) {
  TempDir dir;
  auto server = MustOpen(dir.path());
  ASSERT_NE(server, nullptr);
  auto sink = server->NewBlob();
  ASSERT_TRUE(sink.ok());
  MS_ASSERT_OK(sink.value()->Append(Data("source"), 6));
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, sink.value()->Commit());
  NewVersion nv;
  nv.tenant = "acme";
  nv.asset = "chair";
  nv.source = SourceFile{"chair.glb", src, 6};
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, server->CreateVersion(nv));
  MS_ASSERT_OK(server->AppendUpload("acme", "up", 0, Data("abc"), 3));
  // A blob being written while the tool opens: the tool must leave its temporary file alone.
  auto in_flight = server->NewBlob();
  ASSERT_TRUE(in_flight.ok());
  MS_ASSERT_OK(in_flight.value()->Append(Data("in flight"), 9));

  auto opened = OpenStore(dir.path(), StoreLock::kShared);
  ASSERT_TRUE(opened.ok()) << opened.status().ToString();
  Store& tool = *opened.value();
  MS_EXPECT_OK(in_flight.value()->Commit(Sha("in flight")));

  // Tokens written by the tool are seen by the server at its next read, and back.
  MS_ASSERT_OK_AND_ASSIGN(const TokenRecord token, tool.CreateToken("acme", false, Sha("token")));
  EXPECT_EQ(server->FindToken(Sha("token")).value().id, token.id);
  MS_ASSERT_OK(tool.RevokeToken(token.id));
  EXPECT_EQ(server->FindToken(Sha("token")).status().code(), StatusCode::kNotFound);
  MS_ASSERT_OK(server->CreateToken("globex", true, Sha("other")));
  EXPECT_EQ(tool.ListTokens().value().size(), 2u);
  // Metadata reads work.
  EXPECT_EQ(tool.GetVersion("acme", "chair", 0).value().job_id, v.job_id);
  EXPECT_EQ(tool.ListAssets("acme", 0, "").value().items.size(), 1u);
  EXPECT_EQ(tool.GetJob("acme", v.job_id).value().state, JobState::kPending);
  EXPECT_EQ(tool.CountUnfinishedJobs().value(), 1);
  EXPECT_EQ(tool.UploadSize("acme", "up").value(), 3u);
  // What belongs to the server is refused, naming the operation (after the
  // arguments' checks, which come first on every store).
  ArtifactSummary summary;
  summary.artifact_sha256 = src;
  const std::vector<std::pair<std::string, Status>> refused = {
      {"NewBlob", StatusOf(tool.NewBlob())},
      {"GetBlob", StatusOf(tool.GetBlob(src, 100))},
      {"HasBlob", StatusOf(tool.HasBlob(src))},
      {"RemoveOrphanBlobs", StatusOf(tool.RemoveOrphanBlobs(0))},
      {"AppendUpload", tool.AppendUpload("acme", "up", 3, Data("d"), 1)},
      {"CommitUpload", StatusOf(tool.CommitUpload("acme", "up", ""))},
      {"DiscardUpload", tool.DiscardUpload("acme", "up")},
      {"ExpireUploads", StatusOf(tool.ExpireUploads(0))},
      {"CreateVersion", StatusOf(tool.CreateVersion(nv))},
      {"ClaimJob", StatusOf(tool.ClaimJob("tool", NowMs(), 1000))},
      {"RenewLease", tool.RenewLease(v.job_id, "tool", NowMs(), 1000, 0.5, "")},
      {"CompleteJob", tool.CompleteJob(v.job_id, "tool", summary)},
      {"FailJob", tool.FailJob(v.job_id, "tool", "no")},
      {"ReleaseAllLeases", StatusOf(tool.ReleaseAllLeases())},
      {"PutArtifact", tool.PutArtifact("key", summary)},
  };
  for (const auto& [operation, status] : refused) {
    EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition) << operation << ": " << status.ToString();
    EXPECT_EQ(status.message().rfind(operation + ": ", 0), 0u) << status.message();
  }
  EXPECT_EQ(server->UploadSize("acme", "up").value(), 3u);
  EXPECT_EQ(server->GetJob("acme", v.job_id).value().state, JobState::kPending);
  // The tool holds no lock: the server can stop and start while it is open.
  server.reset();
  server = MustOpen(dir.path());
  EXPECT_NE(server, nullptr);
}

TEST(SqliteStore, ASharedStoreWorksBesideAServerInAnotherProcess) {
  TempDir dir;
  Child holder([&] {
    auto store = SqliteStore::Open(dir.path());
    if (!store.ok()) return store.status().ToString();
    store.value().release();
    return std::string("HOLD");
  });
  ASSERT_GT(holder.pid(), 0);
  ASSERT_EQ(holder.ReadLine(), "HOLD");
  {
    auto tool = SqliteStore::Open(dir.path(), StoreLock::kShared);
    ASSERT_TRUE(tool.ok()) << tool.status().ToString();
    MS_ASSERT_OK(tool.value()->CreateToken("acme", false, Sha("token")));
    EXPECT_EQ(SqliteStore::Open(dir.path()).status().code(), StatusCode::kUnavailable);  // the server still has it
  }
  holder.Kill();
  auto server = MustOpen(dir.path());
  ASSERT_NE(server, nullptr);
  EXPECT_EQ(server->FindToken(Sha("token")).value().tenant, "acme");
}

TEST(SqliteStore, ASharedStoreMigratesOnlyWhileNoServerHoldsTheFolder) {
  TempDir dir;
  const std::string db = dir.File("meta.sqlite3");
  {
    // Nobody holds the folder: the tool may set the store up, and lets go of the lock.
    auto tool = SqliteStore::Open(dir.path(), StoreLock::kShared);
    ASSERT_TRUE(tool.ok()) << tool.status().ToString();
    EXPECT_EQ(tool.value()->ReadSettings().value().schema_version, SqliteStore::kSchemaVersion);
    EXPECT_NE(MustOpen(dir.path()), nullptr);
  }
  auto server = MustOpen(dir.path());
  ASSERT_NE(server, nullptr);
  // An older schema under a running server (set behind its back here): the tool leaves it to the server.
  ASSERT_EQ(RawSql(db, "PRAGMA user_version = 0"), "");
  auto older = SqliteStore::Open(dir.path(), StoreLock::kShared);
  ASSERT_FALSE(older.ok());
  EXPECT_EQ(older.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(older.status().message().find("schema version 0 is older"), std::string::npos) << older.status().message();
  EXPECT_EQ(RawSql(db, "PRAGMA user_version"), "0");
  // A newer one is refused as it is for a server.
  ASSERT_EQ(RawSql(db, "PRAGMA user_version = " + std::to_string(SqliteStore::kSchemaVersion + 1)), "");
  EXPECT_EQ(SqliteStore::Open(dir.path(), StoreLock::kShared).status().code(), StatusCode::kFailedPrecondition);
  ASSERT_EQ(RawSql(db, "PRAGMA user_version = " + std::to_string(SqliteStore::kSchemaVersion)), "");
  MS_EXPECT_OK(SqliteStore::Open(dir.path(), StoreLock::kShared));
}

// --- durability ----------------------------------------------------------------

TEST(SqliteStore, RunsInWalModeWithFullSync) {
  TempDir dir;
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  MS_ASSERT_OK_AND_ASSIGN(const SqliteStore::Settings settings, store->ReadSettings());
  EXPECT_EQ(settings.journal_mode, "wal");
  EXPECT_EQ(settings.synchronous, 2);  // FULL
  EXPECT_GT(settings.busy_timeout_ms, 0);
  EXPECT_EQ(settings.schema_version, SqliteStore::kSchemaVersion);
  MS_ASSERT_OK(store->CreateToken("acme", false, Sha("t")));
  EXPECT_TRUE(fs::exists(dir.File("meta.sqlite3-wal")));
  store.reset();
  EXPECT_EQ(RawSql(dir.File("meta.sqlite3"), "PRAGMA journal_mode"), "wal");  // persistent in the file
}

TEST(SqliteStore, WhatReturnedOkSurvivesSigkill) {
  TempDir dir;
  Child writer([&] {
    auto store = SqliteStore::Open(dir.path());
    if (!store.ok()) return store.status().ToString();
    Store& s = *store.value();
    auto sink = s.NewBlob();
    if (!sink.ok()) return sink.status().ToString();
    const std::string bytes = "a source written just before the crash";
    if (Status st = sink.value()->Append(Data(bytes), bytes.size()); !st.ok()) return st.ToString();
    auto digest = sink.value()->Commit();
    if (!digest.ok()) return digest.status().ToString();
    NewVersion v;
    v.tenant = "acme";
    v.asset = "chair";
    v.source = SourceFile{"chair.glb", digest.value(), bytes.size()};
    auto created = s.CreateVersion(v);
    if (!created.ok()) return created.status().ToString();
    if (Status st = s.AppendUpload("acme", "up", 0, Data("partial"), 7); !st.ok()) return st.ToString();
    store.value().release();  // no clean close: the WAL is not checkpointed
    return "HOLD " + created->job_id;
  });
  ASSERT_GT(writer.pid(), 0);
  const std::string report = writer.ReadLine();
  ASSERT_EQ(report.rfind("HOLD ", 0), 0u) << report;
  const std::string job_id = report.substr(5);
  writer.Kill();

  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store->GetVersion("acme", "chair", 0));
  EXPECT_EQ(v.version, 1);
  EXPECT_EQ(v.job_id, job_id);
  EXPECT_EQ(store->GetBlob(v.source.sha256, 1000).value().size(), v.source.size);
  EXPECT_EQ(store->GetJob("acme", job_id).value().state, JobState::kPending);
  EXPECT_EQ(store->UploadSize("acme", "up").value(), 7u);
}

// --- the schema ----------------------------------------------------------------

TEST(SqliteStore, AFreshStoreGetsTheCurrentSchemaAndKeepsItOnReopen) {
  TempDir dir;
  {
    auto store = MustOpen(dir.path());
    ASSERT_NE(store, nullptr);
    MS_ASSERT_OK(store->CreateToken("acme", false, Sha("t")));
  }
  const std::string db = dir.File("meta.sqlite3");
  EXPECT_EQ(RawSql(db, "PRAGMA user_version"), std::to_string(SqliteStore::kSchemaVersion));
  EXPECT_EQ(RawSql(db, "SELECT group_concat(name, ',') FROM (SELECT name FROM sqlite_master WHERE type = 'table' "
                       "ORDER BY name)"),
            "artifacts,assets,jobs,tokens,uploads,version_resources,versions");
  {
    auto store = MustOpen(dir.path());
    ASSERT_NE(store, nullptr);
    MS_EXPECT_OK(store->FindToken(Sha("t")));
  }
  EXPECT_EQ(RawSql(db, "PRAGMA user_version"), std::to_string(SqliteStore::kSchemaVersion));
}

TEST(SqliteStore, AnOlderDatabaseIsMigratedAtOpen) {
  TempDir dir;
  // Schema version 0: a database meshstream never set up (here with a table
  // of the operator's, which the migration leaves alone).
  ASSERT_EQ(RawSql(dir.File("meta.sqlite3"), "CREATE TABLE notes (x TEXT); INSERT INTO notes VALUES ('kept')"), "");
  ASSERT_EQ(RawSql(dir.File("meta.sqlite3"), "PRAGMA user_version"), "0");
  {
    auto store = MustOpen(dir.path());
    ASSERT_NE(store, nullptr);
    EXPECT_EQ(store->ReadSettings().value().schema_version, SqliteStore::kSchemaVersion);
    MS_EXPECT_OK(store->CreateToken("acme", false, Sha("t")));
  }
  EXPECT_EQ(RawSql(dir.File("meta.sqlite3"), "SELECT x FROM notes"), "kept");
}

TEST(SqliteStore, AFailedMigrationStepChangesNothing) {
  TempDir dir;
  const std::string db = dir.File("meta.sqlite3");
  // A table in the way of the first step: the step fails as a whole.
  ASSERT_EQ(RawSql(db, "CREATE TABLE jobs (something_else INTEGER)"), "");
  auto store = SqliteStore::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_NE(store.status().message().find("migration to schema 1"), std::string::npos) << store.status().ToString();
  EXPECT_EQ(RawSql(db, "PRAGMA user_version"), "0");
  EXPECT_EQ(RawSql(db, "SELECT count(*) FROM sqlite_master WHERE name = 'tokens'"), "0");
  // The failed Open released the folder.
  ASSERT_EQ(RawSql(db, "DROP TABLE jobs"), "");
  EXPECT_NE(MustOpen(dir.path()), nullptr);
}

TEST(SqliteStore, ANewerSchemaIsRefusedAndLeftAlone) {
  TempDir dir;
  { ASSERT_NE(MustOpen(dir.path()), nullptr); }
  const std::string db = dir.File("meta.sqlite3");
  const int64_t newer = SqliteStore::kSchemaVersion + 1;
  ASSERT_EQ(RawSql(db, "PRAGMA user_version = " + std::to_string(newer)), "");
  auto store = SqliteStore::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(store.status().message().find("schema version " + std::to_string(newer)), std::string::npos)
      << store.status().message();
  EXPECT_NE(store.status().message().find(std::to_string(SqliteStore::kSchemaVersion) + " this meshstream knows"),
            std::string::npos)
      << store.status().message();
  EXPECT_EQ(RawSql(db, "PRAGMA user_version"), std::to_string(newer));
}

TEST(SqliteStore, AFileThatIsNotADatabaseIsDataLoss) {
  TempDir dir;
  test_util::WriteText(dir.File("meta.sqlite3"), std::string(4096, 'x'));
  auto store = SqliteStore::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), StatusCode::kDataLoss) << store.status().ToString();
  fs::remove(dir.File("meta.sqlite3"));
  EXPECT_NE(MustOpen(dir.path()), nullptr);  // and the lock was released
}

// --- upload files --------------------------------------------------------------

TEST(SqliteStore, AnUploadSurvivesReopenAndAnUnacknowledgedTailIsDropped) {
  TempDir dir;
  const std::string part = dir.File("uploads/acme/up.part");
  {
    auto store = MustOpen(dir.path());
    ASSERT_NE(store, nullptr);
    MS_ASSERT_OK(store->AppendUpload("acme", "up", 0, Data("hello"), 5));
    EXPECT_EQ(test_util::ReadText(part), "hello");
  }
  // Bytes written by an append that crashed before it returned.
  { std::ofstream(part, std::ios::binary | std::ios::app) << " JUNK, longer than what comes next"; }
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->UploadSize("acme", "up").value(), 5u);
  MS_ASSERT_OK(store->AppendUpload("acme", "up", 5, Data(" world"), 6));
  EXPECT_EQ(test_util::ReadText(part), "hello world");
  EXPECT_EQ(store->CommitUpload("acme", "up", Sha("hello world")).value(), Sha("hello world"));
  EXPECT_FALSE(fs::exists(part));
}

TEST(SqliteStore, UploadFilesStayInsideTheUploadsFolder) {
  TempDir dir;
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  for (const std::string tenant : {".", ".."}) {
    const Status status = store->AppendUpload(tenant, "meta", 0, Data("x"), 1);
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
    EXPECT_NE(status.message().find("tenant"), std::string::npos) << status.message();
  }
  // "." and ".." are no names at all (store.h, IsValidName).
  const Status dots = store->AppendUpload("acme", "..", 0, Data("x"), 1);
  EXPECT_EQ(dots.code(), StatusCode::kInvalidArgument) << dots.ToString();
  MS_ASSERT_OK(store->AppendUpload("acme", "...", 0, Data("x"), 1));  // a file named "....part"
  EXPECT_TRUE(fs::is_regular_file(dir.File("uploads/acme/....part")));
  EXPECT_FALSE(fs::exists(dir.File("meta.part")));
  EXPECT_FALSE(fs::exists(dir.File("uploads/meta.part")));
}

TEST(SqliteStore, ExpireUploadsAlsoRemovesOldFilesACrashLeftWithoutARow) {
  TempDir dir;
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  MS_ASSERT_OK(store->AppendUpload("acme", "live", 0, Data("x"), 1));
  SetMtimeHoursAgo(dir.File("uploads/acme/live.part"), 2);  // its row, not its file, says when it was written
  test_util::WriteText(dir.File("uploads/acme/stray.part"), "left behind");
  SetMtimeHoursAgo(dir.File("uploads/acme/stray.part"), 2);
  test_util::WriteText(dir.File("uploads/acme/young.part"), "being created right now");
  EXPECT_EQ(store->ExpireUploads(3600 * 1000).value(), 0u);  // strays are not uploads
  EXPECT_FALSE(fs::exists(dir.File("uploads/acme/stray.part")));
  EXPECT_TRUE(fs::exists(dir.File("uploads/acme/young.part")));
  EXPECT_TRUE(fs::exists(dir.File("uploads/acme/live.part")));
  EXPECT_EQ(store->UploadSize("acme", "live").value(), 1u);
}

// --- blobs -----------------------------------------------------------------------

TEST(SqliteStore, BlobsLiveInTheBlobFolderAndOrphansGoByFileAge) {
  TempDir dir;
  auto store = MustOpen(dir.path());
  ASSERT_NE(store, nullptr);
  const std::string old_bytes = "an orphan from yesterday", new_bytes = "an orphan committed just now";
  const std::string old_digest = Sha(old_bytes), new_digest = Sha(new_bytes);
  for (const std::string* bytes : {&old_bytes, &new_bytes}) {
    auto sink = store->NewBlob();
    ASSERT_TRUE(sink.ok());
    MS_ASSERT_OK(sink.value()->Append(Data(*bytes), bytes->size()));
    MS_ASSERT_OK(sink.value()->Commit());
  }
  const std::string old_path = dir.File("blobs/" + old_digest.substr(0, 2) + "/" + old_digest);
  ASSERT_TRUE(fs::is_regular_file(old_path));
  SetMtimeHoursAgo(old_path, 24);
  EXPECT_EQ(store->RemoveOrphanBlobs(3600 * 1000).value(), 1u);
  EXPECT_FALSE(store->HasBlob(old_digest).value());
  EXPECT_TRUE(store->HasBlob(new_digest).value());
}

}  // namespace
}  // namespace meshstream
