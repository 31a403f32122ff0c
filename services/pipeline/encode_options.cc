#include "services/pipeline/encode_options.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <draco/core/draco_version.h>
#include <nlohmann/json.hpp>

#include "codec/bitstream/format.h"
#include "codec/core/utf8.h"
#include "codec/mesh/quantization.h"
#include "proto/api_names.h"
#include "proto/sha256.h"

namespace meshstream {

namespace {

using json = nlohmann::json;

constexpr size_t kMaxOptionsJsonBytes = 4096;

// The shortest text that reads back as v, for the messages ("1e-06", "nan").
std::string FormatNumber(double v) {
  char buf[64];
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::isnan(v) || std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

Status OutsideRange(const char* field, const std::string& value, const std::string& lo, const std::string& hi) {
  return InvalidArgument(std::string("options.") + field + ": " + value + " is outside [" + lo + ", " + hi + "]");
}

Status CheckIntRange(const char* field, int64_t value, int64_t lo, int64_t hi) {
  if (value < lo || value > hi) return OutsideRange(field, std::to_string(value), std::to_string(lo), std::to_string(hi));
  return Status::Ok();
}

// The parameters the service keeps at the CLI's defaults, for the cache key.
std::string FixedParameters() {
  const ProgressiveGlbOptions d;
  return "qc=" + std::to_string(d.encode.quantization.qc) + " levels=" + std::to_string(d.encode.simplify.max_levels) +
         " valence=" + std::to_string(d.encode.simplify.max_valence) +
         " rule=" + std::to_string(static_cast<int>(d.encode.simplify.rule)) +
         " cl=" + std::to_string(d.draco_compression_level);
}

void AppendField(std::string& out, const std::string& field) {
  out += std::to_string(field.size());
  out += ':';
  out += field;
  out += ';';
}

// An integer member of `j` (already known to be present), as int64, or
// InvalidArgument naming it.
StatusOr<int64_t> IntegerMember(const json& v, const char* field) {
  if (v.is_number_unsigned()) {
    const uint64_t u = v.get<uint64_t>();
    return u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max()
                                                                         : static_cast<int64_t>(u);
  }
  if (v.is_number_integer()) return v.get<int64_t>();
  return InvalidArgument(std::string("options.") + field + ": not an integer");
}

}  // namespace

EncodeSettings DefaultSettings() {
  const ProgressiveGlbOptions d;
  EncodeSettings s;
  s.qp = d.encode.quantization.qp;
  s.qn = d.encode.quantization.qn;
  s.qt = d.encode.quantization.qt;
  s.packing = d.stream.packing == Packing::kSplit ? "split" : "bundled";
  s.packet_bytes = d.stream.packet_bytes;
  s.base_ratio = d.encode.simplify.base_ratio;
  return s;
}

StatusOr<EncodeSettings> ResolveSettings(EncodeSettings requested) {
  const EncodeSettings d = DefaultSettings();
  EncodeSettings& s = requested;
  if (s.qp == 0) s.qp = d.qp;
  if (s.qn == 0) s.qn = d.qn;
  if (s.qt == 0) s.qt = d.qt;
  if (s.packing.empty()) s.packing = d.packing;
  if (s.packet_bytes == 0) s.packet_bytes = d.packet_bytes;
  if (s.base_ratio == 0.0) s.base_ratio = d.base_ratio;
  MS_RETURN_IF_ERROR(CheckIntRange("qp", s.qp, kMinQuantizationBits, kMaxQuantizationBits));
  MS_RETURN_IF_ERROR(CheckIntRange("qn", s.qn, kMinNormalBits, kMaxNormalBits));
  MS_RETURN_IF_ERROR(CheckIntRange("qt", s.qt, kMinQuantizationBits, kMaxQuantizationBits));
  if (s.packing != "split" && s.packing != "bundled") {
    return InvalidArgument("options.packing: '" + PrintableName(s.packing) + "' is not split or bundled");
  }
  MS_RETURN_IF_ERROR(CheckIntRange("packet_bytes", s.packet_bytes, kMinPacketBytes, kMaxPacketBytes));
  // Written so that NaN fails too.
  if (!(s.base_ratio >= kMinBaseRatio && s.base_ratio <= kMaxBaseRatio)) {
    return OutsideRange("base_ratio", FormatNumber(s.base_ratio), FormatNumber(kMinBaseRatio), FormatNumber(kMaxBaseRatio));
  }
  return s;
}

std::string CanonicalJson(const EncodeSettings& s) {
  // nlohmann's object is ordered by key; the fixed order is written by hand.
  // base_ratio is dumped by nlohmann (shortest text that reads back exactly).
  const json ratio = std::isfinite(s.base_ratio) ? json(s.base_ratio) : json(nullptr);
  const json packing = ToValidUtf8(s.packing);
  return "{\"qp\":" + std::to_string(s.qp) + ",\"qn\":" + std::to_string(s.qn) + ",\"qt\":" + std::to_string(s.qt) +
         ",\"packing\":" + packing.dump() + ",\"packet_bytes\":" + std::to_string(s.packet_bytes) +
         ",\"base_ratio\":" + ratio.dump() + "}";
}

StatusOr<EncodeSettings> ParseSettingsJson(const std::string& text) {
  if (text.size() > kMaxOptionsJsonBytes) {
    return InvalidArgument("options: " + std::to_string(text.size()) + " bytes of JSON exceed " +
                           std::to_string(kMaxOptionsJsonBytes));
  }
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return InvalidArgument("options: not valid JSON");
  if (!j.is_object()) return InvalidArgument("options: not a JSON object");
  EncodeSettings s;
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    const json& v = item.value();
    if (key == "qp" || key == "qn" || key == "qt") {
      MS_ASSIGN_OR_RETURN(int64_t n, IntegerMember(v, key.c_str()));
      const int64_t hi = key == "qn" ? kMaxNormalBits : kMaxQuantizationBits;
      const int64_t lo = key == "qn" ? kMinNormalBits : kMinQuantizationBits;
      // 0 is the default; anything else must fit before it becomes an int.
      if (n != 0) MS_RETURN_IF_ERROR(CheckIntRange(key.c_str(), n, lo, hi));
      (key == "qp" ? s.qp : key == "qn" ? s.qn : s.qt) = static_cast<int>(n);
    } else if (key == "packet_bytes") {
      MS_ASSIGN_OR_RETURN(int64_t n, IntegerMember(v, "packet_bytes"));
      if (n != 0) MS_RETURN_IF_ERROR(CheckIntRange("packet_bytes", n, kMinPacketBytes, kMaxPacketBytes));
      s.packet_bytes = static_cast<uint32_t>(n);
    } else if (key == "packing") {
      if (!v.is_string()) return InvalidArgument("options.packing: not a string");
      s.packing = v.get<std::string>();
    } else if (key == "base_ratio") {
      if (!v.is_number()) return InvalidArgument("options.base_ratio: not a number");
      s.base_ratio = v.get<double>();
    } else {
      return InvalidArgument("options." + PrintableName(key) + ": not an encode option");
    }
  }
  return ResolveSettings(s);
}

ProgressiveGlbOptions ToGlbOptions(const EncodeSettings& s) {
  ProgressiveGlbOptions o;
  o.encode.quantization.qp = s.qp;
  o.encode.quantization.qn = s.qn;
  o.encode.quantization.qt = s.qt;
  o.stream.packing = s.packing == "bundled" ? Packing::kBundled : Packing::kSplit;
  o.stream.packet_bytes = s.packet_bytes;
  o.encode.simplify.base_ratio = s.base_ratio;
  // One ingest, one job, both profiles in one artifact (format version 4):
  // UDP sessions send the loss-tolerant one, the stream, the WebSocket and
  // HTTP ranges the reliable one (docs/design/pipeline.md).
  o.profiles = ProfileSet::kBoth;
  return o;
}

std::string EncoderId() {
  return "meshstream-progressive/" + std::to_string(kStreamVersion) + " datagram/" + std::to_string(kDatagramVersion) +
         " draco/" + draco::kDracoVersion + " pipeline/" + std::to_string(kPipelineRevision);
}

std::string ArtifactCacheKey(const std::string& tenant, const SourceFile& main,
                             const std::vector<SourceFile>& resources, const EncodeSettings& settings) {
  auto resolved = ResolveSettings(settings);
  std::string s;
  AppendField(s, "meshstream-artifact-key/2");
  AppendField(s, tenant);
  AppendField(s, EncoderId());
  AppendField(s, FixedParameters());
  AppendField(s, CanonicalJson(resolved.ok() ? resolved.value() : settings));
  AppendField(s, main.name);
  AppendField(s, main.sha256);
  std::vector<const SourceFile*> sorted;
  for (const SourceFile& r : resources) sorted.push_back(&r);
  std::sort(sorted.begin(), sorted.end(), [](const SourceFile* a, const SourceFile* b) {
    return a->name != b->name ? a->name < b->name : a->sha256 < b->sha256;
  });
  AppendField(s, std::to_string(sorted.size()));
  for (const SourceFile* r : sorted) {
    AppendField(s, r->name);
    AppendField(s, r->sha256);
  }
  return Sha256Hex(reinterpret_cast<const uint8_t*>(s.data()), s.size());
}

}  // namespace meshstream
