#include "services/streaming/artifact_cache.h"

#include <utility>

namespace meshstream {

StatusOr<ArtifactCache::Bytes> ArtifactCache::Get(const std::string& sha256,
                                                  const std::function<StatusOr<std::vector<uint8_t>>()>& load) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = held_.find(sha256);
    if (it != held_.end()) {
      if (Bytes bytes = it->second.lock()) return bytes;
      held_.erase(it);
    }
  }
  auto loaded = load();
  if (!loaded.ok()) return loaded.status();
  Bytes bytes = std::make_shared<const std::vector<uint8_t>>(std::move(loaded).value());
  std::lock_guard<std::mutex> lock(mutex_);
  // Entries whose sessions all ended go here, so the map stays as small as the running set.
  for (auto it = held_.begin(); it != held_.end();) it = it->second.expired() ? held_.erase(it) : std::next(it);
  auto& slot = held_[sha256];
  if (Bytes other = slot.lock()) return other;
  slot = bytes;
  return bytes;
}

}  // namespace meshstream
