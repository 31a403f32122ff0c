#include "services/streaming/session_scene.h"

#include "importers/gltf_export.h"
#include "importers/progressive_glb.h"

namespace meshstream {

namespace {

template <typename T>
void KeepThree(std::vector<T>& v) {
  if (v.size() > 3) v.resize(3);
}

}  // namespace

StatusOr<std::vector<uint8_t>> MakeSessionScene(const std::vector<uint8_t>& artifact,
                                                const std::vector<std::pair<uint32_t, uint32_t>>& refined) {
  ProgressiveDecodeOptions options;
  options.lod = 0;
  ProgressiveDecodeReport report;
  auto scene = DecodeProgressiveGlb(artifact, options, &report);
  if (!scene.ok()) return scene.status().WithContext("the session's scene");
  for (const auto& [mesh, primitive] : refined) {
    if (mesh >= scene->meshes.size()) return DataLoss("the session's scene has no mesh " + std::to_string(mesh));
    const std::vector<Mesh::Ref> order = scene->meshes[mesh].Order();
    if (primitive >= order.size() || order[primitive].carried) {
      return DataLoss("the session's scene has no refined primitive " + std::to_string(primitive) + " in mesh " +
                      std::to_string(mesh));
    }
    Primitive& p = scene->meshes[mesh].primitives[order[primitive].index];
    if (p.positions.size() < 3) continue;  // nothing to shrink
    KeepThree(p.positions);
    KeepThree(p.normals);
    for (auto& set : p.texcoords) KeepThree(set);
    KeepThree(p.colors);
    p.indices = {0, 1, 2};
  }
  return ExportGlb(scene.value(), ExportOptions{});
}

}  // namespace meshstream
