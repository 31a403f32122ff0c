#include "services/streaming/session_scene.h"

#include "importers/gltf_export.h"
#include "importers/progressive_glb.h"

namespace meshstream {

StatusOr<std::vector<uint8_t>> MakeSessionScene(const std::vector<uint8_t>& artifact) {
  ProgressiveDecodeOptions options;
  options.lod = 0;
  ProgressiveDecodeReport report;
  auto scene = DecodeProgressiveGlb(artifact, options, &report);
  if (!scene.ok()) return scene.status().WithContext("the session's scene");
  return ExportGlb(scene.value(), ExportOptions{});
}

StatusOr<std::shared_ptr<const std::vector<uint8_t>>> SessionSceneCache::Get(const std::string& artifact_sha256,
                                                                             const std::vector<uint8_t>& artifact) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first == artifact_sha256) {
        entries_.splice(entries_.begin(), entries_, it);
        return entries_.front().second;
      }
    }
  }
  // Made outside the lock: two sessions may make the same scene once each.
  auto made = MakeSessionScene(artifact);
  if (!made.ok()) return made.status();
  auto shared = std::make_shared<const std::vector<uint8_t>>(std::move(made).value());
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.emplace_front(artifact_sha256, shared);
  while (entries_.size() > max_entries_) entries_.pop_back();
  return shared;
}

}  // namespace meshstream
