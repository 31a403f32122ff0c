#include "codec/progressive/scene_levels.h"

#include <algorithm>
#include <limits>

namespace meshstream {

uint32_t SceneLevels::At(size_t primitive, uint32_t level) const {
  if (primitive >= applied.size() || level == 0 || applied[primitive].empty()) return 0;
  const std::vector<uint32_t>& a = applied[primitive];
  return a[std::min<size_t>(level, a.size()) - 1];
}

namespace {

bool ErrorsFit(const std::vector<uint32_t>& refinements, const std::vector<std::vector<double>>& errors) {
  if (errors.size() != refinements.size()) return false;
  for (size_t p = 0; p < refinements.size(); ++p) {
    if (errors[p].size() != static_cast<size_t>(refinements[p]) + 1) return false;
  }
  return true;
}

// Each primitive's count at every level, from the order (each level a prefix).
void CountLevels(SceneLevels& s, size_t primitives) {
  s.applied.assign(primitives, std::vector<uint32_t>(s.levels, 0));
  std::vector<uint32_t> count(primitives, 0);
  size_t next = 0;
  for (uint32_t level = 1; level <= s.levels; ++level) {
    for (; next < s.order.size() && s.order[next].level == level; ++next) ++count[s.order[next].primitive];
    for (size_t p = 0; p < primitives; ++p) s.applied[p][level - 1] = count[p];
  }
}

}  // namespace

SceneLevels ScheduleSceneLevels(const std::vector<uint32_t>& refinements,
                                const std::vector<std::vector<double>>& errors) {
  SceneLevels s;
  uint64_t total = 0;
  for (uint32_t r : refinements) {
    s.levels = std::max(s.levels, r);
    total += r;
  }
  if (!ErrorsFit(refinements, errors)) {
    for (uint32_t level = 1; level <= s.levels; ++level) {
      for (size_t p = 0; p < refinements.size(); ++p) {
        if (level <= refinements[p]) s.order.push_back({static_cast<uint32_t>(p), level - 1, level});
      }
    }
    CountLevels(s, refinements.size());
    return s;
  }
  struct Item {
    double key;
    uint32_t primitive, refinement;
  };
  std::vector<Item> items;
  items.reserve(total);
  for (size_t p = 0; p < refinements.size(); ++p) {
    // The running minimum, so that a primitive's refinements keep their
    // order even where its errors (against the contract) grow.
    double floor = std::numeric_limits<double>::infinity();
    for (uint32_t k = 0; k < refinements[p]; ++k) {
      floor = std::min(floor, errors[p][k]);
      items.push_back({floor, static_cast<uint32_t>(p), k});
    }
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    if (a.key != b.key) return a.key > b.key;
    if (a.primitive != b.primitive) return a.primitive < b.primitive;
    return a.refinement < b.refinement;
  });
  // Level L ends after ceil(L x T / N) refinements of the order.
  uint32_t level = 1;
  for (size_t i = 0; i < items.size(); ++i) {
    while (i >= (uint64_t{level} * total + s.levels - 1) / s.levels) ++level;
    s.order.push_back({items[i].primitive, items[i].refinement, level});
  }
  CountLevels(s, refinements.size());
  return s;
}

}  // namespace meshstream
