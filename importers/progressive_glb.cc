#include "importers/progressive_glb.h"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>
#include <optional>

#include <nlohmann/json.hpp>

#include "codec/core/task_runner.h"
#include "codec/loss/lossy_decode.h"
#include "codec/loss/protection.h"
#include "codec/bitstream/reader.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/draco_base_coder.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/gltf_limits.h"
#include "importers/exception_boundary.h"

namespace meshstream {

namespace {

using json = nlohmann::json;

// The MESHSTREAM_progressive object of a primitive (docs/spec/progressive-format.md,
// section 1): "bufferView" (an unsigned integer), "version" 1 to 4, an
// optional "reliable" (version 4: an unsigned integer, the bufferView of the
// reliable profile's stream beside the loss-tolerant one), an optional
// "delivery" (checked against the stream by ParseDeliveryRecord), an optional
// "residual_error" (ParseResidualErrors), and nothing else but glTF's
// "extras" and "extensions".
Status CheckProgressiveExtension(const json& ext) {
  const std::string name = kProgressiveExtension;
  if (!ext.is_object()) return InvalidInput(name + " is not an object");
  if (!ext.contains("bufferView") || !ext["bufferView"].is_number_unsigned()) {
    return InvalidInput(name + ".bufferView is missing or not an unsigned integer");
  }
  if (!ext.contains("version")) return InvalidInput(name + ".version is missing");
  const json& version = ext["version"];
  if (!version.is_number_unsigned() || !IsStreamVersion(version.get<uint64_t>())) {
    return Unsupported(name + ".version " + version.dump() + " is not " + kStreamVersionsText);
  }
  const bool four = version.get<uint64_t>() >= 4;
  for (const auto& item : ext.items()) {
    const std::string& key = item.key();
    if (key != "bufferView" && key != "version" && key != "delivery" && key != "residual_error" && key != "extras" &&
        key != "extensions" && !(four && key == "reliable")) {
      return InvalidInput(name + "." + key + " is not defined by version " + version.dump());
    }
  }
  if (ext.contains("reliable") && !ext["reliable"].is_number_unsigned()) {
    return InvalidInput(name + ".reliable is not an unsigned integer");
  }
  return Status::Ok();
}

// A JSON array of refinement indices, each < refinements.
StatusOr<std::vector<uint32_t>> RefinementList(const json& value, const std::string& name, size_t refinements) {
  if (!value.is_array()) return InvalidInput(name + " is not an array");
  if (value.size() > refinements) {
    return InvalidInput(name + " names " + std::to_string(value.size()) + " refinements, the stream has " +
                        std::to_string(refinements));
  }
  std::vector<uint32_t> out;
  out.reserve(value.size());
  for (size_t k = 0; k < value.size(); ++k) {
    if (!value[k].is_number_unsigned() || value[k].get<uint64_t>() >= refinements) {
      return InvalidInput(name + "[" + std::to_string(k) + "] = " + value[k].dump() +
                          " is not a refinement of the stream (0.." + std::to_string(refinements) + ")");
    }
    out.push_back(static_cast<uint32_t>(value[k].get<uint64_t>()));
  }
  return out;
}

}  // namespace

StatusOr<DeliveryRecord> ParseDeliveryRecord(const std::string& delivery_json, size_t refinements) {
  const std::string name = std::string(kProgressiveExtension) + ".delivery";
  const json d = json::parse(delivery_json, nullptr, false);
  if (d.is_discarded() || !d.is_object()) return InvalidInput(name + " is not an object");
  for (const auto& item : d.items()) {
    if (item.key() != "share" && item.key() != "ranking" && item.key() != "reliable" && item.key() != "parity" &&
        item.key() != "harm") {
      return InvalidInput(name + "." + item.key() + " is not defined");
    }
  }
  DeliveryRecord r;
  if (!d.contains("share") || !d["share"].is_number() || !(d["share"].get<double>() >= 0) ||
      !(d["share"].get<double>() <= 1)) {
    return InvalidInput(name + ".share is missing or not a number in [0, 1]");
  }
  r.share = d["share"].get<double>();
  if (!d.contains("ranking") || !d.contains("reliable")) return InvalidInput(name + " needs ranking and reliable");
  MS_ASSIGN_OR_RETURN(r.ranking, RefinementList(d["ranking"], name + ".ranking", refinements));
  MS_ASSIGN_OR_RETURN(r.reliable, RefinementList(d["reliable"], name + ".reliable", refinements));
  std::vector<bool> seen(refinements, false);
  for (uint32_t i : r.ranking) {
    if (seen[i]) return InvalidInput(name + ".ranking names refinement " + std::to_string(i) + " twice");
    seen[i] = true;
  }
  for (size_t k = 0; k < r.reliable.size(); ++k) {
    if (k > 0 && r.reliable[k] <= r.reliable[k - 1]) return InvalidInput(name + ".reliable is not ascending");
    if (!seen[r.reliable[k]]) {
      return InvalidInput(name + ".reliable names refinement " + std::to_string(r.reliable[k]) +
                          ", which the ranking does not");
    }
  }
  if (d.contains("parity")) {
    MS_ASSIGN_OR_RETURN(r.parity, RefinementList(d["parity"], name + ".parity", refinements));
    for (size_t k = 0; k < r.parity.size(); ++k) {
      if (k > 0 && r.parity[k] <= r.parity[k - 1]) return InvalidInput(name + ".parity is not ascending");
      if (std::binary_search(r.reliable.begin(), r.reliable.end(), r.parity[k])) {
        return InvalidInput(name + ".parity names refinement " + std::to_string(r.parity[k]) +
                            ", which travels on the reliable cut");
      }
    }
  }
  if (d.contains("harm")) {
    const json& h = d["harm"];
    if (!h.is_array() || h.size() != refinements) {
      return InvalidInput(name + ".harm is not an array of " + std::to_string(refinements) + " numbers");
    }
    for (size_t k = 0; k < h.size(); ++k) {
      if (!h[k].is_number() || !std::isfinite(h[k].get<double>()) || h[k].get<double>() < 0) {
        return InvalidInput(name + ".harm[" + std::to_string(k) + "] = " + h[k].dump() +
                            " is not a finite non-negative number");
      }
      r.harm.push_back(h[k].get<double>());
    }
  }
  return r;
}

StatusOr<std::vector<double>> ParseResidualErrors(const std::string& residual_json, size_t refinements) {
  const std::string name = std::string(kProgressiveExtension) + ".residual_error";
  const json e = json::parse(residual_json, nullptr, false);
  if (e.is_discarded() || !e.is_array()) return InvalidInput(name + " is not an array");
  if (e.size() != refinements + 1) {
    return InvalidInput(name + " has " + std::to_string(e.size()) + " entries, the stream's " +
                        std::to_string(refinements) + " refinements need " + std::to_string(refinements + 1));
  }
  std::vector<double> out;
  out.reserve(e.size());
  for (size_t k = 0; k < e.size(); ++k) {
    const std::string at = name + "[" + std::to_string(k) + "] = " + e[k].dump();
    if (!e[k].is_number()) return InvalidInput(at + " is not a number");
    const double v = e[k].get<double>();
    if (!std::isfinite(v) || v < 0) return InvalidInput(at + " is not a finite non-negative number");
    if (k > 0 && v > out.back()) return InvalidInput(at + " is larger than the entry before it");
    out.push_back(v);
  }
  if (out.back() != 0) return InvalidInput(name + " does not end with 0 (the finest level)");
  return out;
}

std::string ResidualErrorsJson(const std::vector<double>& errors) {
  return json(std::vector<float>(errors.begin(), errors.end())).dump();
}

std::string DeliveryRecordJson(const DeliveryRecord& record) {
  json d;
  d["share"] = record.share;
  d["ranking"] = record.ranking;
  d["reliable"] = record.reliable;
  if (!record.parity.empty()) d["parity"] = record.parity;
  if (!record.harm.empty()) d["harm"] = std::vector<float>(record.harm.begin(), record.harm.end());
  return d.dump();
}

uint64_t StreamTotalBytes(uint64_t base_bytes, const ProgressiveStream& stream) {
  return base_bytes + stream.reliable_bytes() + stream.unreliable_bytes();
}

std::vector<uint64_t> RefinementDatagramBytes(const ProgressiveStream& stream) {
  std::vector<uint64_t> bytes(stream.datagrams.size(), 0);
  for (size_t i = 0; i < stream.datagrams.size(); ++i) {
    for (const auto& d : stream.datagrams[i]) bytes[i] += d.size();
  }
  return bytes;
}

DeliveryRecord MakeDeliveryRecord(const ProgressiveMesh& mesh, const ProgressiveStream& stream, uint64_t base_bytes,
                                  double share, const DatagramHarm* harm) {
  const std::vector<uint64_t> refinement_bytes = RefinementDatagramBytes(stream);
  DeliveryRecord d;
  d.share = share;
  d.ranking = RankRefinements(RefinementImportance(mesh), refinement_bytes);
  d.reliable = CutForShare(d.ranking, refinement_bytes, StreamTotalBytes(base_bytes, stream), share);
  if (harm != nullptr && harm->harm.size() == stream.control.size()) {
    for (size_t i = 0; i < harm->harm.size(); ++i) d.harm.push_back(harm->RefinementMax(i));
    d.parity = ChooseParity(d.harm, d.reliable, stream.control.size());
  }
  return d;
}

SceneLevels SceneLevelsOf(const std::vector<std::vector<uint32_t>>& level_vertices,
                          const std::vector<std::vector<double>>& residual_errors) {
  std::vector<uint32_t> refinements;
  for (const std::vector<uint32_t>& v : level_vertices) refinements.push_back(v.empty() ? 0 : static_cast<uint32_t>(v.size() - 1));
  return ScheduleSceneLevels(refinements, residual_errors);
}

std::vector<uint32_t> SceneLevelVertices(const SceneLevels& levels,
                                         const std::vector<std::vector<uint32_t>>& level_vertices) {
  std::vector<uint32_t> total(level_vertices.empty() ? 0 : levels.levels + 1, 0);
  for (size_t p = 0; p < level_vertices.size(); ++p) {
    if (level_vertices[p].empty()) continue;
    for (uint32_t level = 0; level < total.size(); ++level) {
      total[level] += level_vertices[p][std::min<size_t>(levels.At(p, level), level_vertices[p].size() - 1)];
    }
  }
  return total;
}

PrimitiveStreamReport ProgressiveGlbReport::Total() const {
  PrimitiveStreamReport t;
  for (const PrimitiveStreamReport& p : primitives) {
    t.vertices += p.vertices;
    t.faces += p.faces;
    t.base_bytes += p.base_bytes;
    t.reliable_bytes += p.reliable_bytes;
    t.unreliable_bytes += p.unreliable_bytes;
    t.datagrams += p.datagrams;
    t.removed_faces += p.removed_faces;
    t.tools |= p.tools;
    t.reliable_cut_bytes += p.reliable_cut_bytes;
    t.hierarchy_ms += p.hierarchy_ms;
    t.stream_ms += p.stream_ms;
    t.harm_ms += p.harm_ms;
    t.delivery_ms += p.delivery_ms;
  }
  std::vector<std::vector<uint32_t>> vertices;
  std::vector<std::vector<double>> errors;
  for (const PrimitiveStreamReport& p : primitives) {
    vertices.push_back(p.level_vertices);
    errors.push_back(p.residual_error);
  }
  const SceneLevels levels = SceneLevelsOf(vertices, errors);
  t.level_vertices = SceneLevelVertices(levels, vertices);
  auto by_scene_level = [&](std::vector<uint64_t> PrimitiveStreamReport::*field) {
    std::vector<uint64_t> out;
    for (size_t p = 0; p < primitives.size(); ++p) {
      const std::vector<uint64_t>& b = primitives[p].*field;
      if (b.empty()) continue;
      out.resize(t.level_vertices.size(), 0);
      for (uint32_t level = 0; level < out.size(); ++level) {
        out[level] += b[std::min<size_t>(levels.At(p, level), b.size() - 1)];
      }
    }
    return out;
  };
  t.level_bytes = by_scene_level(&PrimitiveStreamReport::level_bytes);
  t.reliable_level_bytes = by_scene_level(&PrimitiveStreamReport::reliable_level_bytes);
  for (const PrimitiveStreamReport& p : primitives) t.reliable_profile_bytes += p.reliable_profile_bytes;
  return t;
}

namespace {

// Per level of `stream`, its bytes up to it, the base's `base_bytes` included.
std::vector<uint64_t> LevelBytes(uint64_t base_bytes, const ProgressiveStream& stream) {
  std::vector<uint64_t> out = {base_bytes + stream.header.size()};
  for (size_t i = 0; i < stream.control.size(); ++i) {
    uint64_t bytes = stream.control[i].size();
    for (const auto& d : stream.datagrams[i]) bytes += d.size();
    out.push_back(out.back() + bytes);
  }
  return out;
}

// Drops a refined primitive's vertex and index arrays (what the exporter
// reads of a precoded primitive, its material, stays). Move-assigned from
// empty vectors: `= {}` would keep the capacity.
void ReleaseArrays(Primitive& p) {
  p.positions = decltype(p.positions)();
  p.normals = decltype(p.normals)();
  for (std::vector<Vec2f>& t : p.texcoords) t = std::vector<Vec2f>();
  p.colors = decltype(p.colors)();
  p.indices = decltype(p.indices)();
}

// One stream to encode: a refined primitive, or one spatial part of it.
struct StreamJob {
  size_t mesh = 0, primitive = 0;
  size_t input = 0;  // the primitive's index among the scene's refined ones (progress)
  uint32_t stream_id = 0;
  std::string where;
  QuantizedMesh quantized;  // given up to the encoder
  PrecodedPrimitive pre;
  PrimitiveStreamReport report;
  Status status;
};

// Encodes one stream into job->pre and job->report; `harm_runner` shares its
// harm measure (null: this thread); `observer` sees the simplifier's batches.
Status EncodeStream(StreamJob* job, const ProgressiveGlbOptions& options, double scale, TaskRunner* harm_runner,
                    const std::function<bool(int, size_t)>& observer) {
  const std::string& where = job->where;
  PrecodedPrimitive& pre = job->pre;
  ProgressiveEncodeOptions encode = options.encode;
  // Seam edges collapse only where the stream can carry it (version 2, the seams tool).
  encode.simplify.collapse_seams = options.stream.version >= 2 && (options.stream.tools & kToolSeams) != 0;
  if (observer) encode.simplify.observer = observer;
  const int level = options.draco_compression_level;
  using Clock = std::chrono::steady_clock;
  auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
  Clock::time_point step = Clock::now();
  // The base coder's last call is the one the encoder kept: its Draco ids
  // and decoded floats describe the base in the glTF. (The encoder works in
  // the quantized mesh's arrays: EncodeProgressive without its copy.)
  auto base_coder = [&pre, level](const QuantizedMesh& base, int method) {
    return EncodeDracoBase(base, method, level, &pre.ids, &pre.decoded);
  };
  // A file of the reliable profile alone may simplify by the matching
  // rule; should its replay in split order ever fail, the strict rule's
  // hierarchy (whose splits are independent, so any order is theirs)
  // takes its place. Both profiles share the strict rule's.
  const bool reliable = options.profiles == ProfileSet::kReliable;
  const bool both = options.profiles == ProfileSet::kBoth;
  std::optional<QuantizedMesh> strict_input;
  encode.simplify.rule = BatchRule::kStrict;
  if (reliable) {
    encode.simplify.rule = options.reliable_rule;
    if (options.reliable_rule != BatchRule::kStrict) strict_input = job->quantized;
  }
  auto encoded = EncodeProgressiveQuantized(std::move(job->quantized), encode, base_coder);
  job->quantized = QuantizedMesh();
  if (!encoded.ok() && strict_input && encoded.status().code() == StatusCode::kInternal) {
    encode.simplify.rule = BatchRule::kStrict;
    encoded = EncodeProgressiveQuantized(std::move(*strict_input), encode, base_coder);
  }
  strict_input.reset();
  if (!encoded.ok()) return encoded.status().WithContext(where);
  const double hierarchy_ms = ms_since(step);
  step = Clock::now();
  StreamWriteOptions stream_options = options.stream;
  stream_options.stream_id = job->stream_id;
  stream_options.profile = reliable ? Profile::kReliable : Profile::kLossTolerant;
  auto stream = WriteStream(encoded.value(), encode.quantization, stream_options);
  if (!stream.ok()) return stream.status().WithContext(where);
  auto header = StreamHeader::Parse(stream->header.data(), stream->header.size());
  if (!header.ok()) return header.status().WithContext(where);
  std::optional<ProgressiveStream> reliable_stream;
  if (both) {
    stream_options.profile = Profile::kReliable;
    auto second = WriteStream(encoded.value(), encode.quantization, stream_options);
    if (!second.ok()) return second.status().WithContext(where + ": the reliable profile");
    reliable_stream = std::move(second).value();
    pre.reliable_bytes = reliable_stream->Serialize();
  }
  const double stream_ms = ms_since(step);
  step = Clock::now();

  pre.draco_bytes = encoded->base_bytes;
  pre.extension_name = kProgressiveExtension;
  pre.extension_version = stream->version;
  pre.extension_bytes = stream->Serialize();
  // The reliable cut (codec/loss/reliable_cut.h): the ranking, and its
  // prefix for the encode-time share of this stream's bytes.
  // With the harm of each refinement's loss, which ones parity protects
  // (codec/loss/protection.h), measured on the base as a client decodes it.
  std::optional<DatagramHarm> harm;
  if (options.measure_harm && options.reliable_share > 0 && !stream->control.empty() && !reliable) {
    auto base = DecodeDracoBase(pre.draco_bytes.data(), pre.draco_bytes.size(), pre.ids, header->grids);
    if (!base.ok()) return base.status().WithContext(where + ": the base for the harm measure");
    auto measured = EstimateDatagramHarm(stream.value(), base.value(), harm_runner);
    if (!measured.ok()) return measured.status().WithContext(where + ": harm");
    harm = std::move(measured).value();
  }
  const double harm_ms = ms_since(step);
  step = Clock::now();
  const DeliveryRecord delivery = MakeDeliveryRecord(encoded->mesh, stream.value(), encoded->base_bytes.size(),
                                                     options.reliable_share, harm ? &*harm : nullptr);
  const double delivery_ms = ms_since(step);
  // The error each level leaves, in scene units: what orders the
  // refinements of a scene's primitives (codec/progressive/scene_levels.h).
  std::vector<double> residual = encoded->residual_error;
  const double unit = encoded->mesh.base.position_grid.step() * scale;
  for (double& e : residual) e = static_cast<float>(e * unit);
  // The reliable profile has no datagrams: nothing to deliver otherwise.
  pre.extension_fields = reliable ? "{\"residual_error\":" + ResidualErrorsJson(residual) + "}"
                                  : "{\"delivery\":" + DeliveryRecordJson(delivery) +
                                        ",\"residual_error\":" + ResidualErrorsJson(residual) + "}";

  PrimitiveStreamReport& r = job->report;
  r.vertices = encoded->input_vertices;
  r.faces = encoded->input_faces;
  r.level_vertices = encoded->mesh.level_vertices();
  r.level_bytes = LevelBytes(pre.draco_bytes.size(), stream.value());
  if (reliable_stream) {
    r.reliable_profile_bytes = reliable_stream->reliable_bytes();
    r.reliable_level_bytes = LevelBytes(pre.draco_bytes.size(), *reliable_stream);
  }
  r.base_bytes = pre.draco_bytes.size();
  r.reliable_bytes = stream->reliable_bytes();
  r.unreliable_bytes = stream->unreliable_bytes();
  r.datagrams = stream->datagram_count();
  r.removed_faces = encoded->removed_faces;
  r.tools = header->tools;
  const std::vector<uint64_t> refinement_bytes = RefinementDatagramBytes(stream.value());
  for (uint32_t i : delivery.reliable) r.reliable_cut_bytes += refinement_bytes[i];
  r.reliable_cut = delivery.reliable;
  r.parity = delivery.parity;
  r.residual_error = std::move(residual);
  r.hierarchy_ms = hierarchy_ms;
  r.stream_ms = stream_ms;
  r.harm_ms = harm_ms;
  r.delivery_ms = delivery_ms;
  return Status::Ok();
}

// The encoder's progress, from any worker: one call at a time, the vertices
// left summed over a primitive's parts; a call that throws cancels every
// stream (the simplifiers stop at their next batch) and is kept to rethrow.
class ProgressRelay {
 public:
  ProgressRelay(const ProgressiveGlbOptions& options, const std::vector<StreamJob>& jobs)
      : progress_(options.progress), left_(jobs.size(), 0), input_of_(jobs.size()) {
    for (size_t j = 0; j < jobs.size(); ++j) input_of_[j] = jobs[j].input;
  }
  std::function<bool(int, size_t)> ObserverFor(size_t job) {
    if (!progress_) return nullptr;
    return [this, job](int batch, size_t left) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (error_) return false;
      left_[job] = left;
      size_t total = 0;
      for (size_t j = 0; j < left_.size(); ++j) {
        if (input_of_[j] == input_of_[job]) total += left_[j];
      }
      try {
        progress_(input_of_[job], batch, total);
      } catch (...) {
        error_ = std::current_exception();
        return false;
      }
      return true;
    };
  }
  void RethrowIfAny() {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  const std::function<void(size_t, int, size_t)>& progress_;
  std::mutex mutex_;
  std::vector<size_t> left_;
  std::vector<size_t> input_of_;
  std::exception_ptr error_;
};

// `releasing`: the scene itself, whose refined primitives' arrays are
// dropped once quantized (EncodeProgressiveGlbReleasing), or null.
StatusOr<std::vector<uint8_t>> EncodeProgressiveGlbUnguarded(const Scene& scene, Scene* releasing,
                                                    const ProgressiveGlbOptions& options,
                                                    ProgressiveGlbReport* report) {
  MS_RETURN_IF_ERROR(ValidateScene(scene));
  const std::vector<double> scales = MeshScales(scene);
  // First every stream to encode, in file order: each refined primitive,
  // quantized, and cut into parts when it is large.
  std::vector<StreamJob> jobs;
  size_t input = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    for (size_t k = 0; k < mesh.primitives.size(); ++k) {
      const Primitive& prim = mesh.primitives[k];
      if (prim.face_count() == 0) continue;
      const std::string where = "meshes[" + std::to_string(m) + "].primitives[" + std::to_string(k) + "]";
      auto quantized = QuantizePrimitive(prim, options.encode.quantization);
      if (!quantized.ok()) return quantized.status().WithContext(where);
      if (releasing != nullptr) ReleaseArrays(releasing->meshes[m].primitives[k]);
      // QuantizePrimitive keeps only the referenced vertices.
      const size_t parts = PartCount(quantized->vertex_count(), options.part_vertices);
      std::vector<QuantizedMesh> pieces;
      if (parts > 1) {
        pieces = SplitIntoParts(quantized.value(), parts);
      } else {
        pieces.push_back(std::move(quantized).value());
      }
      quantized = QuantizedMesh();
      for (size_t part = 0; part < pieces.size(); ++part) {
        StreamJob job;
        job.mesh = m;
        job.primitive = k;
        job.input = input;
        job.stream_id = static_cast<uint32_t>(jobs.size());
        job.where = pieces.size() > 1 ? where + " (part " + std::to_string(part + 1) + " of " +
                                            std::to_string(pieces.size()) + ")"
                                      : where;
        job.quantized = std::move(pieces[part]);
        jobs.push_back(std::move(job));
      }
      ++input;
    }
  }
  // Then the streams, several at once when there are workers for them.
  ProgressRelay relay(options, jobs);
  RunEachTask(options.runner, jobs.size(), [&](size_t j, TaskRunner* harm_runner) {
    StreamJob& job = jobs[j];
    job.status = CatchExceptions(job.where, [&]() -> StatusOr<bool> {
      MS_RETURN_IF_ERROR(EncodeStream(&job, options, scales[job.mesh], harm_runner, relay.ObserverFor(j)));
      return true;
    }).status();
    return job.status.ok();
  });
  relay.RethrowIfAny();
  for (const StreamJob& job : jobs) MS_RETURN_IF_ERROR(job.status);

