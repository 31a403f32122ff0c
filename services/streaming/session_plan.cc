#include "services/streaming/session_plan.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <utility>

#include <nlohmann/json.hpp>

#include "codec/mesh/scene_flatten.h"
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

// A JSON array of n finite numbers, or false.
bool Numbers(const nlohmann::json& j, size_t n, double* out) {
  if (!j.is_array() || j.size() != n) return false;
  for (size_t i = 0; i < n; ++i) {
    if (!j[i].is_number()) return false;
    out[i] = j[i].get<double>();
    if (!std::isfinite(out[i])) return false;
  }
  return true;
}

// The scene's structure alone (nodes with their transforms and meshes, the
// scenes' roots, the default scene, as many empty meshes as the file has),
// read from the glTF JSON without importing the artifact.
Scene SceneStructure(const nlohmann::json& doc, size_t meshes) {
  Scene scene;
  scene.meshes.resize(meshes);
  auto index = [](const nlohmann::json& j) { return j.is_number_unsigned() ? j.get<int32_t>() : -1; };
  if (doc.contains("nodes") && doc["nodes"].is_array()) {
    for (const nlohmann::json& node : doc["nodes"]) {
      Node n;
      if (node.is_object()) {
        if (node.contains("mesh")) n.mesh = index(node["mesh"]);
        if (node.contains("children") && node["children"].is_array()) {
          for (const auto& c : node["children"]) n.children.push_back(index(c));
        }
        if (node.contains("matrix") && Numbers(node["matrix"], 16, n.matrix.data())) n.has_matrix = true;
        if (node.contains("translation")) Numbers(node["translation"], 3, n.translation.data());
        if (node.contains("rotation")) Numbers(node["rotation"], 4, n.rotation.data());
        if (node.contains("scale")) Numbers(node["scale"], 3, n.scale.data());
      }
      scene.nodes.push_back(std::move(n));
    }
  }
  if (doc.contains("scenes") && doc["scenes"].is_array()) {
    for (const nlohmann::json& root : doc["scenes"]) {
      SceneRoot r;
      if (root.is_object() && root.contains("nodes") && root["nodes"].is_array()) {
        for (const auto& n : root["nodes"]) r.nodes.push_back(index(n));
      }
      scene.scenes.push_back(std::move(r));
    }
  }
  if (doc.contains("scene")) scene.default_scene = index(doc["scene"]);
  return scene;
}

// Per mesh, the world matrices of the nodes that show it
// (codec/mesh/scene_flatten.h's ForEachMeshInstance over the default scene).
std::vector<std::vector<Mat4d>> MeshInstances(const nlohmann::json& doc, size_t meshes) {
  std::vector<std::vector<Mat4d>> out(meshes);
  ForEachMeshInstance(SceneStructure(doc, meshes),
                      [&](int32_t mesh, const Mat4d& world, bool) { out[static_cast<size_t>(mesh)].push_back(world); });
  return out;
}

