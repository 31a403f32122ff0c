// meshstream_loss_bench: the loss experiments of the paper (sections 5.2-5.3,
// Figures 6-9 and 11-15) with this codec; issue 4 "Experiments";
// docs/results/loss-results.md.
//
// Per model (qp 11, qn 8, qt 10), encoded once (progressive encoder, Draco
// cl 7 base) and written once per packing (split, bundled):
//   - the reference: DecodeStreamLossy with a zero loss model, every level
//     captured through on_level;
//   - for every (packing, pattern, loss, seed) of the model's matrix, one
//     lossy decode per recovery (kPredict, kLwop) with the SAME seed, so the
//     two see the same loss pattern and pair up; at the final level the
//     point-to-surface and vertex-to-vertex Hausdorff distances to the
//     reference (relative to its bbox diagonal), the mean surface distance,
//     the Laplacian distortion (Eq. 4-5, when the vertex counts agree) and
//     the vertex count of every level;
//   - for a subset (bunny and horse by default: split packing, random loss,
//     the first --level-seeds seeds; plus bundled and LwoP at 12 %) the same
//     metrics at every level against the reference's level;
//   - decoding time: medians of in-process DecodeStreamLossy calls alone (no
//     metric inside the timed part), per loss level, interleaved round by
//     round with the zero-loss decode, before any other work starts.
// Writes one JSON object (--out); bench/plot_loss.py turns it into plots and
// the generated part of docs/results/loss-results.md. Aggregation happens there.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/options.h"
#include "codec/metrics/hausdorff.h"
#include "codec/metrics/laplacian.h"
#include "codec/loss/lossy_decode.h"
#include "codec/mesh/mesh.h"
#include "codec/progressive/encoder.h"
#include "codec/loss/datagram_harm.h"
#include "codec/loss/protection.h"
#include "fec/reed_solomon.h"
#include "parallel/fork_join_pool.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"

namespace {

using json = nlohmann::json;
namespace ms = meshstream;
using ms::bench::Check;
using ms::bench::Clock;
using ms::bench::Die;
using ms::bench::Median;
using ms::bench::Ms;
using ms::bench::Stem;

const char kAbout[] =
    "The loss experiments of the paper with this codec (docs/results/loss-results.md); writes one\n"
    "JSON object (default docs/results/bench/loss.json). Progress goes to stderr.\n";

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/results/bench/loss.json";
  int seeds = 20;
  int small_seeds = 10;
  int level_seeds = 3;
  int repeat = 7;
  unsigned threads = 2;
  int64_t samples = 0;
  bool quick = false;
  bool protection_only = false;
  ms::ParityPlanOptions parity_plan;  // the blocks' limits (--parity-span, --parity-block)
  double base_ratio = ms::SimplifyOptions{}.base_ratio;
  double reliable_share = ms::kDefaultReliableShare;
  double harm_margin = -1;  // EstimateDatagramHarm's spread margin (< 0: the encoder's)
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  ms::bench::Options o("meshstream_loss_bench", kAbout);
  o.String("--out", "FILE", &a.out, "output JSON");
  ms::bench::AddModelOptions(o, &a.models_dir, &a.only);
  o.Int("--seeds", "N", &a.seeds, 1, 10000, "seeds per cell for bunny and horse (default 20)");
  o.Int("--small-seeds", "N", &a.small_seeds, 1, 10000, "seeds per cell for fandisk, rocker-arm, spot (default 10)");
  o.Int("--level-seeds", "N", &a.level_seeds, 0, 10000, "seeds of the per-level subset (default 3)");
  o.Int("--repeat", "N", &a.repeat, 1, 1000, "timed decodes per loss level, after one warm-up (default 7)");
  o.Unsigned("--threads", "N", &a.threads, 1, 64, "threads for the untimed decodes and metrics (default 2)");
  o.Int64("--samples", "N", &a.samples, 0, 100000000,
          "Hausdorff samples_per_side (default 0: every vertex, edge midpoint\n"
          "and face centroid, see codec/metrics/hausdorff.h)");
  o.Flag("--quick", &a.quick, "a tiny run for smoke testing (spot unless --model; 2 seeds)");
  o.Flag("--protection-only", &a.protection_only,
         "only the reliable cut and parity at 12 and 30 % loss, random and bursty (no timing):\n"
         "a quick look at loss protection (docs/design/loss-protection.md)");
  int span = static_cast<int>(a.parity_plan.max_span), block = static_cast<int>(a.parity_plan.block_datagrams);
  o.Int("--parity-span", "N", &span, 1, 255, "refinements a parity block spans at most (default 16)");
  o.Int("--parity-block", "N", &block, 1, 255, "datagrams in a parity block at most (default 100)");
  int depth = 1;
  o.Int("--parity-depth", "N", &depth, 1, 8,
        "interleave N blocks over the same refinements, member i to block i mod N\n"
        "(an experiment: the sessions send depth 1; docs/design/loss-protection.md)");
  o.Double("--base-ratio", "F", &a.base_ratio, 0, 1,
           "simplify down to F of the vertices (default: the encoder's, 0.02;\n"
           "0.14 is close to the paper's base, see docs/results/loss-results.md)", true);
  o.Double("--reliable-share", "F", &a.reliable_share, 0, 1,
           "the share of the datagram bytes the reliable cut may take (default 0.10)");
  o.Double("--harm-margin", "F", &a.harm_margin, 0, 100,
           "the harm estimate's spread margin (default: the encoder's, codec/loss/datagram_harm.h)", true);
  o.Parse(argc, argv);
  a.parity_plan.max_span = static_cast<uint32_t>(span);
  a.parity_plan.depth = static_cast<uint32_t>(depth);
  a.parity_plan.block_datagrams = static_cast<uint32_t>(block);
  return a;
}

