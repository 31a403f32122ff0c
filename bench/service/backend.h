// The service benchmark's backends: a meshstream server per store (SQLite
// in a temporary folder, PostgreSQL on a throwaway cluster with --pg-fsync),
// its asset API client, and what was measured on it.
#ifndef MESHSTREAM_BENCH_SERVICE_BACKEND_H_
#define MESHSTREAM_BENCH_SERVICE_BACKEND_H_

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/harness.h"
#include "bench/service/args.h"
#include "services/server/server.h"
#include "testing/pg_cluster.h"

namespace meshstream::bench::service {

struct Backend {
  std::string name;   // "sqlite" or "postgresql"
  std::string store;  // the --store value
  std::string folder; // the temporary folder of the SQLite store
  std::unique_ptr<test_util::PgCluster> pg;
  std::unique_ptr<Server> server;
  std::unique_ptr<AssetApi> client;
  nlohmann::json failures = nlohmann::json::array();
  nlohmann::json ingest = nlohmann::json::object();
  nlohmann::json exports = nlohmann::json::object();
  std::vector<std::string> log;
};

// Records a failed call of `b` (reported in the JSON, never timed).
void Fail(Backend& b, const std::string& what, const std::string& error);

// Starts b.name's store and server (Die when it cannot) and its client.
void StartBackend(Backend& b, const Args& args);
// Stops the server, the cluster, and removes the SQLite folder.
void StopBackend(Backend& b);

// Each backend's address, store and (PostgreSQL) settings.
nlohmann::json BackendsInfo(const std::vector<Backend*>& backends, const Args& args);
// What the stores hold afterwards, into backends_info.
void AddStoreSizes(const std::vector<Backend*>& backends, nlohmann::json& backends_info);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_BACKEND_H_
