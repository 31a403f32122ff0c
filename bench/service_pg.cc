#include "bench/service_pg.h"

#include <pwd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "bench/bench_util.h"

namespace meshstream::bench {

namespace {

namespace fs = std::filesystem;

// Runs `cmd` with stdin closed and its output into `log`; the exit status.
int RunLogged(const std::string& cmd, const std::string& log) {
  const int rc = std::system((cmd + " </dev/null >>" + ShellQuote(log) + " 2>&1").c_str());
  return rc != -1 && WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

std::string Tail(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text.size() > 2000 ? text.substr(text.size() - 2000) : text;
}

}  // namespace

StatusOr<std::unique_ptr<BenchPgCluster>> BenchPgCluster::Start(const std::string& parent, bool fsync) {
  std::string bin;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    if (fs::exists(entry.path() / "bin" / "initdb")) bin = (entry.path() / "bin").string();
  }
  if (bin.empty()) return NotFound("no PostgreSQL server under /usr/lib/postgresql (apt-get install postgresql)");
  const passwd* pg = getpwnam("postgres");
  if (pg == nullptr) return NotFound("no 'postgres' user (the postgresql package creates it)");
  std::string pattern = (fs::path(parent) / "meshstream-bench-pg-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) return IoError(parent + ": mkdtemp failed");
  auto cluster = std::unique_ptr<BenchPgCluster>(new BenchPgCluster());
  cluster->dir_ = pattern;
  cluster->bin_ = bin;
  const bool as_postgres = getuid() == pg->pw_uid;
  if (!as_postgres && chown(pattern.c_str(), pg->pw_uid, pg->pw_gid) != 0) {
    return IoError(pattern + ": cannot hand the folder to the postgres user (run as root or as postgres)");
  }
  cluster->runas_ = as_postgres ? "" : "runuser -u postgres -- ";
  const std::string data = cluster->dir_ + "/data";
  const std::string log = cluster->dir_ + "/setup.log";
  // --no-sync: initdb's own files need not reach the disk; the server below
  // fsyncs everything it commits.
  if (RunLogged(cluster->runas_ + bin + "/initdb -D " + ShellQuote(data) +
                    " -A trust -U postgres --no-sync -E UTF8 --locale=C.UTF-8",
                log) != 0) {
    return Internal("initdb failed: " + Tail(log));
  }
  const std::string settings = "-c listen_addresses='' -k " + cluster->dir_ + " -c fsync=" + (fsync ? "on" : "off") +
                               " -c synchronous_commit=on -c full_page_writes=on";
  if (RunLogged(cluster->runas_ + bin + "/pg_ctl -D " + ShellQuote(data) + " -w -t 60 -l " +
                    ShellQuote(cluster->dir_ + "/server.log") + " -o " + ShellQuote(settings) + " start",
                log) != 0) {
    return Internal("pg_ctl start failed: " + Tail(log) + Tail(cluster->dir_ + "/server.log"));
  }
  cluster->running_ = true;
  return cluster;
}

BenchPgCluster::~BenchPgCluster() {
  if (running_) {
    RunLogged(runas_ + bin_ + "/pg_ctl -D " + ShellQuote(dir_ + "/data") + " -m fast -w stop", "/dev/null");
  }
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

std::string BenchPgCluster::Query(const std::string& sql) const {
  return FirstLineOf(runas_ + bin_ + "/psql -X -q -At -h " + ShellQuote(dir_) + " -U postgres -d postgres -c " +
                     ShellQuote(sql) + " 2>/dev/null </dev/null");
}

std::map<std::string, std::string> BenchPgCluster::Describe() const {
  std::map<std::string, std::string> out;
  out["version"] = Query("SELECT version()");
  for (const char* name : {"fsync", "synchronous_commit", "full_page_writes", "wal_sync_method", "shared_buffers",
                           "max_connections", "default_toast_compression"}) {
    out[name] = Query(std::string("SHOW ") + name);
  }
  return out;
}

}  // namespace meshstream::bench