// The machine, as docs/results/loss-results.md quotes it (keys differ from
// meshstream_bench's: this JSON has its own readers).
json MachineInfo() {
  json m = {{"cpu", ms::bench::CpuModel()},
            {"cores", std::thread::hardware_concurrency()},
            {"os", ms::bench::KernelName()},
            {"compiler", __VERSION__},
            {"build_type", MESHSTREAM_BUILD_TYPE},
            {"loadavg_at_start", ms::bench::LoadAverage()}};
  const std::string commit = ms::bench::GitShortCommit(MESHSTREAM_SOURCE_DIR);
  if (!commit.empty()) m["git_commit"] = commit;
  return m;
}

bool SameMesh(const ms::QuantizedMesh& a, const ms::QuantizedMesh& b) {
  return a.positions == b.positions && a.indices == b.indices && a.attributes == b.attributes;
}

// ------------------------------------------------------------ the matrix

const char* kPackingNames[2] = {"split", "bundled"};
const ms::Packing kPackings[2] = {ms::Packing::kSplit, ms::Packing::kBundled};
const char* kPatternNames[2] = {"random", "bursty"};
const double kBursts[2] = {0.0, 4.0};
const char* kRecoveryNames[2] = {"predict", "lwop"};
const ms::Recovery kRecoveries[2] = {ms::Recovery::kPredict, ms::Recovery::kLwop};

constexpr size_t kLevelStep = 3;  // per-level metrics at every third level

struct Plan {
  std::vector<double> losses;  // nonzero loss levels
  int seeds = 0;
  bool per_level = false;      // the per-level subset and the timing
  bool full = false;
};

struct Stream {
  ms::ProgressiveStream stream;
  ms::QuantizedMesh base;  // as Draco decodes it
  std::vector<ms::QuantizedMesh> ref_q;     // [k]: reference level k (0 = base after fix-ups)
  std::vector<ms::Primitive> ref;           // dequantized
  std::vector<double> ref_diag;
  uint64_t datagrams = 0;
  std::vector<uint32_t> cut;   // the reliable cut at --reliable-share (importance-ordered delivery)
  uint64_t cut_bytes = 0;      // its datagram bytes
  uint64_t total_bytes = 0;    // base, header, control blocks and datagrams
  ms::DatagramHarm harm;       // single-loss harm per datagram (split packing only)
  std::vector<double> refinement_harm;  // the encoder's estimate per refinement (the record's "harm")
  ms::DatagramHarm harm_estimate;       // the encoder's estimate per datagram (EstimateDatagramHarm)
  double harm_estimate_s = 0, harm_measure_s = 0;  // seconds each took
  std::vector<uint8_t> tiers;  // per refinement: its ProtectionTier (the record's "parity")
};

struct Model {
  std::string name, file;
  Plan plan;
  std::vector<uint32_t> level_vertices;  // from the header
  Stream streams[2];
};

const char* kDeliveryNames[3] = {"paper", "cut", "cut_parity"};

struct Job {
  size_t model = 0;
  int packing = 0, pattern = 0;
  int delivery = 0;  // 0: the paper's scheme (split bits and base reliable); 1: the reliable cut as well;
                     // 2: the cut and Reed-Solomon parity blocks (codec/loss/parity_plan.h)
  double loss = 0;
  uint64_t seed = 0;
  bool levels_predict = false;  // per-level metrics for prediction
  bool levels_lwop = false;     // per-level metrics for LwoP
};

struct Metrics {
  double hd_rel = 0, hv_rel = 0, mean_rel = 0;
  double lap_rel = NAN;  // NaN: not computed or undefined (vertex counts differ)
  bool identical = false;
};

struct RecResult {
  std::string error;
  uint64_t vertices = 0, faces = 0, unreliable = 0;
  ms::RecoveryStats stats;
  uint64_t levels_applied = 0;
  std::vector<uint64_t> level_vertices;  // per level 1..n
  Metrics final_m;
  std::vector<Metrics> level_m;          // per level 1..n when asked
};

struct JobResult {
  bool repaired_identical = false;  // the decode after a repair (every datagram) is the zero-loss one
  ms::TransmissionStats tx;
  ms::ReconstructorStats rc;
  RecResult rec[2];
  double seconds = 0;
};

