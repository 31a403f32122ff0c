// The service benchmark's ingests and exports: one Ingest and its job
// watched to the end, one export timed, and per model the plain, resumable
// and cache-hit ingests with the exports of every fresh version, the
// backends taking turns.
#ifndef MESHSTREAM_BENCH_SERVICE_INGEST_H_
#define MESHSTREAM_BENCH_SERVICE_INGEST_H_

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/service/args.h"
#include "bench/service/backend.h"
#include "bench/service/models.h"
#include "meshstream/v1/asset_service.pb.h"

namespace meshstream::bench::service {

// The Ingest messages of `bytes` as m.name, with `options` and, when not
// empty, `upload_id`.
std::vector<v1::IngestRequest> UploadMessages(const Model& m, const std::vector<uint8_t>& bytes,
                                              const v1::EncodeOptions& options, const std::string& upload_id);

struct IngestRun {
  bool ok = false;
  std::string error;
  double upload_ms = 0;        // Ingest: first message written until IngestResponse
  double ready_watch_ms = 0;   // IngestResponse until WatchJob delivered SUCCEEDED
  double ready_server_ms = 0;  // the job's updated - created stamps (the store's clock, ms)
  v1::IngestResponse response;
  v1::Job last;
  nlohmann::json watch = nlohmann::json::array();  // every Job WatchJob sent: client time, state, progress, server time
};

// One Ingest, then WatchJob until the job ends; nothing else runs meanwhile.
IngestRun IngestAndWait(Backend& b, const std::vector<v1::IngestRequest>& messages);

struct ExportTiming {
  bool ok = false;
  std::string error;
  double ms = 0;
  uint64_t bytes = 0;
  std::string sha256;
};

// One export of `asset`@`version` in `format`, timed until the last chunk
// (the client library checks the bytes against the server's SHA-256 inside
// the clock).
ExportTiming TimeExport(Backend& b, const std::string& asset, int64_t version, v1::Format format);

// Warm-up: the first connection of each client, PostgreSQL's pool, the
// encoder's first run; untimed.
void WarmUp(const std::vector<Backend*>& backends, const Model& spot);

// Ingest, READY and export of one model into b.ingest[m] and b.exports[m]
// of every backend: plain, resumable, then cache-hit ingests, the backends
// taking turns (who goes first alternates).
void MeasureIngest(const Args& args, const Model& m, const std::vector<Backend*>& backends);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_INGEST_H_
