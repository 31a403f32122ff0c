// The hot artifacts of the streaming sessions, kept in memory between
// sessions (issue 23, "The server's cost per session"): per artifact its
// bytes, read from the store once (the store's read checks them against
// their SHA-256: a corrupt blob is refused there, at load, and nothing is
// kept), the session plan of every refinement parsed once from the version's
// stream layout (session_plan.h; a session with max_level cuts its own copy
// from it, CutPlan), and the scene at level 0 (session_scene.h). A session
// opens with a lookup instead of a read, a digest, a plan and a scene.
//
// Bounded by bytes: what the cache keeps (the artifact, its scene, its
// plan's ranges) is at most `max_bytes`; beyond, the least recently used
// entries go (LRU). An entry a running session still holds stays alive for
// it (shared) and is found again by the next session of that artifact
// (weak references), so that sessions of one artifact share one copy
// whatever the bound; an entry larger than `max_bytes` is only held so.
// `max_bytes` 0 keeps nothing but what sessions hold.
//
// Contract: `load` is called outside the lock, at most once per Get, when
// no entry of that digest is kept or held; two sessions that miss at once
// may both load, and the second keeps the first's entry. An entry is keyed
// by the artifact's digest and checked against the layout it was planned
// from: a layout that differs (a version that describes the same bytes
// otherwise) is planned on its own, not kept.
// Thread safety: every method from any thread.
#ifndef MESHSTREAM_SERVICES_STREAMING_HOT_ARTIFACTS_H_
#define MESHSTREAM_SERVICES_STREAMING_HOT_ARTIFACTS_H_

#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/streaming/session_plan.h"

namespace meshstream {

// One artifact, ready for sessions. Immutable once made.
struct HotArtifact {
  std::string sha256;
  std::string layout_json;       // what `plan` was made from
  std::vector<uint8_t> bytes;    // the stored progressive .glb, as the store's checked read gave it
  SessionPlan plan;              // every refinement (max_level -1), the loss-tolerant profile's streams
  SessionPlan reliable_plan;     // the same of the reliable profile's, where the artifact has them
  std::vector<uint8_t> scene;    // SessionStart.scene_glb (MakeSessionScene)
  uint64_t cost_bytes = 0;       // what it counts against the cache's bound
};

struct HotArtifactsStats {
  uint64_t hits = 0;       // kept or held entries handed out
  uint64_t loads = 0;      // entries made (the store read, the plan, the scene)
  uint64_t evictions = 0;  // entries the bound pushed out of the LRU
  uint64_t bytes = 0;      // kept now (cost_bytes summed)
  uint64_t entries = 0;    // kept now
};

class HotArtifacts {
 public:
  using Entry = std::shared_ptr<const HotArtifact>;
  using Loader = std::function<StatusOr<std::vector<uint8_t>>()>;

  explicit HotArtifacts(uint64_t max_bytes) : max_bytes_(max_bytes) {}

  // The entry of artifact `sha256` planned from `layout_json`: kept, held by
  // a session, or made from `load()` (its error, or the plan's or the
  // scene's, is returned and nothing is kept).
  StatusOr<Entry> Get(const std::string& sha256, const std::string& layout_json, const Loader& load);

  HotArtifactsStats stats() const;

 private:
  struct Kept {
    Entry entry;
    std::list<std::string>::iterator lru;  // its place in lru_
  };
  // Under mutex_: the kept or held entry of `sha256` (null: none), moved to
  // the front of the LRU when kept.
  Entry FindLocked(const std::string& sha256);
  // Under mutex_: keep `entry` at the front, then evict down to the bound.
  void KeepLocked(const Entry& entry);

  const uint64_t max_bytes_;
  mutable std::mutex mutex_;
  std::list<std::string> lru_;                       // most recently used first
  std::map<std::string, Kept> kept_;                 // within the bound
  std::map<std::string, std::weak_ptr<const HotArtifact>> held_;  // evicted or too large, while sessions hold them
  HotArtifactsStats stats_;
};

// An entry made from `bytes` (the store's checked read): the plan of every
// refinement and the scene; DataLoss when the layout does not fit them.
StatusOr<std::shared_ptr<HotArtifact>> MakeHotArtifact(const std::string& sha256, const std::string& layout_json,
                                                       std::vector<uint8_t> bytes);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_HOT_ARTIFACTS_H_