ms::LossyDecodeOptions DecodeOptions(double loss, double burst, uint64_t seed, ms::Recovery r) {
  ms::LossyDecodeOptions o;
  o.loss.loss = loss;
  o.loss.burst = burst;
  o.loss.seed = seed;
  o.reconstructor.recovery = r;
  return o;
}

Metrics Measure(const ms::QuantizedMesh& ref_q, const ms::Primitive& ref, double diag, const ms::QuantizedMesh& q,
                bool laplacian, int64_t samples, std::string* error) {
  Metrics m;
  if (SameMesh(ref_q, q)) {
    m.identical = true;
    m.lap_rel = 0;
    return m;
  }
  const ms::Primitive p = ms::DequantizeMesh(q, -1);
  ms::SurfaceDistanceOptions so;
  so.samples_per_side = samples;
  auto d = ms::ComputeSurfaceDistance(ref, p, so);
  if (!d.ok()) {
    *error = "ComputeSurfaceDistance: " + d.status().ToString();
    m.hd_rel = m.hv_rel = m.mean_rel = NAN;
    return m;
  }
  m.hd_rel = d->hausdorff_rel;
  m.hv_rel = d->hausdorff_vertex_rel;
  m.mean_rel = diag > 0 ? d->mean_distance / diag : NAN;
  if (laplacian) {
    auto l = ms::LaplacianDistortion(ref, p);
    if (l.ok() && diag > 0) m.lap_rel = l.value() / diag;
  }
  return m;
}

JobResult RunJob(const Model& model, const Job& job, int64_t samples, const ms::ParityPlanOptions& plan) {
  JobResult out;
  const Stream& s = model.streams[job.packing];
  const size_t n = s.ref.size() - 1;
  for (int r = 0; r < 2; ++r) {
    RecResult& rr = out.rec[r];
    const bool levels = r == 0 ? job.levels_predict : job.levels_lwop;
    std::vector<ms::QuantizedMesh> got(n + 1);
    auto options = DecodeOptions(job.loss, kBursts[job.pattern], job.seed, kRecoveries[r]);
    if (job.delivery >= 1) options.reliable = s.cut;
    if (job.delivery == 2) {
      // Reed-Solomon parity over the unreliable refinements, sized for the
      // loss and burst the client would report (the model's own).
      options.parity.code = &ms::fec::DefaultErasureCode();
      options.parity.loss = job.loss;
      options.parity.burst = kBursts[job.pattern];
      options.parity.protect = s.tiers;
      options.parity.plan = plan;
    }
    options.on_level = [&](size_t level, const ms::StreamReader& reader) {
      ms::QuantizedMesh m = reader.Mesh();
      if (level >= rr.level_vertices.size()) rr.level_vertices.resize(level, 0);
      rr.level_vertices[level - 1] = m.vertex_count();
      if (levels && level <= n) got[level] = std::move(m);
    };
    ms::LossyDecodeReport report;
    auto reader = ms::DecodeStreamLossy(s.stream, 0, s.base, options, &report);
    if (r == 0) {
      out.tx = report.transmission;
      out.rc = report.reconstructor;
      // The repair: what the SDK decodes once the lost datagrams are back
      // (every datagram of every refinement, through the same path).
      auto repaired_options = options;
      repaired_options.on_level = nullptr;
      repaired_options.reliable.clear();
      for (uint32_t i = 0; i < s.stream.control.size(); ++i) repaired_options.reliable.push_back(i);
      auto repaired = ms::DecodeStreamLossy(s.stream, 0, s.base, repaired_options, nullptr);
      out.repaired_identical = repaired.ok() && SameMesh(repaired->Mesh(), s.ref_q[n]);
    }
    rr.stats = report.recovery;
    rr.levels_applied = report.levels_applied;
    if (!reader.ok()) {
      rr.error = "DecodeStreamLossy: " + reader.status().ToString();
      continue;
    }
    if (reader->applied() != n) {
      rr.error = "decoded " + std::to_string(reader->applied()) + " of " + std::to_string(n) + " levels";
      continue;
    }
    const ms::QuantizedMesh final_q = reader->Mesh();
    rr.vertices = final_q.vertex_count();
    rr.faces = final_q.face_count();
    rr.unreliable = reader->unreliable_vertices();
    rr.final_m = Measure(s.ref_q[n], s.ref[n], s.ref_diag[n], final_q, r == 0, samples, &rr.error);
    if (levels) {
      rr.level_m.resize(n);
      // Every third level, counted down from the last (the budget), marked
      // hd_rel NaN and skipped in the JSON otherwise.
      for (size_t k = 1; k <= n; ++k) {
        if ((n - k) % kLevelStep != 0) {
          rr.level_m[k - 1].hd_rel = NAN;
          continue;
        }
        rr.level_m[k - 1] = k == n ? rr.final_m
                                   : Measure(s.ref_q[k], s.ref[k], s.ref_diag[k], got[k], r == 0, samples, &rr.error);
      }
    }
  }
  return out;
}

json Num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json StatsJson(const ms::RecoveryStats& s) {
  return {{"exact", s.exact},
          {"predicted_both", s.predicted_both},
          {"predicted_structure", s.predicted_structure},
          {"predicted_geometry", s.predicted_geometry},
          {"structure_fallbacks", s.structure_fallbacks},
          {"abandoned", s.abandoned}};
}

