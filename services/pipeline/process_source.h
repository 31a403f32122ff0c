// What the server does with one version's source: import it, encode it into
// a progressive .glb, and describe the result (ArtifactSummary), with the
// same figures `meshstream encode --json` prints for the same file and flags.
//
// Stages and progress (reported through `progress`, monotone):
//   0.0  "importing"        ImportFile on the materialized main file
//   0.1  "encoding ..."     EncodeProgressiveGlb; the encoder's callback
//                           (primitive, batch, vertices left) is mapped onto
//                           0.1 .. 0.95, each primitive weighted by its vertices
//   0.95 "encoded"          the layout and the summary are computed
// The caller stores 1.0 when the result is stored (docs/design/pipeline.md).
//
// Contract: the source is untrusted (the importers check it); a failure is
// the importer's or encoder's Status with its message naming the file by its
// name in the upload, not by the work folder's path. No exception escapes
// (one from the progress callback or a library becomes a Status).
// Cancellation: when `options.cancelled` returns true, processing stops at
// the next progress point (a batch of the encoder, a stage) with Aborted.
// Thread safety: calls are independent; `progress` and `cancelled` are
// called on the calling thread.
#ifndef MESHSTREAM_SERVICES_PIPELINE_PROCESS_SOURCE_H_
#define MESHSTREAM_SERVICES_PIPELINE_PROCESS_SOURCE_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "services/pipeline/encode_options.h"
#include "services/store/store.h"

namespace meshstream {

struct ProcessResult {
  ArtifactSummary summary;    // every field, artifact_sha256 included
  std::vector<uint8_t> glb;   // the progressive .glb
  ProgressiveGlbReport report;
};

using ProgressCallback = std::function<void(double progress, const std::string& stage)>;

struct ProcessOptions {
  uint64_t max_input_bytes = kDefaultMaxInputBytes;  // ImportOptions
  std::function<bool()> cancelled;                   // null: never
  // Workers that encode the scene's streams (primitives and spatial parts)
  // at once (ProgressiveGlbOptions::runner; the artifact does not depend on
  // their count); null: this thread.
  TaskRunner* runner = nullptr;
};

// `main_path`: the main file in a work folder, its resources beside it
// (materialize.h). `settings` must be resolved (ResolveSettings).
// `progress` may be null.
StatusOr<ProcessResult> ProcessSource(const std::string& main_path, const EncodeSettings& settings,
                                      const ProgressCallback& progress, const ProcessOptions& options = {});

// The summary's figures from an encode report, as cmd_encode computes them
// (reliable_bytes = base bytes + the streams' reliable bytes, ...).
void FillFigures(const ProgressiveGlbReport& report, ArtifactSummary* summary);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_PIPELINE_PROCESS_SOURCE_H_
