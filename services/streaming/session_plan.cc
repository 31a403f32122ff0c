#include "services/streaming/session_plan.h"

#include <algorithm>
#include <cstring>
#include <utility>

#include <nlohmann/json.hpp>

#include "codec/progressive/scene_levels.h"

namespace meshstream {

namespace {

// The glTF JSON of a .glb (its first chunk), or null when there is none.
nlohmann::json GlbJson(const std::vector<uint8_t>& glb) {
  if (glb.size() < 20) return nullptr;
  uint32_t length = 0, type = 0;
  std::memcpy(&length, glb.data() + 12, 4);
  std::memcpy(&type, glb.data() + 16, 4);
  if (type != 0x4E4F534Au || length > glb.size() - 20) return nullptr;
  return nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + length, nullptr, false);
}

// KHR_draco_mesh_compression.attributes of meshes[mesh].primitives[primitive].
StatusOr<std::map<std::string, int32_t>> DracoAttributes(const nlohmann::json& doc, uint32_t mesh, uint32_t primitive) {
  const std::string where = "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(primitive) + "]";
  if (!doc.is_object() || !doc.contains("meshes") || !doc["meshes"].is_array() || mesh >= doc["meshes"].size()) {
    return DataLoss("the artifact has no " + where);
  }
  const nlohmann::json& m = doc["meshes"][mesh];
  if (!m.is_object() || !m.contains("primitives") || !m["primitives"].is_array() || primitive >= m["primitives"].size()) {
    return DataLoss("the artifact has no " + where);
  }
  const nlohmann::json& p = m["primitives"][primitive];
  const nlohmann::json* attributes = nullptr;
  if (p.is_object() && p.contains("extensions") && p["extensions"].is_object() &&
      p["extensions"].contains("KHR_draco_mesh_compression")) {
    const nlohmann::json& draco = p["extensions"]["KHR_draco_mesh_compression"];
    if (draco.is_object() && draco.contains("attributes") && draco["attributes"].is_object()) {
      attributes = &draco["attributes"];
    }
  }
  if (attributes == nullptr) return DataLoss(where + ": no KHR_draco_mesh_compression attributes");
  std::map<std::string, int32_t> out;
  for (const auto& [name, id] : attributes->items()) {
    if (!id.is_number_integer() || id.get<int64_t>() < 0 || id.get<int64_t>() > 1000) {
      return DataLoss(where + ": Draco attribute " + name + " has no valid id");
    }
    out[name] = id.get<int32_t>();
  }
  return out;
}

}  // namespace

std::vector<uint32_t> ReliableCutFor(const PlannedPrimitive& p, double loss) {
  return CutForShare(p.delivery.ranking, p.refinement_bytes, p.stream_bytes,
                     ReliableShareForLoss(p.delivery.share, loss));
}

StatusOr<SessionPlan> PlanSession(const std::vector<uint8_t>& artifact, const std::string& layout_json,
                                  int32_t max_level, bool reliable) {
  auto layout = ParseStreamLayout(layout_json);
  if (!layout.ok()) return DataLoss("the version's stream layout: " + layout.status().message());
  if (layout->file_bytes != artifact.size()) {
    return DataLoss("the stream layout describes " + std::to_string(layout->file_bytes) +
                    " bytes, the artifact has " + std::to_string(artifact.size()));
  }
  SessionPlan plan;
  plan.reliable_profile = reliable && !layout->primitives.empty();
  std::vector<StreamBlocks> blocks;
  const nlohmann::json doc = layout->primitives.empty() ? nlohmann::json() : GlbJson(artifact);
  for (const PrimitiveLayout& entry : layout->primitives) {
    const bool second = reliable && entry.has_reliable();
    plan.reliable_profile = plan.reliable_profile && second;
    auto located = LocateStreamBlocks(artifact.data(), artifact.size(), entry, second);
    if (!located.ok()) return located.status().WithContext("stream " + std::to_string(entry.stream));
    PlannedPrimitive p;
    p.stream = entry.stream;
    p.mesh = entry.mesh;
    p.mesh_primitive = entry.primitive;
    p.header = located->header;
    p.base = located->base;
    p.refinements = static_cast<uint32_t>(located->control.size());
    auto attributes = DracoAttributes(doc, entry.mesh, entry.primitive);
    if (!attributes.ok()) return attributes.status();
    p.draco_attributes = std::move(attributes).value();
    if (!second) p.delivery = entry.delivery;  // the reliable profile has nothing to deliver
    p.refinement_bytes.assign(located->datagrams.size(), 0);
    for (size_t i = 0; i < located->datagrams.size(); ++i) {
      for (const ByteRange& d : located->datagrams[i]) p.refinement_bytes[i] += d.length;
    }
    p.stream_bytes = p.base.length + (second ? entry.reliable_profile_bytes : entry.reliable_bytes + entry.unreliable_bytes);
    plan.reliable_bytes += p.header.length + p.base.length;
    plan.primitives.push_back(p);
    blocks.push_back(std::move(located).value());
  }
  std::vector<uint32_t> counts;
  std::vector<std::vector<double>> errors;
  for (size_t i = 0; i < plan.primitives.size(); ++i) {
    counts.push_back(plan.primitives[i].refinements);
    errors.push_back(layout->primitives[i].residual_error);
  }
  const SceneLevels levels = ScheduleSceneLevels(counts, errors);
  plan.levels = levels.levels;
  for (size_t i = 0; i < plan.primitives.size(); ++i) plan.primitives[i].level_refinements = levels.applied[i];
  for (const ScheduledRefinement& s : levels.order) {
    PlannedRefinement r;
    r.primitive = s.primitive;
    r.refinement = s.refinement;
    r.level = s.level;
    r.control = blocks[s.primitive].control[s.refinement];
    r.datagrams = blocks[s.primitive].datagrams[s.refinement];
    plan.reliable_bytes += r.control.length;
    for (const ByteRange& d : r.datagrams) plan.unreliable_bytes += d.length;
    plan.refinements.push_back(std::move(r));
  }
  if (max_level < 0) return plan;
  return CutPlan(plan, max_level);
}

SessionPlan CutPlan(const SessionPlan& full, int32_t max_level) {
  if (max_level < 0) return full;
  const uint32_t cut = std::min(static_cast<uint32_t>(max_level), full.levels);
  SessionPlan plan;
  plan.primitives = full.primitives;
  plan.reliable_profile = full.reliable_profile;
  plan.levels = cut;
  for (PlannedPrimitive& p : plan.primitives) {
    p.level_refinements.resize(std::min<size_t>(cut, p.level_refinements.size()));
    p.refinements = p.level_refinements.empty() ? 0 : p.level_refinements.back();
    plan.reliable_bytes += p.header.length + p.base.length;
  }
  for (const PlannedRefinement& r : full.refinements) {
    if (r.level > cut) continue;
    plan.reliable_bytes += r.control.length;
    for (const ByteRange& d : r.datagrams) plan.unreliable_bytes += d.length;
    plan.refinements.push_back(r);
  }
  return plan;
}

}  // namespace meshstream