json MetricsJson(const Metrics& m, bool laplacian) {
  json j = {{"hd_rel", Num(m.hd_rel)}, {"hv_rel", Num(m.hv_rel)}, {"mean_rel", Num(m.mean_rel)}};
  if (laplacian) j["lap_rel"] = Num(m.lap_rel);
  if (m.identical) j["identical"] = true;
  return j;
}

// What a repair (sdk/session.h, SessionOptions::repair) puts on the gRPC
// stream for this transmission's losses (docs/spec/streaming-protocol.md,
// "Repair"), in protobuf bytes: the request (per refinement with a loss an
// item of primitive, refinement and packed ordinals, at most 3 + 3 + 3 bytes
// of fields and lengths plus 2 bytes per ordinal; 8 for the message and the
// gRPC frame), then per lost datagram a ServerMessage.datagram (the payload,
// 3 + 3 bytes of tags and lengths, a 5-byte gRPC frame), then RepairEnd (16).
uint64_t RepairBytes(const ms::TransmissionStats& tx) {
  if (tx.datagrams_lost == 0) return 0;
  const uint64_t request = 8 + 9 * tx.refinements_with_loss + 2 * tx.datagrams_lost;
  return request + tx.lost_bytes + 11 * tx.datagrams_lost + 16;
}

json JobJson(const Job& job, const JobResult& r) {
  json j = {{"packing", kPackingNames[job.packing]},
            {"delivery", kDeliveryNames[job.delivery]},
            {"pattern", kPatternNames[job.pattern]},
            {"loss", job.loss},
            {"seed", job.seed},
            {"datagrams_sent", r.tx.datagrams_sent},
            {"datagrams_lost", r.tx.datagrams_lost},
            {"ends_lost", r.tx.ends_lost},
            {"reliable_datagrams", r.tx.reliable_datagrams},
            {"reliable_datagram_bytes", r.tx.reliable_bytes},
            {"lost_bytes", r.tx.lost_bytes},
            {"parity_datagrams", r.tx.parity_datagrams},
            {"parity_bytes", r.tx.parity_bytes},
            {"parity_lost", r.tx.parity_lost},
            {"parity_recovered", r.rc.recovered},
            {"redecoded", r.rc.redecoded},
            {"datagram_bytes", r.tx.datagram_bytes},
            {"repair_bytes", RepairBytes(r.tx)},
            {"repaired_identical", r.repaired_identical},
            {"finished_timeout", r.rc.finished_timeout},
            {"seconds", r.seconds}};
  for (int k = 0; k < 2; ++k) {
    const RecResult& rr = r.rec[k];
    json x = {{"vertices", rr.vertices},
              {"faces", rr.faces},
              {"unreliable_vertices", rr.unreliable},
              {"levels_applied", rr.levels_applied},
              {"stats", StatsJson(rr.stats)},
              {"level_vertices", rr.level_vertices}};
    x.update(MetricsJson(rr.final_m, k == 0));
    if (!rr.error.empty()) x["error"] = rr.error;
    if (!rr.level_m.empty()) {
      json lv = json::array();
      for (size_t i = 0; i < rr.level_m.size(); ++i) {
        if (std::isnan(rr.level_m[i].hd_rel)) continue;
        json e = MetricsJson(rr.level_m[i], k == 0);
        e["level"] = i + 1;
        lv.push_back(e);
      }
      x["levels"] = lv;
    }
    j[kRecoveryNames[k]] = x;
  }
  return j;
}

// ------------------------------------------------------------ preparation

