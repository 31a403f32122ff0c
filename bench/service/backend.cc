#include "bench/service/backend.h"

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// version(), and the settings that decide what a commit costs.
std::map<std::string, std::string> DescribePostgres(const ms::test_util::PgCluster& pg) {
  std::map<std::string, std::string> out;
  out["version"] = pg.Query("SELECT version()");
  for (const char* name : {"fsync", "synchronous_commit", "full_page_writes", "wal_sync_method", "shared_buffers",
                           "max_connections", "default_toast_compression"}) {
    out[name] = pg.Query(std::string("SHOW ") + name);
  }
  return out;
}

}  // namespace

void Fail(Backend& b, const std::string& what, const std::string& error) {
  std::fprintf(stderr, "meshstream_bench_service: %s: %s: FAILED: %s\n", b.name.c_str(), what.c_str(), error.c_str());
  b.failures.push_back({{"what", what}, {"error", error}});
}

void StartBackend(Backend& b, const Args& args) {
  if (b.name == "sqlite") {
    b.folder = ms::bench::MakeTempFolder(args.work_dir, "meshstream-bench-sqlite");
    b.store = b.folder + "/store";
  } else {
    b.pg = Check(ms::test_util::PgCluster::Start({args.work_dir, args.pg_fsync}), "PostgreSQL cluster");
    b.store = b.pg->uri();
  }
  std::vector<std::string>* log = &b.log;
  const bool verbose = args.verbose;
  const std::string name = b.name;
  const ms::ServerOptions o = ms::bench::BenchServerOptions(
      b.store, args.workers, "bench-" + b.name, [log, verbose, name](const std::string& line) {
        log->push_back(line);
        if (verbose) std::fprintf(stderr, "[%s server] %s\n", name.c_str(), line.c_str());
      });
  b.server = Check(ms::Server::Start(o), b.name + " server");
  b.client = std::make_unique<AssetApi>(b.server->address());
}

void StopBackend(Backend& b) {
  b.client.reset();
  StopServer(b.server);
  b.pg.reset();
  if (!b.folder.empty()) {
    std::error_code ec;
    fs::remove_all(b.folder, ec);
  }
}

json BackendsInfo(const std::vector<Backend*>& backends, const Args& args) {
  json backends_info = json::object();
  for (Backend* b : backends) {
    json info = {{"address", b->server->address()}, {"workers", args.workers}};
    if (b->pg) {
      info["postgresql"] = DescribePostgres(*b->pg);
      info["pool_size"] = 4;
      info["store"] = "postgresql:///postgres?host=<cluster folder>&user=postgres (Unix socket)";
    } else {
      info["store"] = "<work_dir>/meshstream-bench-sqlite-*/store";
    }
    backends_info[b->name] = info;
  }
  return backends_info;
}

void AddStoreSizes(const std::vector<Backend*>& backends, json& backends_info) {
  for (Backend* b : backends) {
    if (b->pg) {
      backends_info[b->name]["blob_chunks"] = {
          {"raw_bytes", b->pg->Query("SELECT coalesce(sum(octet_length(data)), 0) FROM meshstream.blob_chunks")},
          {"stored_bytes", b->pg->Query("SELECT coalesce(sum(pg_column_size(data)), 0) FROM meshstream.blob_chunks")},
          {"column_storage", b->pg->Query("SELECT attstorage FROM pg_attribute WHERE attrelid = "
                                          "'meshstream.blob_chunks'::regclass AND attname = 'data'")}};
      backends_info[b->name]["database_bytes"] = b->pg->Query("SELECT pg_database_size('postgres')");
    } else {
      backends_info[b->name]["store_bytes"] = FirstLineOf("du -sb " + ShellQuote(b->folder) + " | cut -f1");
    }
  }
}

}  // namespace meshstream::bench::service
