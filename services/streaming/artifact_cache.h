// The artifacts of the sessions running, shared: every session of one
// version holds the same bytes instead of a copy each (a server of thousands
// of sessions of one asset holds it once). An artifact stays while a session
// holds it and goes with the last one (weak references), so the cache holds
// nothing the sessions do not.
//
// Contract: `load` is called (outside the lock) when no running session holds
// the artifact; two sessions that open at once may both load it, and the
// second keeps its own copy until it ends.
// Thread safety: Get from any thread.
#ifndef MESHSTREAM_SERVICES_STREAMING_ARTIFACT_CACHE_H_
#define MESHSTREAM_SERVICES_STREAMING_ARTIFACT_CACHE_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

class ArtifactCache {
 public:
  using Bytes = std::shared_ptr<const std::vector<uint8_t>>;
  StatusOr<Bytes> Get(const std::string& sha256, const std::function<StatusOr<std::vector<uint8_t>>()>& load);

 private:
  std::mutex mutex_;
  std::map<std::string, std::weak_ptr<const std::vector<uint8_t>>> held_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_ARTIFACT_CACHE_H_
