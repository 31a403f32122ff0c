#include "services/pipeline/process_source.h"

#include <algorithm>
#include <exception>
#include <new>

#include <nlohmann/json.hpp>

#include "codec/core/utf8.h"
#include "importers/import.h"
#include "proto/sha256.h"
#include "services/pipeline/stream_layout.h"

namespace meshstream {

namespace {

constexpr double kImported = 0.1;
constexpr double kEncoded = 0.95;

// Thrown from the encoder's progress callback to stop it; the encoder's
// exception boundary turns it into a Status, which the flag below explains.
struct CancelledError {};

void ReplaceAll(std::string& s, const std::string& from, const std::string& to) {
  if (from.empty()) return;
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
}

// Messages name files as the upload does: "bunny.obj: ...", not the work folder.
class PathScrubber {
 public:
  explicit PathScrubber(const std::string& main_path)
      : main_path_(main_path), name_(FileBaseName(main_path)), dir_(FileFolder(main_path)) {}
  const std::string& name() const { return name_; }
  std::string Scrub(std::string message) const {
    ReplaceAll(message, main_path_, name_);
    ReplaceAll(message, dir_, "");
    return message;
  }
  Status Scrub(const Status& status) const {
    if (status.ok()) return status;
    std::string message = Scrub(status.message());
    // The importers name the file; make sure the message does.
    if (message.rfind(name_, 0) != 0) message = name_ + ": " + message;
    return Status(status.code(), message);
  }

 private:
  std::string main_path_, name_, dir_;
};

// Maps the encoder's (primitive, batch, vertices left) onto kImported..kEncoded.
class EncodeProgress {
 public:
  EncodeProgress(const Scene& scene, double base_ratio) : base_ratio_(base_ratio) {
    // The primitives EncodeProgressiveGlb encodes, in its order.
    for (const Mesh& mesh : scene.meshes)
      for (const Primitive& p : mesh.primitives)
        if (p.face_count() > 0) weights_.push_back(static_cast<double>(std::max<size_t>(p.vertex_count(), 1)));
    double total = 0;
    for (double w : weights_) {
      before_.push_back(total);
      total += w;
    }
    total_ = total > 0 ? total : 1.0;
  }
  size_t primitives() const { return weights_.size(); }
  double At(size_t primitive, size_t left) const {
    if (primitive >= weights_.size()) return kEncoded;
    const double v = weights_[primitive];
    const double span = std::max(1.0, v - v * base_ratio_);
    const double done = std::clamp((v - static_cast<double>(left)) / span, 0.0, 1.0);
    return kImported + (kEncoded - kImported) * (before_[primitive] + v * done) / total_;
  }

 private:
  double base_ratio_;
  std::vector<double> weights_, before_;
  double total_ = 1.0;
};

std::string WarningsJson(const std::vector<std::string>& warnings, const PathScrubber& scrub) {
  nlohmann::json a = nlohmann::json::array();
  for (const std::string& w : warnings) a.push_back(ToValidUtf8(scrub.Scrub(w)));
  return a.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

StatusOr<ProcessResult> ProcessUnguarded(const std::string& main_path, const EncodeSettings& settings,
                                         const ProgressCallback& progress, const ProcessOptions& options) {
  const PathScrubber scrub(main_path);
  double reported = -1.0;
  bool cancel_seen = false;
  auto cancelled = [&] {
    if (!cancel_seen && options.cancelled && options.cancelled()) cancel_seen = true;
    return cancel_seen;
  };
  auto report = [&](double value, const std::string& stage) {
    value = std::max(value, reported);
    reported = value;
    if (progress) progress(value, stage);
  };
  const Status kCancelled = Aborted(scrub.name() + ": processing cancelled");

  report(0.0, "importing");
  ImportOptions import_options;
  import_options.max_input_bytes = options.max_input_bytes;
  StatusOr<Scene> scene = ImportFile(main_path, import_options);
  if (!scene.ok()) return scrub.Scrub(scene.status());
  if (cancelled()) return kCancelled;
  report(kImported, "imported");

  ProgressiveGlbOptions glb_options = ToGlbOptions(settings);
  glb_options.runner = options.runner;
  const EncodeProgress mapping(scene.value(), settings.base_ratio);
  const size_t primitives = mapping.primitives();
  glb_options.progress = [&](size_t primitive, int batch, size_t left) {
    if (cancelled()) throw CancelledError{};
    report(mapping.At(primitive, left), "encoding primitive " + std::to_string(primitive + 1) + " of " +
                                            std::to_string(primitives) + ": refinement " + std::to_string(batch + 1) +
                                            ", " + std::to_string(left) + " vertices left");
  };
  report(kImported, "encoding");
  ProcessResult result;
  // The imported arrays are released as each primitive is quantized (the
  // encoder's peak then does not hold them); the warnings stay for below.
  StatusOr<std::vector<uint8_t>> glb = EncodeProgressiveGlbReleasing(&scene.value(), glb_options, &result.report);
  if (cancel_seen) return kCancelled;
  if (!glb.ok()) return scrub.Scrub(glb.status());  // Scrub names the file once
  result.glb = std::move(glb).value();

  MS_ASSIGN_OR_RETURN(StreamLayout layout, ComputeStreamLayout(result.glb.data(), result.glb.size()));
  ArtifactSummary& s = result.summary;
  FillFigures(result.report, &s);
  s.artifact_sha256 = Sha256Hex(result.glb.data(), result.glb.size());
  s.encoder = EncoderId();
  s.layout_json = StreamLayoutJson(layout);
  s.warnings_json = WarningsJson(scene->warnings, scrub);
  if (cancelled()) return kCancelled;
  report(kEncoded, "encoded");
  return result;
}

}  // namespace

void FillFigures(const ProgressiveGlbReport& report, ArtifactSummary* summary) {
  const PrimitiveStreamReport total = report.Total();
  summary->vertices = static_cast<int64_t>(total.vertices);
  summary->faces = static_cast<int64_t>(total.faces);
  summary->levels = total.level_vertices.empty() ? 0 : static_cast<int32_t>(total.level_vertices.size() - 1);
  summary->level_vertices.assign(total.level_vertices.begin(), total.level_vertices.end());
  summary->progressive_bytes = report.file_bytes;
  summary->reliable_bytes = total.base_bytes + total.reliable_bytes;
  summary->unreliable_bytes = total.unreliable_bytes;
}

StatusOr<ProcessResult> ProcessSource(const std::string& main_path, const EncodeSettings& settings,
                                      const ProgressCallback& progress, const ProcessOptions& options) {
  const std::string name = FileBaseName(main_path);
  try {
    return ProcessUnguarded(main_path, settings, progress, options);
  } catch (const CancelledError&) {
    return Aborted(name + ": processing cancelled");
  } catch (const std::bad_alloc&) {
    return ResourceExhausted(name + ": out of memory while processing");
  } catch (const std::exception& e) {
    return Internal(name + ": " + e.what());
  } catch (...) {
    return Internal(name + ": unknown exception while processing");
  }
}

}  // namespace meshstream