// The box, in the scene, of meshes[mesh].primitives[primitive]'s base (its
// POSITION accessor's min and max) over every instance; false when the file
// does not say or no node shows the mesh.
bool WorldBounds(const nlohmann::json& doc, const std::vector<std::vector<Mat4d>>& instances, uint32_t mesh,
                 uint32_t primitive, Box* out) {
  try {
    const nlohmann::json& p = doc.at("meshes").at(mesh).at("primitives").at(primitive);
    const nlohmann::json& accessor = doc.at("accessors").at(p.at("attributes").at("POSITION").get<size_t>());
    Box local;
    if (!Numbers(accessor.at("min"), 3, local.lo.data()) || !Numbers(accessor.at("max"), 3, local.hi.data())) {
      return false;
    }
    if (mesh >= instances.size() || instances[mesh].empty()) return false;
    bool first = true;
    for (const Mat4d& m : instances[mesh]) {
      const Box b = TransformBox(local, m);
      for (int a = 0; a < 3; ++a) {
        out->lo[a] = first ? b.lo[a] : std::min(out->lo[a], b.lo[a]);
        out->hi[a] = first ? b.hi[a] : std::max(out->hi[a], b.hi[a]);
      }
      first = false;
    }
    return true;
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

}  // namespace

bool ViewCanOrder(const SessionPlan& plan) {
  for (const PlannedPrimitive& p : plan.primitives) {
    // The stream's errors cover every refinement, those of this session too.
    if (!p.has_bounds || p.residual_error.size() < size_t{p.refinements} + 1) return false;
  }
  return !plan.primitives.empty();
}

std::optional<SessionPlan> OrderByView(const SessionPlan& plan, size_t begun, const View& view,
                                       uint32_t* first_changed) {
  const size_t total = plan.refinements.size();
  if (!ViewCanOrder(plan) || begun >= total) return std::nullopt;
  // The levels keep their sizes: level L is the first count[L] refinements.
  std::vector<size_t> count(plan.levels + 1, 0);
  for (const PlannedRefinement& r : plan.refinements) {
    if (r.level >= 1 && r.level <= plan.levels) ++count[r.level];
  }
  for (uint32_t l = 1; l <= plan.levels; ++l) count[l] += count[l - 1];
  // Per primitive: its refinements begun, in the session, and by index.
  const size_t primitives = plan.primitives.size();
  std::vector<uint32_t> done(primitives, 0), in_session(primitives, 0);
  std::vector<std::vector<const PlannedRefinement*>> by_primitive(primitives);
  for (size_t k = 0; k < total; ++k) {
    const PlannedRefinement& r = plan.refinements[k];
    ++in_session[r.primitive];
    if (k < begun) ++done[r.primitive];
    auto& list = by_primitive[r.primitive];
    if (list.size() <= r.refinement) list.resize(r.refinement + 1, nullptr);
    list[r.refinement] = &r;
  }
  // The rest by the view: the scene's scheduler over each primitive's
  // remaining errors, in pixels (a suffix of its own).
  std::vector<Box> bounds;
  std::vector<std::vector<double>> errors;
  for (const PlannedPrimitive& p : plan.primitives) {
    bounds.push_back(p.bounds);
    errors.push_back(p.residual_error);
  }
  const std::vector<std::vector<double>> seen = ViewErrors(view, bounds, errors);
  std::vector<uint32_t> remaining(primitives);
  std::vector<std::vector<double>> rest_errors(primitives);
  for (size_t p = 0; p < primitives; ++p) {
    remaining[p] = in_session[p] - done[p];
    rest_errors[p].assign(seen[p].begin() + done[p], seen[p].begin() + in_session[p] + 1);
  }
  const SceneLevels rest = ScheduleSceneLevels(remaining, rest_errors);
  SessionPlan out;
  out.primitives = plan.primitives;
  out.reliable_profile = plan.reliable_profile;
  out.reliable_bytes = plan.reliable_bytes;
  out.unreliable_bytes = plan.unreliable_bytes;
  out.levels = plan.levels;
  out.refinements.assign(plan.refinements.begin(), plan.refinements.begin() + static_cast<long>(begun));
  bool same = true;
  for (const ScheduledRefinement& s : rest.order) {
    const PlannedRefinement& r = *by_primitive[s.primitive][done[s.primitive] + s.refinement];
    const PlannedRefinement& was = plan.refinements[out.refinements.size()];
    same = same && was.primitive == r.primitive && was.refinement == r.refinement;
    out.refinements.push_back(r);
  }
  if (same) return std::nullopt;
  // Each refinement's level and each primitive's level list, by position.
  uint32_t level = 1;
  for (size_t k = 0; k < out.refinements.size(); ++k) {
    while (level < plan.levels && count[level] <= k) ++level;
    out.refinements[k].level = level;
  }
  std::vector<uint32_t> applied(primitives, 0);
  for (PlannedPrimitive& p : out.primitives) p.level_refinements.assign(plan.levels, 0);
  size_t k = 0;
  for (uint32_t l = 1; l <= plan.levels; ++l) {
    for (; k < count[l] && k < out.refinements.size(); ++k) ++applied[out.refinements[k].primitive];
    for (size_t p = 0; p < primitives; ++p) out.primitives[p].level_refinements[l - 1] = applied[p];
  }
  uint32_t first = 1;
  while (first <= plan.levels && count[first] <= begun) ++first;
  if (first_changed != nullptr) *first_changed = first;
  return out;
}

SessionPlan ViewPlan(const SessionPlan& full, const View& view, int32_t max_level) {
  uint32_t first_changed = 0;
  std::optional<SessionPlan> ordered = OrderByView(full, 0, view, &first_changed);
  return CutPlan(ordered ? *ordered : full, max_level);
}

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
  const size_t meshes = doc.is_object() && doc.contains("meshes") && doc["meshes"].is_array() ? doc["meshes"].size() : 0;
  const std::vector<std::vector<Mat4d>> instances = MeshInstances(doc, meshes);
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
    p.has_bounds = WorldBounds(doc, instances, entry.mesh, entry.primitive, &p.bounds);
    p.residual_error = entry.residual_error;
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
