#include "bench/service/references.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service/ingest.h"
#include "bench/service_echo.h"
#include "bench/service_stats.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/store/blob_store.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string StatusText(const grpc::Status& s) {
  return "status " + std::to_string(s.error_code()) + ": " + s.error_message();
}

// What a blob commit costs at least: the bytes into a new file, fsync, rename,
// fsync of the folder (services/store/blob_store.cc does this and more).
double DiskWriteFsyncMs(const std::string& dir, const std::vector<uint8_t>& bytes) {
  const std::string tmp = dir + "/write-test.part", target = dir + "/write-test";
  const auto t0 = Clock::now();
  const int fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) Die(tmp + ": cannot create");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + done, bytes.size() - done);
    if (n <= 0) Die(tmp + ": write failed");
    done += static_cast<size_t>(n);
  }
  if (fsync(fd) != 0) Die(tmp + ": fsync failed");
  close(fd);
  if (rename(tmp.c_str(), target.c_str()) != 0) Die(target + ": rename failed");
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0 || fsync(dfd) != 0) Die(dir + ": fsync of the folder failed");
  close(dfd);
  const double ms = Ms(t0, Clock::now());
  unlink(target.c_str());
  return ms;
}

// The cost of one small durable commit: 4 KiB written at the same offset and
// fdatasync'd, n times (what a WAL commit waits for at least).
json FsyncFloor(const std::string& dir, int n) {
  const std::string path = dir + "/fsync-test";
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) Die(path + ": cannot create");
  std::vector<char> page(4096, 'x');
  std::vector<double> us;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    if (pwrite(fd, page.data(), page.size(), 0) != static_cast<ssize_t>(page.size()) || fdatasync(fd) != 0) {
      Die(path + ": write or fdatasync failed");
    }
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  close(fd);
  unlink(path.c_str());
  json s = ms::bench::LatencySummary(us);
  s.erase("histogram");
  return s;
}

// What an upload of `m` costs without a server, `repeat` times each: the
// job's import + encode (ProcessSource) in this process, the same messages
// streamed into the echo server's sink, the bytes written and fsync'd into a
// file in `disk_dir`, their SHA-256.
json ModelReference(const Model& m, int repeat, const std::shared_ptr<grpc::Channel>& echo_channel,
                    const std::string& disk_dir) {
  static const auto settings = Check(ms::ResolveSettings(ms::EncodeSettings{}), "default encode settings");
  std::vector<double> encode, sink, disk, sha;
  const auto messages = UploadMessages(m, m.bytes, VariantOptions(m, 0), "");
  std::vector<grpc::ByteBuffer> buffers;
  uint64_t message_bytes = 0;
  for (const auto& msg : messages) {
    buffers.push_back(ms::bench::ToByteBuffer(msg.SerializeAsString()));
    message_bytes += buffers.back().Length();
  }
  json figures;
  for (int i = 0; i < repeat; ++i) {
    auto t0 = Clock::now();
    auto result = ms::ProcessSource(m.path, settings, nullptr);
    encode.push_back(Ms(t0, Clock::now()));
    if (!result.ok()) Die(m.path + ": ProcessSource: " + result.status().ToString());
    figures = {{"vertices", result->summary.vertices},
               {"faces", result->summary.faces},
               {"levels", result->summary.levels},
               {"progressive_bytes", result->summary.progressive_bytes}};
    uint64_t received = 0;
    t0 = Clock::now();
    const grpc::Status s = ms::bench::SinkStream(echo_channel, buffers, &received);
    sink.push_back(Ms(t0, Clock::now()));
    if (!s.ok() || received != message_bytes) Die("the echo sink failed: " + StatusText(s));
    disk.push_back(DiskWriteFsyncMs(disk_dir, m.bytes));
    t0 = Clock::now();
    const std::string digest = ms::Sha256Hex(m.bytes.data(), m.bytes.size());
    sha.push_back(Ms(t0, Clock::now()));
    if (digest.size() != 64) Die("Sha256Hex failed");
  }
  auto with_rate = [&m](const std::vector<double>& runs) {
    json j = ms::bench::RunsSummary(runs);
    j["MBps"] = MBps(m.bytes.size(), j["median_ms"].get<double>());
    return j;
  };
  return {{"file", m.file},
          {"bytes", m.bytes.size()},
          {"figures", figures},
          {"encode_inprocess", ms::bench::RunsSummary(encode)},
          {"transport_sink", with_rate(sink)},
          {"disk_write_fsync", with_rate(disk)},
          {"sha256", with_rate(sha)}};
}

