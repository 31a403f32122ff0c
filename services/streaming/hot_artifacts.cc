#include "services/streaming/hot_artifacts.h"

#include <utility>

#include "services/streaming/session_scene.h"

namespace meshstream {

namespace {

// What an entry's plan holds beyond its struct: the ranges of every
// refinement and the per-primitive tables (an estimate, by their sizes).
uint64_t PlanBytes(const SessionPlan& plan) {
  uint64_t bytes = sizeof(SessionPlan);
  for (const PlannedPrimitive& p : plan.primitives) {
    bytes += sizeof(PlannedPrimitive) + p.refinement_bytes.size() * sizeof(uint64_t) +
             (p.delivery.ranking.size() + p.delivery.reliable.size()) * sizeof(uint32_t) + p.draco_attributes.size() * 64;
  }
  for (const PlannedRefinement& r : plan.refinements) {
    bytes += sizeof(PlannedRefinement) + r.datagrams.size() * sizeof(ByteRange);
  }
  return bytes;
}

}  // namespace

StatusOr<std::shared_ptr<HotArtifact>> MakeHotArtifact(const std::string& sha256, const std::string& layout_json,
                                                       std::vector<uint8_t> bytes) {
  auto hot = std::make_shared<HotArtifact>();
  hot->sha256 = sha256;
  hot->layout_json = layout_json;
  hot->bytes = std::move(bytes);
  MS_ASSIGN_OR_RETURN(hot->plan, PlanSession(hot->bytes, layout_json, -1));
  MS_ASSIGN_OR_RETURN(hot->reliable_plan, PlanSession(hot->bytes, layout_json, -1, /*reliable=*/true));
  std::vector<std::pair<uint32_t, uint32_t>> refined;
  for (const PlannedPrimitive& p : hot->plan.primitives) refined.emplace_back(p.mesh, p.mesh_primitive);
  MS_ASSIGN_OR_RETURN(hot->scene, MakeSessionScene(hot->bytes, refined));
  hot->cost_bytes = sizeof(HotArtifact) + hot->sha256.size() + hot->layout_json.size() + hot->bytes.size() +
                    hot->scene.size() + PlanBytes(hot->plan) + PlanBytes(hot->reliable_plan);
  return hot;
}

HotArtifacts::Entry HotArtifacts::FindLocked(const std::string& sha256) {
  auto kept = kept_.find(sha256);
  if (kept != kept_.end()) {
    lru_.splice(lru_.begin(), lru_, kept->second.lru);
    return kept->second.entry;
  }
  auto held = held_.find(sha256);
  if (held == held_.end()) return nullptr;
  Entry entry = held->second.lock();
  if (!entry) {
    held_.erase(held);
    return nullptr;
  }
  // A running session held it: kept again, as used now.
  held_.erase(held);
  KeepLocked(entry);
  return entry;
}

void HotArtifacts::KeepLocked(const Entry& entry) {
  if (entry->cost_bytes > max_bytes_) {
    held_[entry->sha256] = entry;  // too large to keep: shared while sessions hold it
    return;
  }
  lru_.push_front(entry->sha256);
  kept_[entry->sha256] = Kept{entry, lru_.begin()};
  stats_.bytes += entry->cost_bytes;
  while (stats_.bytes > max_bytes_ && !lru_.empty()) {
    auto victim = kept_.find(lru_.back());
    stats_.bytes -= victim->second.entry->cost_bytes;
    held_[victim->first] = victim->second.entry;
    kept_.erase(victim);
    lru_.pop_back();
    ++stats_.evictions;
  }
  // Held entries no session holds any more go here, so the map stays as small as the running set.
  for (auto it = held_.begin(); it != held_.end();) it = it->second.expired() ? held_.erase(it) : std::next(it);
}

StatusOr<HotArtifacts::Entry> HotArtifacts::Get(const std::string& sha256, const std::string& layout_json,
                                                  const Loader& load) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (Entry entry = FindLocked(sha256)) {
      if (entry->layout_json == layout_json) {
        ++stats_.hits;
        return entry;
      }
    }
  }
  auto bytes = load();
  if (!bytes.ok()) return bytes.status();
  auto made = MakeHotArtifact(sha256, layout_json, std::move(bytes).value());
  if (!made.ok()) return made.status();
  Entry entry = std::move(made).value();
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.loads;
  if (Entry other = FindLocked(sha256)) {
    if (other->layout_json == layout_json) return other;  // made at once by another session: share the first
    return entry;                                          // another layout keeps the slot; this one is not kept
  }
  KeepLocked(entry);
  return entry;
}

HotArtifactsStats HotArtifacts::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  HotArtifactsStats s = stats_;
  s.entries = kept_.size();
  return s;
}

}  // namespace meshstream