Model Prepare(const std::string& dir, const std::string& file, const Plan& plan, double base_ratio,
              double reliable_share, double harm_margin) {
  Model m;
  m.file = file;
  m.name = Stem(file);
  m.plan = plan;
  const ms::Scene scene = Check(ms::ImportFile(dir + "/" + file), file);
  const auto prims = ms::bench::Primitives(scene);
  if (prims.empty()) Die(file + ": no triangles");
  if (prims.size() > 1)
    std::fprintf(stderr, "  warning: %s has %zu primitives; only the first is used\n", file.c_str(), prims.size());
  ms::ProgressiveEncodeOptions options;
  options.quantization.qp = 11;
  options.quantization.qn = 8;
  options.quantization.qt = 10;
  options.simplify.base_ratio = base_ratio;
  options.simplify.collapse_seams = true;  // the default stream (version 2, every tool)
  ms::DracoAttributeIds ids;
  const auto enc = ms::bench::EncodeWithDracoBase(*prims[0], options, &ids, file);
  for (int p = 0; p < 2; ++p) {
    Stream& s = m.streams[p];
    ms::StreamWriteOptions wo;
    wo.packing = kPackings[p];
    s.stream = Check(ms::WriteStream(enc, options.quantization, wo), file + ": WriteStream");
    for (const auto& d : s.stream.datagrams) s.datagrams += d.size();
    // The reliable cut, as EncodeProgressiveGlb records it.
    s.total_bytes = ms::StreamTotalBytes(enc.base_bytes.size(), s.stream);
    s.cut = ms::MakeDeliveryRecord(enc.mesh, s.stream, enc.base_bytes.size(), reliable_share).reliable;
    const std::vector<uint64_t> refinement_bytes = ms::RefinementDatagramBytes(s.stream);
    for (uint32_t i : s.cut) s.cut_bytes += refinement_bytes[i];
    auto reader = Check(ms::StreamReader::Create(s.stream.header.data(), s.stream.header.size(), 0), "header");
    s.base = Check(ms::DecodeDracoBase(enc.base_bytes.data(), enc.base_bytes.size(), ids, reader.header().grids),
                   file + ": DecodeDracoBase");
    m.level_vertices = reader.header().level_vertices();
    // The reference: the zero-loss decode, through the same path as the lossy ones.
    const size_t n = s.stream.control.size();
    s.ref_q.resize(n + 1);
    {
      auto base_reader = Check(ms::StreamReader::Create(s.stream.header.data(), s.stream.header.size(), 0), "header");
      if (!base_reader.SetBase(s.base).ok()) Die(file + ": SetBase");
      s.ref_q[0] = base_reader.Mesh();
    }
    auto o = DecodeOptions(0, 0, 1, ms::Recovery::kPredict);
    o.on_level = [&](size_t level, const ms::StreamReader& r) {
      if (level <= n) s.ref_q[level] = r.Mesh();
    };
    ms::LossyDecodeReport report;
    auto done = Check(ms::DecodeStreamLossy(s.stream, 0, s.base, o, &report), file + ": zero-loss decode");
    if (done.applied() != n) Die(file + ": the zero-loss decode stopped early");
    for (size_t k = 0; k <= n; ++k) {
      s.ref.push_back(ms::DequantizeMesh(s.ref_q[k], -1));
      s.ref_diag.push_back(ms::bench::Diagonal(s.ref.back()));
    }
    if (p == 0) {
      // The encoder's protection choice (codec/loss/protection.h), as
      // EncodeProgressiveGlb records it, and every datagram's own harm for
      // the JSON (what the choice is measured against).
      const auto h0 = Clock::now();
      ms::ForkJoinPool pool(2);
      // The encoder's estimate (EstimateDatagramHarm), beside the measure it
      // stands for (every datagram decoded lost to the end), timed both.
      ms::HarmOptions estimate;
      estimate.spread_margin = harm_margin;
      const ms::DatagramHarm quick = Check(ms::EstimateDatagramHarm(s.stream, s.base, &pool, estimate), file + ": harm");
      const double quick_s = Ms(h0, Clock::now()) / 1000;
      s.harm_estimate_s = quick_s;
      ms::HarmOptions every_estimate = estimate;
      every_estimate.every_datagram = true;
      s.harm_estimate = Check(ms::EstimateDatagramHarm(s.stream, s.base, &pool, every_estimate), file + ": harm estimate");
      const ms::DeliveryRecord record =
          ms::MakeDeliveryRecord(enc.mesh, s.stream, enc.base_bytes.size(), reliable_share, &quick);
      s.tiers = ms::ProtectionTiers(record.parity, record.harm, n);
      s.refinement_harm = record.harm;
      ms::HarmOptions every;
      every.every_datagram = true;
      const auto h1 = Clock::now();
      s.harm = Check(ms::MeasureDatagramHarm(s.stream, s.base, &pool, every), file + ": datagram harm");
      s.harm_measure_s = Ms(h1, Clock::now()) / 1000;
      std::fprintf(stderr, "  %s: harm estimated in %.2f s (measured, every datagram: %.1f s); %zu refinements protected\n",
                   file.c_str(), quick_s, s.harm_measure_s, record.parity.size());
    }
    if (s.ref_q[n].vertex_count() != m.level_vertices.back())
      std::fprintf(stderr, "  warning: %s %s: zero-loss decode has %zu vertices, the header says %u\n", file.c_str(),
                   kPackingNames[p], s.ref_q[n].vertex_count(), m.level_vertices.back());
  }
  if (!SameMesh(m.streams[0].ref_q.back(), m.streams[1].ref_q.back()))
    std::fprintf(stderr, "  warning: %s: the two packings' zero-loss decodes differ\n", file.c_str());
  return m;
}

// ------------------------------------------------------------ timing

