#include "services/pipeline/stream_layout.h"

#include <algorithm>
#include <limits>

#include <nlohmann/json.hpp>

#include "codec/core/byte_io.h"
#include "importers/gltf_limits.h"
#include "importers/progressive_glb.h"

namespace meshstream {

namespace {

using json = nlohmann::json;

constexpr char kDracoExtension[] = "KHR_draco_mesh_compression";
constexpr size_t kMaxLayoutJsonBytes = size_t{64} << 20;
constexpr uint64_t kMaxLayoutPrimitives = uint64_t{1} << 20;

// --- reading the .glb ------------------------------------------------------

// The absolute range of bufferView `view` of the GLB's binary chunk.
StatusOr<ByteRange> ViewRange(const json& doc, const json& view_index, const GlbView& glb, const uint8_t* file,
                              const std::string& where) {
  if (!view_index.is_number_unsigned()) return InvalidInput(where + ".bufferView is not an unsigned integer");
  const uint64_t view = view_index.get<uint64_t>();
  const json* views = doc.contains("bufferViews") ? &doc["bufferViews"] : nullptr;
  if (views == nullptr || !views->is_array() || view >= views->size()) {
    return InvalidInput(where + ".bufferView " + std::to_string(view) + " does not exist");
  }
  const json& v = (*views)[view];
  if (!v.is_object()) return InvalidInput("bufferViews[" + std::to_string(view) + "] is not an object");
  const json buffer = v.value("buffer", json(nullptr));
  if (!buffer.is_number_unsigned() || buffer.get<uint64_t>() != 0) {
    return InvalidInput("bufferViews[" + std::to_string(view) + "] is not in the GLB's binary chunk (buffer 0)");
  }
  const json offset = v.value("byteOffset", json(0));
  const json length = v.value("byteLength", json(nullptr));
  if (!offset.is_number_unsigned() || !length.is_number_unsigned()) {
    return InvalidInput("bufferViews[" + std::to_string(view) + "]: byteOffset or byteLength is not an unsigned integer");
  }
  const uint64_t o = offset.get<uint64_t>(), n = length.get<uint64_t>();
  if (glb.bin == nullptr || o > glb.bin_size || n > glb.bin_size - o) {
    return InvalidInput(where + ": bufferView " + std::to_string(view) + " lies outside the GLB's binary chunk");
  }
  return ByteRange{static_cast<uint64_t>(glb.bin - file) + o, n};
}

// The stream id of the first data datagram of `s`, when there is one.
StatusOr<int64_t> FirstDatagramStream(const ProgressiveStream& s) {
  for (const auto& level : s.datagrams) {
    for (const auto& d : level) {
      ByteReader r(d.data(), d.size());
      MS_ASSIGN_OR_RETURN(DatagramHeader h, DatagramHeader::Parse(r));
      return static_cast<int64_t>(h.stream);
    }
  }
  return int64_t{-1};
}

// `datagram_stream`: the stream number the first datagram names (-1: none).
StatusOr<PrimitiveLayout> PrimitiveFromFile(const json& doc, const json& prim, const GlbView& glb, const uint8_t* file,
                                            const std::string& where, int64_t* datagram_stream) {
  const json& ext = prim["extensions"];
  PrimitiveLayout p;
  if (!ext.contains(kDracoExtension) || !ext[kDracoExtension].is_object() ||
      !ext[kDracoExtension].contains("bufferView")) {
    return InvalidInput(where + ": a progressive primitive without " + kDracoExtension + ".bufferView");
  }
  MS_ASSIGN_OR_RETURN(p.base, ViewRange(doc, ext[kDracoExtension]["bufferView"], glb, file,
                                        where + ".extensions." + kDracoExtension));
  const json& progressive = ext[kProgressiveExtension];
  if (!progressive.is_object() || !progressive.contains("bufferView")) {
    return InvalidInput(where + ": " + kProgressiveExtension + ".bufferView is missing");
  }
  MS_ASSIGN_OR_RETURN(p.stream_blob, ViewRange(doc, progressive["bufferView"], glb, file,
                                               where + ".extensions." + kProgressiveExtension));
  if (progressive.contains("reliable")) {
    MS_ASSIGN_OR_RETURN(p.reliable_blob, ViewRange(doc, progressive["reliable"], glb, file,
                                                   where + ".extensions." + kProgressiveExtension + ".reliable"));
  }
  auto parsed = ProgressiveStream::Parse(file + p.stream_blob.offset, static_cast<size_t>(p.stream_blob.length));
  if (!parsed.ok()) return parsed.status().WithContext(where);
  const ProgressiveStream& s = parsed.value();
  auto header = s.ParseHeader();
  if (!header.ok()) return header.status().WithContext(where);
  p.quantization = header->quantization;
  p.packing = header->packing;
  p.refinements = static_cast<uint32_t>(s.control.size());
  p.split_counts = header->split_counts;
  for (const auto& level : s.datagrams) p.datagram_counts.push_back(static_cast<uint32_t>(level.size()));
  p.level_vertices = header->level_vertices();
  p.reliable_bytes = s.reliable_bytes();
  p.unreliable_bytes = s.unreliable_bytes();
  if (progressive.contains("delivery")) {
    auto delivery = ParseDeliveryRecord(progressive["delivery"].dump(), s.control.size());
    if (!delivery.ok()) return delivery.status().WithContext(where);
    p.delivery = std::move(delivery).value();
  }
  if (progressive.contains("residual_error")) {
    auto residual = ParseResidualErrors(progressive["residual_error"].dump(), s.control.size());
    if (!residual.ok()) return residual.status().WithContext(where);
    p.residual_error = std::move(residual).value();
  }
  auto first = FirstDatagramStream(s);
  if (!first.ok()) return first.status().WithContext(where);
  *datagram_stream = first.value();
  if (p.has_reliable()) {
    // The reliable profile's stream of the same hierarchy: same refinements, no datagrams.
    auto second = ProgressiveStream::Parse(file + p.reliable_blob.offset, static_cast<size_t>(p.reliable_blob.length));
    if (!second.ok()) return second.status().WithContext(where + ": the reliable profile");
    auto second_header = second->ParseHeader();
    if (!second_header.ok()) return second_header.status().WithContext(where + ": the reliable profile");
    if (!second_header->reliable() || second->datagram_count() != 0) {
      return InvalidInput(where + ": " + kProgressiveExtension + ".reliable is not a stream of the reliable profile");
    }
    if (second_header->split_counts != header->split_counts) {
      return InvalidInput(where + ": the two profiles' streams have different refinements");
    }
    p.reliable_profile_bytes = second->reliable_bytes();
  }
  return p;
}

// --- reading the layout JSON -------------------------------------------------

Status Missing(const std::string& where, const char* what) {
  return InvalidInput("stream layout: " + where + ": missing or not " + what);
}

StatusOr<uint64_t> GetU64(const json& obj, const std::string& where, const char* key, uint64_t max) {
  const std::string at = where.empty() ? key : where + "." + key;
  if (!obj.contains(key) || !obj[key].is_number_unsigned()) return Missing(at, "an unsigned integer");
  const uint64_t v = obj[key].get<uint64_t>();
  if (v > max) return InvalidInput("stream layout: " + at + " = " + std::to_string(v) + " exceeds " + std::to_string(max));
  return v;
}

StatusOr<std::vector<uint32_t>> GetU32Array(const json& obj, const std::string& where, const char* key, size_t size,
                                            uint64_t max) {
  const std::string at = where + "." + key;
  if (!obj.contains(key) || !obj[key].is_array()) return Missing(at, "an array");
  const json& a = obj[key];
  if (a.size() != size) {
    return InvalidInput("stream layout: " + at + " has " + std::to_string(a.size()) + " entries, not " +
                        std::to_string(size));
  }
  max = std::min<uint64_t>(max, UINT32_MAX);
  std::vector<uint32_t> out;
  out.reserve(size);
  for (size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_number_unsigned() || a[i].get<uint64_t>() > max) {
      return InvalidInput("stream layout: " + at + "[" + std::to_string(i) + "] is not an unsigned integer up to " +
                          std::to_string(max));
    }
    out.push_back(static_cast<uint32_t>(a[i].get<uint64_t>()));
  }
  return out;
}

StatusOr<ByteRange> GetRange(const json& obj, const std::string& where, const char* key, uint64_t file_bytes) {
  const std::string at = where + "." + key;
  if (!obj.contains(key) || !obj[key].is_object()) return Missing(at, "an object");
  ByteRange r;
  MS_ASSIGN_OR_RETURN(r.offset, GetU64(obj[key], at, "offset", file_bytes));
  MS_ASSIGN_OR_RETURN(r.length, GetU64(obj[key], at, "length", file_bytes - r.offset));
  return r;
}

StatusOr<PrimitiveLayout> PrimitiveFromJson(const json& e, const std::string& where, uint64_t file_bytes) {
  if (!e.is_object()) return Missing(where, "an object");
  PrimitiveLayout p;
  MS_ASSIGN_OR_RETURN(uint64_t mesh, GetU64(e, where, "mesh", UINT32_MAX));
  MS_ASSIGN_OR_RETURN(uint64_t primitive, GetU64(e, where, "primitive", UINT32_MAX));
  MS_ASSIGN_OR_RETURN(uint64_t stream, GetU64(e, where, "stream", UINT32_MAX));
  p.mesh = static_cast<uint32_t>(mesh);
  p.primitive = static_cast<uint32_t>(primitive);
  p.stream = static_cast<uint32_t>(stream);
  MS_ASSIGN_OR_RETURN(p.base, GetRange(e, where, "base", file_bytes));
  MS_ASSIGN_OR_RETURN(p.stream_blob, GetRange(e, where, "stream_blob", file_bytes));
  const std::string qwhere = where + ".quantization";
  if (!e.contains("quantization") || !e["quantization"].is_object()) return Missing(qwhere, "an object");
  const json& q = e["quantization"];
  int* const bits[4] = {&p.quantization.qp, &p.quantization.qn, &p.quantization.qt, &p.quantization.qc};
  const char* const names[4] = {"qp", "qn", "qt", "qc"};
  for (int k = 0; k < 4; ++k) {
    MS_ASSIGN_OR_RETURN(uint64_t b, GetU64(q, qwhere, names[k], 30));
    if (b == 0) return InvalidInput("stream layout: " + qwhere + "." + names[k] + " is 0");
    *bits[k] = static_cast<int>(b);
  }
  if (!e.contains("packing") || !e["packing"].is_string()) return Missing(where + ".packing", "a string");
  const std::string packing = e["packing"].get<std::string>();
  if (packing != "split" && packing != "bundled") {
    return InvalidInput("stream layout: " + where + ".packing is not split or bundled");
  }
  p.packing = packing == "split" ? Packing::kSplit : Packing::kBundled;
  MS_ASSIGN_OR_RETURN(uint64_t refinements, GetU64(e, where, "refinements", kMaxRefinements));
  p.refinements = static_cast<uint32_t>(refinements);
  MS_ASSIGN_OR_RETURN(p.split_counts, GetU32Array(e, where, "split_counts", p.refinements, kMaxStreamVertices));
  MS_ASSIGN_OR_RETURN(p.datagram_counts, GetU32Array(e, where, "datagram_counts", p.refinements, file_bytes / 2));
  MS_ASSIGN_OR_RETURN(p.level_vertices,
                      GetU32Array(e, where, "level_vertices", size_t{p.refinements} + 1, kMaxStreamVertices));
  MS_ASSIGN_OR_RETURN(p.reliable_bytes, GetU64(e, where, "reliable_bytes", p.stream_blob.length));
  MS_ASSIGN_OR_RETURN(p.unreliable_bytes, GetU64(e, where, "unreliable_bytes", p.stream_blob.length));
  if (e.contains("reliable_blob")) {  // optional: layouts before version 4 and files of one profile have none
    MS_ASSIGN_OR_RETURN(p.reliable_blob, GetRange(e, where, "reliable_blob", file_bytes));
    MS_ASSIGN_OR_RETURN(p.reliable_profile_bytes, GetU64(e, where, "reliable_profile_bytes", p.reliable_blob.length));
  }
  if (e.contains("delivery")) {  // optional: layouts stored before the reliable cut have none
    auto delivery = ParseDeliveryRecord(e["delivery"].dump(), p.refinements);
    if (!delivery.ok()) return InvalidInput("stream layout: " + where + ": " + delivery.status().message());
    p.delivery = std::move(delivery).value();
  }
  if (e.contains("residual_error")) {  // optional: layouts stored before scene levels have none
    auto residual = ParseResidualErrors(e["residual_error"].dump(), p.refinements);
    if (!residual.ok()) return InvalidInput("stream layout: " + where + ": " + residual.status().message());
    p.residual_error = std::move(residual).value();
  }
  return p;
}

StatusOr<StreamLayout> ParseChecked(const std::string& text) {
  if (text.size() > kMaxLayoutJsonBytes) return InvalidInput("stream layout: " + std::to_string(text.size()) + " bytes is too large");
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return InvalidInput("stream layout: not valid JSON");
  if (!j.is_object()) return InvalidInput("stream layout: not a JSON object");
  MS_ASSIGN_OR_RETURN(uint64_t version, GetU64(j, "", "version", UINT32_MAX));
  if (version != kStreamLayoutVersion) {
    return Unsupported("stream layout: version " + std::to_string(version) + " is not " +
                       std::to_string(kStreamLayoutVersion));
  }
  StreamLayout layout;
  MS_ASSIGN_OR_RETURN(layout.file_bytes, GetU64(j, "", "file_bytes", std::numeric_limits<uint64_t>::max()));
  if (!j.contains("primitives") || !j["primitives"].is_array()) return Missing("primitives", "an array");
  const json& prims = j["primitives"];
  if (prims.size() > kMaxLayoutPrimitives) return InvalidInput("stream layout: too many primitives");
  for (size_t i = 0; i < prims.size(); ++i) {
    MS_ASSIGN_OR_RETURN(PrimitiveLayout p,
                        PrimitiveFromJson(prims[i], "primitives[" + std::to_string(i) + "]", layout.file_bytes));
    layout.primitives.push_back(std::move(p));
  }
  return layout;
}

// --- walking the stream blob's framing ------------------------------------

StatusOr<StreamBlocks> LocateChecked(const uint8_t* glb, size_t size, const PrimitiveLayout& entry, bool reliable) {
  auto inside = [size](const ByteRange& r) { return r.offset <= size && r.length <= size - r.offset; };
  if (!inside(entry.base)) return InvalidInput("stream layout: the base mesh lies outside the file");
  if (reliable && !entry.has_reliable()) return InvalidInput("stream layout: the stream has no reliable profile");
  const ByteRange& chosen = reliable ? entry.reliable_blob : entry.stream_blob;
  if (!inside(chosen)) return InvalidInput("stream layout: the stream blob lies outside the file");
  const uint8_t* blob = glb + chosen.offset;
  const uint64_t origin = chosen.offset;
  // The framing of docs/spec/progressive-format.md section 2, with the checks of
  // ProgressiveStream::Parse, recording where each block lies.
  ByteReader r(blob, static_cast<size_t>(chosen.length));
  static const uint8_t kMagic[4] = {'M', 'S', 'P', 'S'};
  for (uint8_t b : kMagic) {
    MS_ASSIGN_OR_RETURN(uint8_t got, r.U8("stream blob: magic"));
    if (got != b) return InvalidInput("stream blob: magic is not MSPS (not a meshstream progressive stream)");
  }
  MS_ASSIGN_OR_RETURN(uint8_t version, r.U8("stream blob: version"));
  if (!IsStreamVersion(version)) {
    return Unsupported("stream blob: version " + std::to_string(version) + " is not " + kStreamVersionsText);
  }
  StreamBlocks out;
  out.base = entry.base;
  auto range = [&](const uint8_t* p, size_t length) {
    return ByteRange{origin + static_cast<uint64_t>(p - blob), static_cast<uint64_t>(length)};
  };
  size_t length = 0;
  MS_ASSIGN_OR_RETURN(const uint8_t* header, r.Block("stream blob: header", &length));
  out.header = range(header, length);
  MS_ASSIGN_OR_RETURN(uint64_t levels, r.Varint("stream blob: refinement count", kMaxRefinements));
  if (levels != entry.refinements) {
    return DataLoss("stream layout: the blob has " + std::to_string(levels) + " refinements, the layout " +
                    std::to_string(entry.refinements));
  }
  if (entry.datagram_counts.size() != levels) return InvalidInput("stream layout: datagram_counts does not match refinements");
  for (uint64_t i = 0; i < levels; ++i) {
    MS_ASSIGN_OR_RETURN(const uint8_t* control, r.Block("stream blob: control block", &length));
    out.control.push_back(range(control, length));
    MS_ASSIGN_OR_RETURN(uint64_t count, r.Varint("stream blob: datagram count", r.remaining() / 2));
    const uint64_t expected = reliable ? 0 : entry.datagram_counts[i];
    if (count != expected) {
      return DataLoss("stream layout: refinement " + std::to_string(i) + " has " + std::to_string(count) +
                      " datagrams, the layout " + std::to_string(expected));
    }
    out.datagrams.emplace_back();
    out.datagrams.back().reserve(static_cast<size_t>(count));
    for (uint64_t d = 0; d < count; ++d) {
      MS_ASSIGN_OR_RETURN(const uint8_t* dg, r.Block("stream blob: datagram", &length));
      out.datagrams.back().push_back(range(dg, length));
    }
  }
  if (r.remaining() != 0) {
    return InvalidInput("stream blob: " + std::to_string(r.remaining()) + " stray bytes after the last refinement");
  }
  return out;
}

StatusOr<StreamLayout> ComputeChecked(const uint8_t* data, size_t size) {
  MS_ASSIGN_OR_RETURN(GlbView glb, ParseGlb(data, size));
  const json doc = json::parse(glb.json, glb.json + glb.json_size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return InvalidInput("GLB: the JSON chunk is not a JSON object");
  StreamLayout layout;
  layout.file_bytes = size;
  if (!doc.contains("meshes")) return layout;
  const json& meshes = doc["meshes"];
  if (!meshes.is_array()) return InvalidInput("meshes is not an array");
  uint32_t stream = 0;
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (!meshes[m].is_object() || !meshes[m].contains("primitives") || !meshes[m]["primitives"].is_array()) {
      return InvalidInput("meshes[" + std::to_string(m) + "].primitives is not an array");
    }
    const json& prims = meshes[m]["primitives"];
    for (size_t j = 0; j < prims.size(); ++j) {
      const json& prim = prims[j];
      if (!prim.is_object() || !prim.contains("extensions") || !prim["extensions"].is_object() ||
          !prim["extensions"].contains(kProgressiveExtension)) {
        continue;  // carried, or without triangles: plain glTF
      }
      const std::string where = "meshes[" + std::to_string(m) + "].primitives[" + std::to_string(j) + "]";
      int64_t datagram_stream = -1;
      MS_ASSIGN_OR_RETURN(PrimitiveLayout p, PrimitiveFromFile(doc, prim, glb, data, where, &datagram_stream));
      p.mesh = static_cast<uint32_t>(m);
      p.primitive = static_cast<uint32_t>(j);
      // Streams are numbered in file order (docs/spec/progressive-format.md,
      // section 1); the datagrams carry the same number.
      if (datagram_stream >= 0 && datagram_stream != stream) {
        return InvalidInput(where + ": its datagrams name stream " + std::to_string(datagram_stream) + ", not " +
                            std::to_string(stream));
      }
      p.stream = stream++;
      layout.primitives.push_back(std::move(p));
    }
  }
  return layout;
}

}  // namespace