  ExportOptions export_options;
  export_options.precoded.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) export_options.precoded[m].resize(scene.meshes[m].primitives.size());
  ProgressiveGlbReport local;
  for (StreamJob& job : jobs) {
    export_options.precoded[job.mesh][job.primitive].push_back(&job.pre);
    local.primitives.push_back(std::move(job.report));
  }
  MS_ASSIGN_OR_RETURN(std::vector<uint8_t> glb, ExportGlb(scene, export_options));
  local.file_bytes = glb.size();
  if (report) *report = std::move(local);
  return glb;
}

}  // namespace

StatusOr<std::vector<uint8_t>> EncodeProgressiveGlb(const Scene& scene, const ProgressiveGlbOptions& options,
                                                    ProgressiveGlbReport* report) {
  return CatchExceptions(std::string("progressive encode"),
                         [&] { return EncodeProgressiveGlbUnguarded(scene, nullptr, options, report); });
}

StatusOr<std::vector<uint8_t>> EncodeProgressiveGlbReleasing(Scene* scene, const ProgressiveGlbOptions& options,
                                                             ProgressiveGlbReport* report) {
  return CatchExceptions(std::string("progressive encode"),
                         [&] { return EncodeProgressiveGlbUnguarded(*scene, scene, options, report); });
}

