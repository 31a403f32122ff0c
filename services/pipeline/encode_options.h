// The encode options of the asset service: what a client may choose per
// version (proto EncodeOptions), their defaults and ranges, their canonical
// JSON (the store's options_json), and the artifact cache key.
//
// Defaults and ranges are those of `meshstream encode` (cli/cmd_encode.cc):
// the defaults are read from the same structs the CLI fills
// (ProgressiveGlbOptions and what it holds), never copied; the ranges are the
// CLI's, named here once. Every option the service does not expose (qc,
// levels, Draco compression level, the simplifier's rule and valence) stays
// at the CLI's default, so that a version's figures equal those of
// `meshstream encode --json` with the same flags.
//
// Contract: EncodeSettings from a client are untrusted: ResolveSettings and
// ParseSettingsJson check every field and answer InvalidArgument naming it
// ("options.qp: 40 is outside [1, 30]"). Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_PIPELINE_ENCODE_OPTIONS_H_
#define MESHSTREAM_SERVICES_PIPELINE_ENCODE_OPTIONS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "importers/progressive_glb.h"
#include "services/store/store.h"

namespace meshstream {

// 0 or empty: the CLI's default.
struct EncodeSettings {
  int qp = 0;
  int qn = 0;
  int qt = 0;
  std::string packing;        // "split" or "bundled"
  uint32_t packet_bytes = 0;
  double base_ratio = 0.0;

  bool operator==(const EncodeSettings& o) const {
    return qp == o.qp && qn == o.qn && qt == o.qt && packing == o.packing && packet_bytes == o.packet_bytes &&
           base_ratio == o.base_ratio;
  }
  bool operator!=(const EncodeSettings& o) const { return !(*this == o); }
};

// The ranges of `meshstream encode` (qp and qt: kMin/kMaxQuantizationBits;
// packet_bytes: kMin/kMaxPacketBytes). The CLI writes these two as literals.
constexpr int kMinNormalBits = 2;
constexpr int kMaxNormalBits = 15;
constexpr double kMinBaseRatio = 1e-6;
constexpr double kMaxBaseRatio = 1.0;

// Every field at the CLI's default.
EncodeSettings DefaultSettings();

// Fills 0/empty fields with their defaults and checks every field against
// its range: InvalidArgument "options.<field>: <value> is outside [lo, hi]"
// (packing: "options.packing: 'x' is not split or bundled").
StatusOr<EncodeSettings> ResolveSettings(EncodeSettings requested);

// One line of JSON with the fields in a fixed order
// ({"qp":11,"qn":8,"qt":10,"packing":"split","packet_bytes":1200,"base_ratio":0.02}).
// Meant for resolved settings; the same settings always give the same text.
std::string CanonicalJson(const EncodeSettings& settings);

// The inverse of CanonicalJson, on untrusted text: an object whose keys are
// among the six fields (missing keys mean the default, unknown keys and wrong
// types are InvalidArgument naming them), then ResolveSettings.
StatusOr<EncodeSettings> ParseSettingsJson(const std::string& json);

// The options EncodeProgressiveGlb takes (no progress callback), as
// cmd_encode fills them for the same flags. `settings` must be resolved.
ProgressiveGlbOptions ToGlbOptions(const EncodeSettings& settings);

// Names what makes the artifact's bytes: the progressive container and
// stream versions, the datagram version and the Draco library coding the
// base ("meshstream-progressive/1 datagram/1 draco/1.5.5 pipeline/1"). It
// changes when the bitstream format, the base coder or kPipelineRevision
// changes. Stored as ArtifactSummary::encoder.
std::string EncoderId();

// Bumped by hand when the encoder's output for the same input and options
// changes without a format change (a new simplifier rule, say), so that the
// artifact cache does not hand out artifacts of the previous encoder.
// 2: seam edges collapse on both sides (the seams tool of format version 2).
// 3: the .glb records the reliable cut (MESHSTREAM_progressive.delivery), which
//    sessions send on the stream.
// 4: the .glb records each level's residual error
//    (MESHSTREAM_progressive.residual_error), by which a scene's levels and
//    its sessions' order are made (codec/progressive/scene_levels.h).
// 5: format version 4, both profiles in the artifact (MESHSTREAM_progressive's
//    "reliable" beside its loss-tolerant "bufferView"), the harm estimated
//    (codec/loss/datagram_harm.h).
constexpr int kPipelineRevision = 5;

// The artifact cache key: SHA-256 (hex) over an unambiguous serialization
// (every field length-prefixed) of the tenant (a cache hit must not tell one
// tenant that another uploaded the same file), EncoderId(), the fixed encoder parameters
// the service does not expose, CanonicalJson(resolved settings), the main
// file's name and digest and each resource's name and digest (sorted by
// name, so the order of upload does not matter). Settings that do not
// resolve are keyed as given (they never reach an encode).
std::string ArtifactCacheKey(const std::string& tenant, const SourceFile& main,
                             const std::vector<SourceFile>& resources, const EncodeSettings& settings);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_PIPELINE_ENCODE_OPTIONS_H_
