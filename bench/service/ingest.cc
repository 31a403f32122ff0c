#include "bench/service/ingest.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service_stats.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

int64_t TimestampMs(const google::protobuf::Timestamp& t) { return t.seconds() * 1000 + t.nanos() / 1000000; }

json RunJson(const IngestRun& r, int variant, uint64_t bytes) {
  return {{"variant", variant},
          {"bytes", bytes},
          {"upload_ms", r.upload_ms},
          {"upload_MBps", MBps(bytes, r.upload_ms)},
          {"ready_watch_ms", r.ready_watch_ms},
          {"ready_server_ms", r.ready_server_ms},
          {"version", r.response.version()},
          {"job_message", r.last.message()},
          {"attempts", r.last.attempts()},
          {"watch", r.watch}};
}

// What one backend measured of one model, over its ingests.
struct Slot {
  json plain = json::array(), resumable = json::array(), cache = json::array();
  std::vector<double> progressive, glb_first, glb_cached;
  uint64_t progressive_bytes = 0, glb_bytes = 0;
  std::vector<std::string> artifacts;
};

// One ingest of `m` (variant k; `cache`: one the artifact cache answers;
// `resumable`: with an upload_id) into `b`, then for a fresh version its
// exports: the stored artifact, then .glb twice.
void IngestOnce(Backend& b, const Model& m, int k, bool cache, bool resumable, Slot& slot) {
  const int variant = cache ? 0 : k;
  const auto bytes = VariantBytes(m, variant);
  const std::string upload_id = resumable ? m.name + "-resume-" + std::to_string(k) : "";
  const std::string what = m.file + (cache ? " cache hit" : resumable ? " resumable" : " plain") + " #" +
                           std::to_string(k);
  IngestRun r = IngestAndWait(b, UploadMessages(m, bytes, VariantOptions(m, variant), upload_id));
  if (!r.ok) return Fail(b, "ingest " + what, r.error);
  const bool reused = r.last.message().find("reused") != std::string::npos;
  if (cache != reused) {
    return Fail(b, "ingest " + what,
                std::string(cache ? "the artifact cache did not answer" : "the artifact cache answered a fresh "
                                                                          "variant") +
                    " (job message: " + r.last.message() + ")");
  }
  (cache ? slot.cache : resumable ? slot.resumable : slot.plain).push_back(RunJson(r, variant, bytes.size()));
  if (cache) return;
  const int64_t version = r.response.version();
  ExportTiming p = TimeExport(b, m.name, version, v1::FORMAT_PROGRESSIVE_GLB);
  if (!p.ok) return Fail(b, "export " + what, p.error);
  if (std::find(slot.artifacts.begin(), slot.artifacts.end(), p.sha256) != slot.artifacts.end()) {
    return Fail(b, "export " + what, "the artifact is one of an earlier variant: its .glb export would be cached");
  }
  slot.artifacts.push_back(p.sha256);
  slot.progressive.push_back(p.ms);
  slot.progressive_bytes = p.bytes;
  ExportTiming g1 = TimeExport(b, m.name, version, v1::FORMAT_GLB);
  ExportTiming g2 = g1.ok ? TimeExport(b, m.name, version, v1::FORMAT_GLB) : ExportTiming{};
  if (!g1.ok || !g2.ok) return Fail(b, "export glb " + what, g1.ok ? g2.error : g1.error);
  if (g1.sha256 != g2.sha256) return Fail(b, "export glb " + what, "the cached .glb differs from the first");
  slot.glb_first.push_back(g1.ms);
  slot.glb_cached.push_back(g2.ms);
  slot.glb_bytes = g1.bytes;
}

// A slot's medians into b.ingest[m] and b.exports[m].
void Summarize(Backend& b, const Model& m, const Slot& slot) {
  auto median_of = [](const json& runs, const char* key) {
    std::vector<double> v;
    for (const json& r : runs) v.push_back(r[key].get<double>());
    return Median(v);
  };
  json fresh_runs = slot.plain;
  for (const json& r : slot.resumable) fresh_runs.push_back(r);
  const json summary = {
      {"upload_ms", median_of(slot.plain, "upload_ms")},
      {"upload_MBps", MBps(m.bytes.size(), median_of(slot.plain, "upload_ms"))},
      {"ready_watch_ms", median_of(slot.plain, "ready_watch_ms")},
      {"ready_server_ms", median_of(slot.plain, "ready_server_ms")},
      {"resumable_upload_ms", median_of(slot.resumable, "upload_ms")},
      {"resumable_upload_MBps", MBps(m.bytes.size(), median_of(slot.resumable, "upload_ms"))},
      {"resumable_ready_watch_ms", median_of(slot.resumable, "ready_watch_ms")},
      {"cache_upload_ms", median_of(slot.cache, "upload_ms")},
      {"cache_ready_watch_ms", median_of(slot.cache, "ready_watch_ms")},
      {"cache_ready_server_ms", median_of(slot.cache, "ready_server_ms")},
      {"fresh_ready_watch_ms", median_of(fresh_runs, "ready_watch_ms")},
      {"fresh_ready_server_ms", median_of(fresh_runs, "ready_server_ms")},
  };
  b.ingest[m.name] = {{"file", m.file},
                      {"bytes", m.bytes.size()},
                      {"plain", slot.plain},
                      {"resumable", slot.resumable},
                      {"cache_hit", slot.cache},
                      {"summary", summary}};
  auto exp = [](const std::vector<double>& runs, uint64_t bytes) {
    json j = ms::bench::RunsSummary(runs);
    j["bytes"] = bytes;
    j["MBps"] = MBps(bytes, Median(runs));
    return j;
  };
  b.exports[m.name] = {{"progressive_glb", exp(slot.progressive, slot.progressive_bytes)},
                       {"glb_first", exp(slot.glb_first, slot.glb_bytes)},
                       {"glb_cached", exp(slot.glb_cached, slot.glb_bytes)},
                       {"distinct_artifacts", slot.artifacts.size()}};
}

}  // namespace