// Medians of DecodeStreamLossy alone, split packing, random loss, per loss
// level and recovery; the warm-up round uses seed 1, kept round r seed r + 2; every round times every
// configuration once, so all see the same machine load.
json TimeDecodes(const Model& m, int repeat, const ms::ParityPlanOptions& plan) {
  const Stream& s = m.streams[0];
  std::vector<double> losses = {0.0};
  for (double l : m.plan.losses) losses.push_back(l);
  // Per loss level: predict, LwoP, predict with the reliable cut, and with
  // the cut and parity (sized for the loss, the run's own).
  constexpr int kColumns = 4;
  std::vector<std::vector<double>> t(losses.size() * kColumns);
  for (int round = -1; round < repeat; ++round) {  // round -1: warm-up, not kept
    for (size_t li = 0; li < losses.size(); ++li)
      for (int c = 0; c < kColumns; ++c) {
        if (losses[li] == 0 && c != 0) continue;
        auto o = DecodeOptions(losses[li], 0, static_cast<uint64_t>(round + 2), kRecoveries[c == 1 ? 1 : 0]);
        if (c >= 2) o.reliable = s.cut;
        if (c == 3) {
          o.parity.code = &ms::fec::DefaultErasureCode();
          o.parity.loss = losses[li];
          o.parity.protect = s.tiers;
          o.parity.plan = plan;
        }
        ms::QuantizedMesh base = s.base;  // the copy is not timed
        ms::LossyDecodeReport report;
        const auto start = Clock::now();
        auto reader = ms::DecodeStreamLossy(s.stream, 0, std::move(base), o, &report);
        const double ms_ = Ms(start, Clock::now());
        if (!reader.ok()) Die(m.name + ": timed decode failed: " + reader.status().ToString());
        if (round >= 0) t[li * kColumns + c].push_back(ms_);
      }
  }
  const double zero = Median(t[0]);
  json rows = json::array();
  const char* names[kColumns] = {"predict", "lwop", "predict_cut", "predict_parity"};
  for (size_t li = 0; li < losses.size(); ++li) {
    json row = {{"loss", losses[li]}};
    for (int c = 0; c < kColumns; ++c) {
      const auto& v = t[li * kColumns + (losses[li] == 0 ? 0 : c)];
      const double med = Median(v);
      row[names[c]] = {{"median_ms", med},
                       {"min_ms", *std::min_element(v.begin(), v.end())},
                       {"max_ms", *std::max_element(v.begin(), v.end())},
                       {"ratio", zero > 0 ? med / zero : 0.0}};
    }
    rows.push_back(row);
    auto at = [&](int c) { return Median(t[li * kColumns + (losses[li] == 0 ? 0 : c)]); };
    std::fprintf(stderr,
                 "  time %s loss %4.1f%%: predict %.2f ms (x%.3f), lwop %.2f ms, predict with the cut %.2f ms (x%.3f), "
                 "with the cut and parity %.2f ms (x%.3f)\n",
                 m.name.c_str(), 100 * losses[li], at(0), zero > 0 ? at(0) / zero : 0.0, at(1), at(2),
                 zero > 0 ? at(2) / zero : 0.0, at(3), zero > 0 ? at(3) / zero : 0.0);
  }
  return {{"packing", "split"}, {"pattern", "random"}, {"repeat", repeat}, {"zero_loss_median_ms", zero},
          {"rows", rows}};
}

// The models of --model (spot alone for --quick without it; all five
// otherwise), each with its plan: the full matrix for the bunny and the
// horse, the reduced one for the others, a tiny one for --quick.
std::vector<Model> PrepareModels(const Args& args) {
  const std::vector<double> kFullLosses = {0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.20, 0.30};
  const std::vector<double> kSmallLosses = {0.04, 0.08, 0.12, 0.20, 0.30};
  const std::vector<std::string> chosen = ms::bench::ChooseSharedModels(
      args.only.empty() && args.quick ? std::vector<std::string>{"spot"} : args.only);

  std::vector<Model> models;
  for (const auto& f : chosen) {
    Plan plan;
    plan.full = f == "stanford-bunny.obj" || f == "horse.ply";
    plan.per_level = plan.full || args.quick;
    plan.losses = plan.full ? kFullLosses : kSmallLosses;
    plan.seeds = plan.full ? args.seeds : args.small_seeds;
    if (args.quick) {
      plan.losses = {0.04, 0.12};
      plan.seeds = 2;
    }
    std::fprintf(stderr, "prepare %s\n", f.c_str());
    const auto s = Clock::now();
    models.push_back(Prepare(args.models_dir, f, plan, args.base_ratio, args.reliable_share, args.harm_margin));
    const Model& m = models.back();
    std::fprintf(stderr, "  %zu levels, %u vertices, datagrams split %llu bundled %llu (%.1f s)\n",
                 m.level_vertices.size() - 1, m.level_vertices.back(),
                 static_cast<unsigned long long>(m.streams[0].datagrams),
                 static_cast<unsigned long long>(m.streams[1].datagrams), Ms(s, Clock::now()) / 1000);
  }
  return models;
}

json SettingsJson(const Args& args) {
  return {{"qp", 11}, {"qn", 8}, {"qt", 10}, {"base", "Draco cl 7"}, {"base_ratio", args.base_ratio},
          {"packet_bytes", ms::StreamWriteOptions{}.packet_bytes},
          {"bursty_mean_burst", kBursts[1]},
          {"samples_per_side", args.samples},
          {"threads", args.threads},
          {"repeat", args.repeat},
          {"seeds_full", args.quick ? 2 : args.seeds},
          {"seeds_small", args.quick ? 2 : args.small_seeds},
          {"level_seeds", args.level_seeds},
          {"level_step", kLevelStep},
          {"reliable_share", args.reliable_share},
          {"parity_span", args.parity_plan.max_span},
          {"parity_block", args.parity_plan.block_datagrams},
          {"parity_depth", args.parity_plan.depth},
          {"cells", "full models: split+random at every loss level; split+bursty and bundled+random at 4, 12, 30 %; bundled+bursty at 12 %. Reduced models: the same cells at 4, 12, 30 % only"},
          {"quick", args.quick},
          {"timing", "median of --repeat in-process DecodeStreamLossy calls (simulator, reconstructor, "
                     "reader; base copy outside the timed part), one warm-up round, every loss level "
                     "and recovery timed once per round, the kept rounds with seeds 2..repeat+1; split packing, random "
                     "loss; ratio = median / zero-loss median of the same run"}};
}

