#include "services/streaming/session_plan.h"

#include <algorithm>
#include <utility>

namespace meshstream {

StatusOr<SessionPlan> PlanSession(const std::vector<uint8_t>& artifact, const std::string& layout_json,
                                  int32_t max_level) {
  auto layout = ParseStreamLayout(layout_json);
  if (!layout.ok()) return DataLoss("the version's stream layout: " + layout.status().message());
  if (layout->file_bytes != artifact.size()) {
    return DataLoss("the stream layout describes " + std::to_string(layout->file_bytes) +
                    " bytes, the artifact has " + std::to_string(artifact.size()));
  }
  SessionPlan plan;
  std::vector<StreamBlocks> blocks;
  for (const PrimitiveLayout& entry : layout->primitives) {
    auto located = LocateStreamBlocks(artifact.data(), artifact.size(), entry);
    if (!located.ok()) return located.status().WithContext("stream " + std::to_string(entry.stream));
    PlannedPrimitive p;
    p.stream = entry.stream;
    p.mesh = entry.mesh;
    p.mesh_primitive = entry.primitive;
    p.header = located->header;
    p.base = located->base;
    const uint32_t available = static_cast<uint32_t>(located->control.size());
    p.refinements = max_level < 0 ? available : std::min(available, static_cast<uint32_t>(max_level));
    plan.reliable_bytes += p.header.length + p.base.length;
    plan.levels = std::max(plan.levels, p.refinements);
    plan.primitives.push_back(p);
    blocks.push_back(std::move(located).value());
  }
  for (uint32_t level = 0; level < plan.levels; ++level) {
    for (uint32_t i = 0; i < plan.primitives.size(); ++i) {
      if (level >= plan.primitives[i].refinements) continue;
      PlannedRefinement r;
      r.primitive = i;
      r.refinement = level;
      r.control = blocks[i].control[level];
      r.datagrams = blocks[i].datagrams[level];
      plan.reliable_bytes += r.control.length;
      for (const ByteRange& d : r.datagrams) plan.unreliable_bytes += d.length;
      plan.refinements.push_back(std::move(r));
    }
  }
  return plan;
}

}  // namespace meshstream
