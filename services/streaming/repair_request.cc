#include "services/streaming/repair_request.h"

#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>

namespace meshstream {

StatusOr<std::vector<ByteRange>> RepairDatagrams(const SessionPlan& plan, const std::vector<RepairItem>& items) {
  std::map<std::pair<uint32_t, uint32_t>, const PlannedRefinement*> by_key;
  for (const PlannedRefinement& r : plan.refinements) {
    by_key[{plan.primitives[r.primitive].stream, r.refinement}] = &r;
  }
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> seen;
  std::vector<ByteRange> out;
  for (size_t i = 0; i < items.size(); ++i) {
    const RepairItem& item = items[i];
    const std::string where = "repair.items[" + std::to_string(i) + "]";
    auto it = by_key.find({item.stream, item.refinement});
    if (it == by_key.end()) {
      return InvalidArgument(where + ": primitive " + std::to_string(item.stream) + " refinement " +
                             std::to_string(item.refinement) + " is not part of this session");
    }
    const PlannedRefinement& r = *it->second;
    for (uint32_t k : item.datagrams) {
      if (k >= r.datagrams.size()) {
        return InvalidArgument(where + ": datagram " + std::to_string(k) + " does not exist (the refinement has " +
                               std::to_string(r.datagrams.size()) + ")");
      }
      if (seen.insert({item.stream, item.refinement, k}).second) out.push_back(r.datagrams[k]);
    }
  }
  return out;
}

}  // namespace meshstream