// PostgreSQL's side of a blob: the file inserted as one bytea value into a
// table like blob_chunks (storage EXTENDED: TOAST compresses it with the
// cluster's default, pglz) and into one with storage EXTERNAL (no
// compression), timed inside the backend (the commit's WAL flush not
// included): what compression costs the shared store's ingest. Into
// ref_models[model]["pg_bytea_insert"]. False when the tables could not be
// set up.
bool PgByteaReference(ms::test_util::PgCluster& pg, const std::vector<Model>& models, int repeat, json& ref_models) {
  const std::string setup =
      "CREATE TABLE bench_toast_x (d bytea); CREATE TABLE bench_toast_e (d bytea); "
      "ALTER TABLE bench_toast_e ALTER d SET STORAGE EXTERNAL; "
      "CREATE FUNCTION bench_insert_ms(tbl text, path text) RETURNS double precision AS $f$ "
      "DECLARE t0 timestamptz; BEGIN t0 := clock_timestamp(); "
      "EXECUTE format('INSERT INTO %I SELECT pg_read_binary_file(%L)', tbl, path); "
      "RETURN extract(epoch FROM clock_timestamp() - t0) * 1000; END $f$ LANGUAGE plpgsql; SELECT 'ok'";
  if (pg.Query(setup) != "ok") {
    std::fprintf(stderr, "meshstream_bench_service: the PostgreSQL bytea reference could not be set up; skipped\n");
    return false;
  }
  for (const Model& m : models) {
    std::error_code ec;
    const std::string path = fs::canonical(m.path, ec).string();
    std::vector<double> compressed, external;
    for (int i = 0; i < repeat; ++i) {
      for (const char* table : {"bench_toast_x", "bench_toast_e"}) {
        const std::string v = pg.Query(std::string("SELECT bench_insert_ms('") + table + "', '" + path + "')");
        char* end = nullptr;
        const double ms_taken = std::strtod(v.c_str(), &end);
        if (v.empty() || end == v.c_str()) continue;
        (table[12] == 'x' ? compressed : external).push_back(ms_taken);
      }
    }
    if (compressed.empty() || external.empty()) continue;  // e.g. the file is not readable by postgres
    const std::string stored = pg.Query("SELECT sum(pg_column_size(d)) || ' ' || sum(octet_length(d)) FROM "
                                        "bench_toast_x");
    pg.Query("TRUNCATE bench_toast_x, bench_toast_e");
    json r = {{"compressed", ms::bench::RunsSummary(compressed)}, {"uncompressed", ms::bench::RunsSummary(external)}};
    const size_t space = stored.find(' ');
    if (space != std::string::npos) {
      const double a = std::strtod(stored.c_str(), nullptr), t = std::strtod(stored.c_str() + space, nullptr);
      if (t > 0) r["compressed_stored_fraction"] = a / t;
    }
    ref_models[m.name]["pg_bytea_insert"] = r;
  }
  pg.Query("DROP TABLE bench_toast_x, bench_toast_e; DROP FUNCTION bench_insert_ms; SELECT 'ok'");
  return true;
}

}  // namespace

json References(const Args& args, const std::vector<Model>& models, const std::vector<Backend*>& backends,
                const std::string& echo_address) {
  std::fprintf(stderr, "meshstream_bench_service: references (disk, encoder, transport)\n");
  const std::string disk_dir = ms::bench::MakeTempFolder(args.work_dir, "meshstream-bench-disk");
  json references = {{"fsync_4k", FsyncFloor(disk_dir, args.quick ? 50 : 200)}};
  json ref_models = json::object();
  const auto echo_channel = grpc::CreateChannel(echo_address, grpc::InsecureChannelCredentials());
  const int ref_repeat = std::max(args.repeat, 3);
  for (const Model& m : models) ref_models[m.name] = ModelReference(m, ref_repeat, echo_channel, disk_dir);
  for (Backend* b : backends) {
    if (b->pg && !PgByteaReference(*b->pg, models, ref_repeat, ref_models)) break;
  }
  references["models"] = ref_models;
  std::error_code ec;
  fs::remove_all(disk_dir, ec);
  return references;
}

}  // namespace meshstream::bench::service
