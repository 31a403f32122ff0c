// A throwaway PostgreSQL cluster for tests that need the real database:
// initdb into a fresh temporary folder as the unprivileged `postgres` user
// (PostgreSQL refuses to run as root), a server listening only on a Unix
// socket in that folder (no TCP port), stopped and removed afterwards.
//
// Needs Debian's `postgresql` package (scripts/install-deps installs it) and
// root, or the postgres user itself, to switch users. When the cluster cannot
// start, Start() says why: tests fail with that reason rather than skip.
#ifndef MESHSTREAM_TESTING_PG_CLUSTER_H_
#define MESHSTREAM_TESTING_PG_CLUSTER_H_

#include <pwd.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "codec/core/status.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

struct PgClusterOptions {
  std::string parent;  // where the cluster's folder is made ("": the system's temporary folder)
  // Tests run with fsync off (nothing must survive a power cut there); the
  // service benchmark turns it on, with synchronous_commit and
  // full_page_writes, to measure what a deployment pays.
  bool fsync = false;
};

class PgCluster {
 public:
  static StatusOr<std::unique_ptr<PgCluster>> Start(const PgClusterOptions& options = {}) {
    namespace fs = std::filesystem;
    std::string bin;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator("/usr/lib/postgresql", ec)) {
      if (fs::exists(entry.path() / "bin" / "initdb")) bin = (entry.path() / "bin").string();
    }
    if (bin.empty()) return NotFound("no PostgreSQL server under /usr/lib/postgresql (apt-get install postgresql)");
    const passwd* pg = getpwnam("postgres");
    if (pg == nullptr) return NotFound("no 'postgres' user (the postgresql package creates it)");
    const fs::path parent = options.parent.empty() ? fs::temp_directory_path() : fs::path(options.parent);
    std::string pattern = (parent / "meshstream-pg-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) return IoError("mkdtemp failed");
    auto cluster = std::unique_ptr<PgCluster>(new PgCluster());
    cluster->dir_ = pattern;
    cluster->bin_ = bin;
    const bool as_postgres = getuid() == pg->pw_uid;
    if (!as_postgres && chown(pattern.c_str(), pg->pw_uid, pg->pw_gid) != 0) {
      return IoError(pattern + ": cannot hand the folder to the postgres user (tests that start PostgreSQL run as root)");
    }
    cluster->runas_ = as_postgres ? "" : "runuser -u postgres -- ";
    const std::string data = cluster->dir_ + "/data";
    auto init = RunCommand(cluster->runas_ + bin + "/initdb -D " + Quote(data) +
                           " -A trust -U postgres --no-sync -E UTF8 --locale=C.UTF-8");
    if (init.exit_code != 0) return Internal("initdb failed: " + init.err);
    auto start = RunCommand(cluster->runas_ + bin + "/pg_ctl -D " + Quote(data) + " -w -t 60 -l " +
                            Quote(cluster->dir_ + "/server.log") + " -o " +
                            Quote("-c listen_addresses='' -k " + cluster->dir_ +
                                  (options.fsync ? " -c fsync=on -c synchronous_commit=on -c full_page_writes=on"
                                                 : " -c fsync=off")) +
                            " start");
    if (start.exit_code != 0) {
      return Internal("pg_ctl start failed: " + start.err + " " + ReadText(cluster->dir_ + "/server.log"));
    }
    cluster->running_ = true;
    return cluster;
  }

  ~PgCluster() {
    if (running_) RunCommand(runas_ + bin_ + "/pg_ctl -D " + Quote(dir_ + "/data") + " -m immediate -w stop");
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  // libpq keywords: the socket folder as host, trust authentication.
  std::string connection_string(const std::string& database = "postgres") const {
    return "host=" + dir_ + " user=postgres dbname=" + database;
  }
  const std::string& socket_dir() const { return dir_; }
  // The URI `meshstream serve --store` takes.
  std::string uri() const { return "postgresql:///postgres?host=" + dir_ + "&user=postgres"; }
  // The first line psql prints for `sql` (rows only, no command tags); "" on failure.
  std::string Query(const std::string& sql) const {
    const auto r = RunCommand(runas_ + bin_ + "/psql -X -q -At -h " + Quote(dir_) + " -U postgres -d postgres -c " +
                              Quote(sql));
    return r.out.substr(0, r.out.find('\n'));
  }

 private:
  PgCluster() = default;
  std::string dir_, bin_, runas_;
  bool running_ = false;
};

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_PG_CLUSTER_H_