// The jobs of one model's matrix. Compute budget (about 10 min on 2 cores):
// every loss level for split packing with random loss; the other cells at
// 4, 12 and 30 % (bursty with bundled packing at 12 % only).
void PlanModelJobs(const Args& args, size_t mi, const Plan& p, std::vector<Job>& jobs) {
  if (args.protection_only) {
    for (int pt = 0; pt < 2; ++pt)
      for (double loss : {0.12, 0.30})
        for (int sd = 1; sd <= p.seeds; ++sd)
          for (int delivery : {1, 2}) {
            Job j;
            j.model = mi;
            j.pattern = pt;
            j.loss = loss;
            j.seed = static_cast<uint64_t>(sd);
            j.delivery = delivery;
            jobs.push_back(j);
          }
    return;
  }
  for (int pk = 0; pk < 2; ++pk)
    for (int pt = 0; pt < 2; ++pt)
      for (double loss : p.losses) {
        const bool key = std::fabs(loss - 0.04) < 1e-9 || std::fabs(loss - 0.12) < 1e-9 ||
                         std::fabs(loss - 0.30) < 1e-9;
        const bool in = args.quick || (pk == 0 && pt == 0) || (key && !(pk == 1 && pt == 1)) ||
                        std::fabs(loss - 0.12) < 1e-9;
        if (!in) continue;
        for (int sd = 1; sd <= p.seeds; ++sd) {
          Job j;
          j.model = mi;
          j.packing = pk;
          j.pattern = pt;
          j.loss = loss;
          j.seed = static_cast<uint64_t>(sd);
          const bool subset = p.per_level && pt == 0 && sd <= args.level_seeds;
          const bool at12 = std::fabs(loss - 0.12) < 1e-9;
          j.levels_predict = subset && (pk == 0 || at12);
          j.levels_lwop = subset && pk == 0 && at12;
          jobs.push_back(j);
          if (pk != 0) continue;
          // Importance-ordered delivery on the same seeds: split packing,
          // every loss level of the split cells; per-level metrics for
          // prediction on the level subset at 12 % (the error's spread).
          Job c = j;
          c.delivery = 1;
          c.levels_predict = subset && at12;
          c.levels_lwop = false;
          jobs.push_back(c);
          // Parity on top of the cut (issue 27), at 4, 12 and 30 %, random
          // and bursty.
          if (key) {
            Job q = c;
            q.delivery = 2;
            q.levels_predict = false;
            jobs.push_back(q);
          }
        }
      }
}

// Every model's jobs, the expensive ones first (large models, per-level
// ones), so the tail is short.
std::vector<Job> PlanJobs(const Args& args, const std::vector<Model>& models) {
  std::vector<Job> jobs;
  for (size_t mi = 0; mi < models.size(); ++mi) PlanModelJobs(args, mi, models[mi].plan, jobs);
  std::stable_sort(jobs.begin(), jobs.end(), [&](const Job& a, const Job& b) {
    auto cost = [&](const Job& j) {
      return static_cast<double>(models[j.model].level_vertices.back()) * (j.levels_predict ? 3 : 1) *
             (j.levels_lwop ? 2 : 1);
    };
    return cost(a) > cost(b);
  });
  return jobs;
}