namespace {

StatusOr<Scene> DecodeChecked(const std::vector<uint8_t>& bytes, const ProgressiveDecodeOptions& options,
                              ProgressiveDecodeReport* report) {
  // The glTF import checks everything and decodes every base with Draco.
  json doc;
  MS_ASSIGN_OR_RETURN(Scene scene, ImportGltfBytes(bytes, "", "progressive stream", {}, &doc));
  if (!LooksLikeGlb(bytes.data(), bytes.size())) return InvalidInput("a progressive file must be a .glb");
  MS_ASSIGN_OR_RETURN(GlbView glb, ParseGlb(bytes.data(), bytes.size()));
  // Drop the importer's note about our own extension.
  scene.warnings.erase(std::remove_if(scene.warnings.begin(), scene.warnings.end(),
                                      [](const std::string& w) { return w.find(kProgressiveExtension) != std::string::npos; }),
                       scene.warnings.end());

  // First every stream's framing and header: the scene's levels need every
  // primitive's refinement count and errors before any is decoded.
  struct Found {
    size_t m = 0, k = 0;
    const json* prim = nullptr;
    std::string where;
    ProgressiveStream stream;
    StreamHeader header;
    std::vector<double> residual;  // empty: the file has none
  };
  std::vector<Found> found;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    // Carried primitives sit at their file position; refined ones fill the
    // rest, so the file's j-th primitive is Order()[j].
    const std::vector<Mesh::Ref> order = scene.meshes[m].Order();
    for (size_t j = 0; j < order.size(); ++j) {
      if (order[j].carried) continue;
      const size_t k = order[j].index;
      const json& prim = doc.at("meshes").at(m).at("primitives").at(j);
      const std::string where = "meshes[" + std::to_string(m) + "].primitives[" + std::to_string(j) + "]";
      if (!prim.contains("extensions") || !prim["extensions"].is_object() ||
          !prim["extensions"].contains(kProgressiveExtension)) {
        continue;
      }
      const json& ext = prim["extensions"][kProgressiveExtension];
      MS_RETURN_IF_ERROR(CheckProgressiveExtension(ext).WithContext(where));
      // Which of the primitive's streams: the reliable profile's ("reliable",
      // or "bufferView" when its header says so) or the other.
      const bool has_second = ext.contains("reliable");
      const bool nothing_lost = options.loss.loss == 0 && options.loss.reorder == 0 && options.loss.duplicate == 0;
      const bool second = has_second && (options.profile == DecodeProfile::kReliable ||
                                         (options.profile == DecodeProfile::kAuto && nothing_lost));
      const char* member = second ? "reliable" : "bufferView";
      const uint64_t view = ext[member].get<uint64_t>();
      const json& views = doc.at("bufferViews");
      if (!views.is_array() || view >= views.size()) {
        return InvalidInput(where + ": " + kProgressiveExtension + "." + member + " does not exist");
      }
      const uint64_t offset = views[view].value("byteOffset", uint64_t{0});
      const uint64_t length = views[view].value("byteLength", uint64_t{0});
      if (glb.bin == nullptr || offset > glb.bin_size || length > glb.bin_size - offset) {
        return InvalidInput(where + ": the progressive stream lies outside the GLB's binary chunk");
      }
      auto parsed = ProgressiveStream::Parse(glb.bin + offset, length);
      if (!parsed.ok()) return parsed.status().WithContext(where);
      ProgressiveStream stream = std::move(parsed).value();
      auto header = stream.ParseHeader();
      if (!header.ok()) return header.status().WithContext(where);
      if (stream.version != ext["version"].get<uint64_t>() || header->version != stream.version) {
        return InvalidInput(where + ": " + kProgressiveExtension + ".version " + ext["version"].dump() +
                            ", the stream blob's version " + std::to_string(stream.version) +
                            " and its header's " + std::to_string(header->version) + " differ");
      }
      if (second != header->reliable() && has_second) {
        return InvalidInput(where + ": " + kProgressiveExtension + "." + member + " names a stream of the " +
                            ProfileName(header->profile) + " profile");
      }
      if (options.profile == DecodeProfile::kReliable && !header->reliable()) {
        return InvalidArgument(where + ": the file has no stream of the reliable profile");
      }
      if (options.profile == DecodeProfile::kLossTolerant && header->reliable()) {
        return InvalidArgument(where + ": the file has no stream of the loss-tolerant profile");
      }
      if (header->reliable() && !nothing_lost) {
        return InvalidArgument(where + ": the file holds the reliable profile alone, which has no datagrams to lose "
                                       "(encode with --profile loss-tolerant or both to simulate a lossy network)");
      }
      Found f;
      f.m = m;
      f.k = k;
      f.prim = &prim;
      f.where = where;
      if (ext.contains("residual_error")) {
        auto residual = ParseResidualErrors(ext["residual_error"].dump(), header->split_counts.size());
        if (!residual.ok()) return residual.status().WithContext(where);
        f.residual = std::move(residual).value();
      }
      f.stream = std::move(stream);
      f.header = std::move(header).value();
      found.push_back(std::move(f));
    }
  }
  std::vector<std::vector<uint32_t>> level_vertices;
  std::vector<std::vector<double>> residuals;
  for (const Found& f : found) {
    level_vertices.push_back(f.header.level_vertices());  // lossless counts
    residuals.push_back(f.residual);
  }
  const SceneLevels scene_levels = SceneLevelsOf(level_vertices, residuals);

