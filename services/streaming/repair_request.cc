#include "services/streaming/repair_request.h"

#include <map>
#include <string>
#include <utility>

namespace meshstream {

StatusOr<std::vector<ByteRange>> RepairDatagrams(const SessionPlan& plan, const std::vector<RepairItem>& items) {
  if (items.size() > plan.refinements.size()) {
    return InvalidArgument("repair: " + std::to_string(items.size()) + " items, more than the " +
                           std::to_string(plan.refinements.size()) + " refinements of this session");
  }
  // Per refinement of the plan, where its datagrams' bits start in `seen`:
  // a named ordinal costs a lookup, not an insert into a tree (the ordinals
  // are bounded only by the message size).
  std::map<std::pair<uint32_t, uint32_t>, size_t> by_key;
  std::vector<size_t> first_bit(plan.refinements.size() + 1, 0);
  for (size_t j = 0; j < plan.refinements.size(); ++j) {
    const PlannedRefinement& r = plan.refinements[j];
    by_key[{plan.primitives[r.primitive].stream, r.refinement}] = j;
    first_bit[j + 1] = first_bit[j] + r.datagrams.size();
  }
  std::vector<bool> seen(first_bit.back(), false);
  std::vector<ByteRange> out;
  for (size_t i = 0; i < items.size(); ++i) {
    const RepairItem& item = items[i];
    auto where = [i] { return "repair.items[" + std::to_string(i) + "]"; };  // for a refusal only
    auto it = by_key.find({item.stream, item.refinement});
    if (it == by_key.end()) {
      return InvalidArgument(where() + ": primitive " + std::to_string(item.stream) + " refinement " +
                             std::to_string(item.refinement) + " is not part of this session");
    }
    const PlannedRefinement& r = plan.refinements[it->second];
    for (uint32_t k : item.datagrams) {
      if (k >= r.datagrams.size()) {
        return InvalidArgument(where() + ": datagram " + std::to_string(k) + " does not exist (the refinement has " +
                               std::to_string(r.datagrams.size()) + ")");
      }
      const size_t bit = first_bit[it->second] + k;
      if (seen[bit]) continue;
      seen[bit] = true;
      out.push_back(r.datagrams[k]);
    }
  }
  return out;
}

}  // namespace meshstream