// The matrix on --threads worker threads, progress on stderr.
std::vector<JobResult> RunMatrix(const Args& args, const std::vector<Model>& models, const std::vector<Job>& jobs) {
  std::fprintf(stderr, "matrix: %zu jobs (each decodes with both recoveries) on %u threads\n", jobs.size(),
               args.threads);
  std::vector<JobResult> results(jobs.size());
  std::atomic<size_t> next{0}, finished{0};
  std::mutex log_mu;
  const auto m0 = Clock::now();
  auto worker = [&]() {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= jobs.size()) return;
      const auto s = Clock::now();
      results[i] = RunJob(models[jobs[i].model], jobs[i], args.samples, args.parity_plan);
      results[i].seconds = Ms(s, Clock::now()) / 1000;
      const size_t f = finished.fetch_add(1) + 1;
      std::lock_guard<std::mutex> lock(log_mu);
      for (int r = 0; r < 2; ++r)
        if (!results[i].rec[r].error.empty())
          std::fprintf(stderr, "  ERROR %s %s %s loss %.2f seed %llu %s: %s\n", models[jobs[i].model].name.c_str(),
                       kPackingNames[jobs[i].packing], kPatternNames[jobs[i].pattern], jobs[i].loss,
                       static_cast<unsigned long long>(jobs[i].seed), kRecoveryNames[r],
                       results[i].rec[r].error.c_str());
      if (f % 50 == 0 || f == jobs.size()) {
        const double el = Ms(m0, Clock::now()) / 1000;
        std::fprintf(stderr, "  %zu/%zu jobs, %.0f s elapsed, about %.0f s left\n", f, jobs.size(), el,
                     el / f * (jobs.size() - f));
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < args.threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  return results;
}

// One model's object of "models": its runs in matrix order, its timing.
// Adds the runs' decode errors to *errors.
json ModelJson(const Model& m, size_t mi, const std::vector<Job>& jobs, const std::vector<JobResult>& results,
               const json& timing, uint64_t* errors) {
  json runs = json::array();
  std::vector<size_t> order;
  for (size_t i = 0; i < jobs.size(); ++i)
    if (jobs[i].model == mi) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const Job &x = jobs[a], &y = jobs[b];
    return std::tie(x.delivery, x.packing, x.pattern, x.loss, x.seed) <
           std::tie(y.delivery, y.packing, y.pattern, y.loss, y.seed);
  });
  for (size_t i : order) {
    runs.push_back(JobJson(jobs[i], results[i]));
    for (int r = 0; r < 2; ++r) *errors += !results[i].rec[r].error.empty();
  }
  json mj = {{"name", m.name},
             {"file", m.file},
             {"matrix", m.plan.full ? "full" : "reduced"},
             {"losses", m.plan.losses},
             {"seeds", m.plan.seeds},
             {"level_vertices", m.level_vertices},
             {"vertices", m.level_vertices.back()},
             {"diagonal", m.streams[0].ref_diag.back()},
             {"datagrams", {{"split", m.streams[0].datagrams}, {"bundled", m.streams[1].datagrams}}},
             {"reliable_cut", {{"refinements", m.streams[0].cut},
                               {"datagram_bytes", m.streams[0].cut_bytes},
                               {"stream_bytes", m.streams[0].total_bytes},
                               {"share", m.streams[0].total_bytes > 0 ? static_cast<double>(m.streams[0].cut_bytes) /
                                                                            static_cast<double>(m.streams[0].total_bytes)
                                                                      : 0.0}}},
             {"runs", runs}};
  {
    // The protection choice and what it rests on (docs/design/loss-protection.md).
    const Stream& s = m.streams[0];
    json tiers = json::array(), datagram_harm = json::array();
    for (uint8_t t : s.tiers) tiers.push_back(t);
    json datagram_estimate = json::array();
    for (const auto& h : s.harm.harm) datagram_harm.push_back(h);
    for (const auto& h : s.harm_estimate.harm) datagram_estimate.push_back(h);
    mj["protection"] = {{"tiers", tiers},
                        {"refinement_harm", s.refinement_harm},
                        {"datagram_harm", datagram_harm},
                        {"datagram_harm_estimate", datagram_estimate},
                        {"harm_estimate_s", s.harm_estimate_s},
                        {"harm_measure_s", s.harm_measure_s},
                        {"datagram_bytes", ms::RefinementDatagramBytes(s.stream)}};
  }
  if (!timing.is_null()) mj["timing"] = timing;
  return mj;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_loss_bench");
  const Args args = ParseArgs(argc, argv);
  const auto t0 = Clock::now();
  const std::vector<Model> models = PrepareModels(args);
  json out;
  out["tool"] = "meshstream_loss_bench";
  out["machine"] = MachineInfo();
  out["settings"] = SettingsJson(args);

  // 1. Timing, alone (nothing else runs in the process meanwhile).
  std::vector<json> timing(models.size());
  for (size_t mi = 0; mi < models.size(); ++mi) {
    if (!models[mi].plan.per_level || args.protection_only) continue;
    std::fprintf(stderr, "timing %s\n", models[mi].name.c_str());
    timing[mi] = TimeDecodes(models[mi], args.quick ? 2 : args.repeat, args.parity_plan);
  }
  // 2. The matrix, on worker threads.
  const std::vector<Job> jobs = PlanJobs(args, models);
  const std::vector<JobResult> results = RunMatrix(args, models, jobs);
  // 3. The JSON, runs grouped by model in matrix order.
  out["models"] = json::array();
  uint64_t errors = 0;
  for (size_t mi = 0; mi < models.size(); ++mi) {
    out["models"].push_back(ModelJson(models[mi], mi, jobs, results, timing[mi], &errors));
  }
  out["errors"] = errors;
  out["runtime_s"] = Ms(t0, Clock::now()) / 1000;
  out["machine"]["loadavg_at_end"] = ms::bench::LoadAverage();
  std::ofstream f(args.out);
  if (!f) Die("cannot write " + args.out);
  f << out.dump(1) << "\n";
  std::fprintf(stderr, "wrote %s (%.0f s, %llu errors)\n", args.out.c_str(), Ms(t0, Clock::now()) / 1000,
               static_cast<unsigned long long>(errors));
  return 0;
}