uint32_t StreamLayout::levels() const {
  uint32_t n = 0;
  for (const PrimitiveLayout& p : primitives) n = std::max(n, p.refinements);
  return n;
}

StatusOr<StreamLayout> ComputeStreamLayout(const uint8_t* glb, size_t size) {
  try {
    return ComputeChecked(glb, size);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("stream layout: out of memory");
  } catch (const std::exception& e) {
    return InvalidInput(std::string("stream layout: ") + e.what());
  }
}

std::string StreamLayoutJson(const StreamLayout& layout) {
  json prims = json::array();
  for (const PrimitiveLayout& p : layout.primitives) {
    json entry = {
        {"mesh", p.mesh},
        {"primitive", p.primitive},
        {"stream", p.stream},
        {"base", {{"offset", p.base.offset}, {"length", p.base.length}}},
        {"stream_blob", {{"offset", p.stream_blob.offset}, {"length", p.stream_blob.length}}},
        {"quantization",
         {{"qp", p.quantization.qp}, {"qn", p.quantization.qn}, {"qt", p.quantization.qt}, {"qc", p.quantization.qc}}},
        {"packing", p.packing == Packing::kSplit ? "split" : "bundled"},
        {"refinements", p.refinements},
        {"split_counts", p.split_counts},
        {"datagram_counts", p.datagram_counts},
        {"level_vertices", p.level_vertices},
        {"reliable_bytes", p.reliable_bytes},
        {"unreliable_bytes", p.unreliable_bytes},
    };
    if (p.has_reliable()) {
      entry["reliable_blob"] = {{"offset", p.reliable_blob.offset}, {"length", p.reliable_blob.length}};
      entry["reliable_profile_bytes"] = p.reliable_profile_bytes;
    }
    if (p.delivery.share > 0 || !p.delivery.ranking.empty()) {
      entry["delivery"] = json::parse(DeliveryRecordJson(p.delivery));
    }
    if (!p.residual_error.empty()) entry["residual_error"] = json::parse(ResidualErrorsJson(p.residual_error));
    prims.push_back(std::move(entry));
  }
  const json j = {{"version", kStreamLayoutVersion}, {"file_bytes", layout.file_bytes}, {"primitives", std::move(prims)}};
  return j.dump();
}

StatusOr<StreamLayout> ParseStreamLayout(const std::string& text) {
  try {
    return ParseChecked(text);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("stream layout: out of memory");
  } catch (const std::exception& e) {
    return InvalidInput(std::string("stream layout: ") + e.what());
  }
}

StatusOr<StreamBlocks> LocateStreamBlocks(const uint8_t* glb, size_t size, const PrimitiveLayout& entry,
                                          bool reliable) {
  try {
    return LocateChecked(glb, size, entry, reliable);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("stream layout: out of memory");
  }
}

}  // namespace meshstream