std::vector<v1::IngestRequest> UploadMessages(const Model& m, const std::vector<uint8_t>& bytes,
                                              const v1::EncodeOptions& options, const std::string& upload_id) {
  ms::bench::Upload upload;
  upload.asset = m.name;
  upload.file = m.file;
  upload.bytes = &bytes;
  upload.options = options;
  upload.upload_id = upload_id;
  return ms::bench::IngestMessages(upload);
}

IngestRun IngestAndWait(Backend& b, const std::vector<v1::IngestRequest>& messages) {
  IngestRun run;
  const auto t0 = Clock::now();
  ms::StatusOr<v1::IngestResponse> response = b.client->Ingest(messages);
  const auto t1 = Clock::now();
  if (!response.ok()) {
    run.error = "Ingest: " + response.status().ToString();
    return run;
  }
  run.response = response.value();
  run.upload_ms = Ms(t0, t1);
  Clock::time_point final_seen = t1;
  ms::StatusOr<v1::Job> last = b.client->Watch(run.response.job_id(), [&](const v1::Job& job) {
    const auto now = Clock::now();
    run.watch.push_back({{"t_ms", Ms(t1, now)},
                         {"state", v1::JobState_Name(job.state())},
                         {"progress", job.progress()},
                         {"server_ms", TimestampMs(job.updated()) - TimestampMs(job.created())}});
    final_seen = now;
  });
  if (!last.ok()) {
    run.error = "WatchJob: " + last.status().ToString();
    return run;
  }
  run.last = last.value();
  if (run.last.state() != v1::JOB_STATE_SUCCEEDED) {
    run.error = "job " + run.response.job_id() + " ended " + v1::JobState_Name(run.last.state()) + ": " +
                run.last.message();
    return run;
  }
  run.ready_watch_ms = Ms(t1, final_seen);
  run.ready_server_ms = static_cast<double>(TimestampMs(run.last.updated()) - TimestampMs(run.last.created()));
  run.ok = true;
  return run;
}

ExportTiming TimeExport(Backend& b, const std::string& asset, int64_t version, v1::Format format) {
  ExportTiming t;
  const auto t0 = Clock::now();
  ms::StatusOr<AssetApi::Exported> exported = b.client->Export(asset, version, format);
  t.ms = Ms(t0, Clock::now());
  if (!exported.ok()) {
    t.error = "Export " + v1::Format_Name(format) + ": " + exported.status().ToString();
    return t;
  }
  const AssetApi::Exported& e = exported.value();
  t.ok = true;
  t.bytes = e.bytes.size();
  t.sha256 = e.sha256;
  return t;
}

void WarmUp(const std::vector<Backend*>& backends, const Model& spot) {
  std::fprintf(stderr, "meshstream_bench_service: warming up\n");
  for (Backend* b : backends) {
    Model w = spot;
    w.name = "warmup";
    IngestRun r = IngestAndWait(*b, UploadMessages(w, w.bytes, v1::EncodeOptions(), ""));
    if (!r.ok) Die(b->name + ": the warm-up ingest failed: " + r.error);
    TimeExport(*b, "warmup", r.response.version(), v1::FORMAT_GLB);
  }
}

void MeasureIngest(const Args& args, const Model& m, const std::vector<Backend*>& backends) {
  std::fprintf(stderr, "meshstream_bench_service: ingest %s (%zu bytes)\n", m.file.c_str(), m.bytes.size());
  std::map<std::string, Slot> slots;
  const int fresh = args.repeat + args.resumable_repeat;
  for (int k = 0; k < fresh + args.cache_repeat; ++k) {
    const bool cache = k >= fresh;
    const bool resumable = !cache && k >= args.repeat;
    for (size_t i = 0; i < backends.size(); ++i) {
      Backend& b = *backends[(i + static_cast<size_t>(k)) % backends.size()];
      IngestOnce(b, m, k, cache, resumable, slots[b.name]);
    }
  }
  for (Backend* b : backends) Summarize(*b, m, slots[b->name]);
}

}  // namespace meshstream::bench::service
