// A throwaway PostgreSQL cluster for the service benchmark, with fsync ON.
//
// tests/common/pg_cluster.h starts its clusters with fsync=off (tests need
// speed, not durability); a benchmark of the shared store must pay for what
// a deployment pays for, so this one runs with PostgreSQL's durable
// defaults spelled out: fsync=on, synchronous_commit=on, full_page_writes=on.
// Like the tests' cluster: initdb into a fresh folder under `parent` as the
// `postgres` user (runuser when we are root), a server on a Unix socket in
// that folder only (no TCP port), stopped (fast) and removed on destruction.
//
// Contract: for benchmark programs only; runs shell commands. Not thread-safe.
#ifndef MESHSTREAM_BENCH_SERVICE_PG_H_
#define MESHSTREAM_BENCH_SERVICE_PG_H_

#include <map>
#include <memory>
#include <string>

#include "codec/core/status.h"

namespace meshstream::bench {

class BenchPgCluster {
 public:
  // `fsync`: "on" (the default of PostgreSQL and of this benchmark) or "off".
  static StatusOr<std::unique_ptr<BenchPgCluster>> Start(const std::string& parent, bool fsync = true);
  ~BenchPgCluster();

  // The URI `meshstream serve --store` takes.
  std::string uri() const { return "postgresql:///postgres?host=" + dir_ + "&user=postgres"; }
  const std::string& dir() const { return dir_; }

  // The first line psql prints for `sql` (-qAt: rows only, no command tags);
  // "" on failure.
  std::string Query(const std::string& sql) const;
  // version(), and the settings that decide what a commit costs.
  std::map<std::string, std::string> Describe() const;

 private:
  BenchPgCluster() = default;
  std::string dir_, bin_, runas_;
  bool running_ = false;
};

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SERVICE_PG_H_