  // Each stream decodes on its own (any core, any order): several at once
  // when there are workers for them, else one after the other, each with
  // the workers for its refinements. The mesh is the same bit for bit.
  struct Decoded {
    Status status;
    LossyDecodeReport lossy;
    uint64_t predicted_vertices = 0;
  };
  std::vector<Decoded> decoded(found.size());
  auto decode_one = [&](size_t i, TaskRunner* runner) -> Status {
    Found& f = found[i];
    const size_t m = f.m, k = f.k;
    const json& prim = *f.prim;
    const json& ext = prim["extensions"][kProgressiveExtension];
    const json& views = doc.at("bufferViews");
    const std::string& where = f.where;
    ProgressiveStream& stream = f.stream;
    const StreamHeader& header = f.header;
    Primitive& target = scene.meshes[m].primitives[k];
    auto base = QuantizeOnto(target, header.grids);
    if (!base.ok()) return base.status().WithContext(where);
    const size_t levels = header.split_counts.size();
    const size_t apply = options.lod < 0 ? levels : scene_levels.At(i, static_cast<uint32_t>(options.lod));
    // What travels reliably: the recorded cut, none, or the cut for another share.
    std::vector<uint32_t> reliable;
    std::vector<uint8_t> protect;  // the record's parity tiers (protection.h)
    if (ext.contains("delivery") && (options.reliable_share != 0 || options.parity != nullptr)) {
      auto delivery = ParseDeliveryRecord(ext["delivery"].dump(), levels);
      if (!delivery.ok()) return delivery.status().WithContext(where);
      protect = ProtectionTiers(delivery->parity, delivery->harm, levels);
      if (options.reliable_share < 0) {
        reliable = delivery->reliable;
      } else if (options.reliable_share > 0) {
        // The base's Draco bytes (the importer has checked its bufferView).
        const json& draco = prim["extensions"]["KHR_draco_mesh_compression"];
        const uint64_t base_bytes = views.at(draco.at("bufferView").get<uint64_t>()).value("byteLength", uint64_t{0});
        reliable = CutForShare(delivery->ranking, RefinementDatagramBytes(stream), StreamTotalBytes(base_bytes, stream),
                               options.reliable_share);
      }
    }
    // Loss-free or not, every stream crosses the simulated network and the
    // reconstructor: one code path.
    const uint32_t stream_id = static_cast<uint32_t>(i);
    LossyDecodeOptions lossy;
    lossy.loss = options.loss;
    lossy.loss.seed = options.loss.seed + stream_id;
    lossy.reconstructor.recovery = options.recovery;
    lossy.reconstructor.lod = static_cast<int>(apply);
    lossy.reconstructor.runner = runner;
    lossy.reliable = std::move(reliable);
    if (options.parity != nullptr && !protect.empty()) {
      lossy.parity.code = options.parity;
      lossy.parity.protect = std::move(protect);
      lossy.parity.loss = options.loss.loss;
      lossy.parity.burst = options.loss.burst;
    }
    LossyDecodeReport& lr = decoded[i].lossy;
    auto reader = DecodeStreamLossy(stream, stream_id, std::move(base).value(), lossy, &lr);
    if (!reader.ok()) return reader.status().WithContext(where);
    if (reader->applied() != apply) {
      return Internal(where + ": decoded " + std::to_string(reader->applied()) + " of " + std::to_string(apply) +
                      " refinements");
    }
    decoded[i].predicted_vertices = reader->inexact_positions();
    const RefinementState& state = reader->state();
    if (state.any_absent) {
      target = DequantizeMesh(reader->Mesh(), target.material);
    } else {
      // Every vertex exists: the state's arrays are the mesh (what Mesh()
      // would copy), dequantized where they are.
      const std::vector<Face>& faces = state.connectivity.faces();
      static_assert(sizeof(Face) == 3 * sizeof(uint32_t), "a Face is three packed indices");
      target = DequantizeArrays(header.grids.position_grid, header.grids.layout, state.positions,
                                state.attributes, faces.empty() ? nullptr : faces.front().data(),
                                3 * faces.size(), target.material);
    }
    return Status::Ok();
  };
  RunEachTask(options.runner, found.size(), [&](size_t i, TaskRunner* runner) {
    try {
      decoded[i].status = decode_one(i, runner);
    } catch (const std::exception& e) {
      decoded[i].status = InvalidInput(found[i].where + ": " + e.what());
    }
    return decoded[i].status.ok();
  });
  ProgressiveDecodeReport local;
  for (size_t i = 0; i < found.size(); ++i) {
    MS_RETURN_IF_ERROR(decoded[i].status);
    const LossyDecodeReport& lr = decoded[i].lossy;
    local.datagrams += lr.transmission.datagrams_sent;
    local.lost_datagrams += lr.transmission.datagrams_lost;
    local.late_datagrams += lr.reconstructor.late;
    local.reliable_datagrams += lr.transmission.reliable_datagrams;
    local.reliable_datagram_bytes += lr.transmission.reliable_bytes;
    local.recovery.Add(lr.recovery);
    (found[i].header.reliable() ? local.reliable_profile_streams : local.loss_tolerant_streams) += 1;
    local.predicted_vertices += decoded[i].predicted_vertices;
    local.parity_datagrams += lr.transmission.parity_datagrams;
    local.parity_bytes += lr.transmission.parity_bytes;
    local.recovered_datagrams += lr.reconstructor.recovered;
    local.refinements_decoded_again += lr.reconstructor.redecoded;
    local.tools |= found[i].header.tools;
  }
  local.levels = scene_levels.levels;
  local.level_vertices = SceneLevelVertices(scene_levels, level_vertices);
  // The scene's level decoded (with several primitives, a level may apply
  // more refinements of one of them than its number).
  local.levels_applied = options.lod < 0 ? scene_levels.levels
                                         : std::min<uint64_t>(scene_levels.levels, static_cast<uint64_t>(options.lod));
  if (report) *report = std::move(local);
  return scene;
}

}  // namespace

StatusOr<Scene> DecodeProgressiveGlb(const std::vector<uint8_t>& bytes, const ProgressiveDecodeOptions& options,
                                     ProgressiveDecodeReport* report) {
  try {
    return DecodeChecked(bytes, options, report);
  } catch (const std::exception& e) {
    // nlohmann's at() on a document the importer already validated; kept as a backstop.
    return InvalidInput(std::string("progressive stream: ") + e.what());
  }
}

}  // namespace meshstream
