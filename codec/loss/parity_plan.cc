#include "codec/loss/parity_plan.h"

#include <algorithm>
#include <cmath>

namespace meshstream {
namespace {

double Clamp01(double v) { return std::isnan(v) ? 0.0 : std::min(1.0, std::max(0.0, v)); }

}  // namespace

std::vector<ParityBlockPlan> PlanParityBlocks(const ProgressiveStream& stream, size_t refinements,
                                              const std::vector<uint8_t>& protect, const ParityPlanOptions& options) {
  std::vector<ParityBlockPlan> blocks;
  const size_t limit = std::min({refinements, stream.datagrams.size(), protect.size()});
  const uint32_t depth = std::max<uint32_t>(1, options.depth);
  // With depth > 1 a group of up to `depth` blocks' members is formed first,
  // then dealt round-robin (each block still at most block_datagrams).
  const uint32_t most = depth * std::max<uint32_t>(1, std::min<uint32_t>(options.block_datagrams, kParityMaxRows - 1));
  const uint32_t span = std::max<uint32_t>(1, options.max_span);
  ParityBlockPlan open;
  for (uint32_t r = 0; r < limit; ++r) {
    if (!protect[r]) continue;
    for (uint32_t d = 0; d < stream.datagrams[r].size(); ++d) {
      if (!open.members.empty() && (open.members.size() >= most || r - open.first_refinement() >= span)) {
        blocks.push_back(std::move(open));
        open = {};
      }
      // A block's tier is its strongest refinement's: a change of tier does
      // not cut a block short (a small block needs more parity per member).
      open.tier = open.members.empty() ? protect[r] : std::max(open.tier, protect[r]);
      open.members.push_back({r, d});
    }
  }
  if (!open.members.empty()) blocks.push_back(std::move(open));
  if (depth == 1) return blocks;
  std::vector<ParityBlockPlan> dealt;
  for (const ParityBlockPlan& group : blocks) {
    const uint32_t ways = std::min<uint32_t>(depth, static_cast<uint32_t>(group.members.size()));
    std::vector<ParityBlockPlan> part(ways);
    for (size_t i = 0; i < group.members.size(); ++i) part[i % ways].members.push_back(group.members[i]);
    for (ParityBlockPlan& p : part) {
      p.tier = group.tier;
      p.stride = ways;
      dealt.push_back(std::move(p));
    }
  }
  return dealt;
}

double WeightedFailure(const std::vector<uint32_t>& weights, uint32_t m, double loss, double burst) {
  loss = Clamp01(loss);
  uint64_t total = 0;
  for (uint32_t w : weights) total += w;
  if (total <= m || loss <= 0.0) return 0.0;
  if (loss >= 1.0) return 1.0;
  // good[j] / bad[j]: probability of j rows lost so far (column m + 1
  // gathers "more than m") with the chain good (delivers) or bad (loses) for
  // the next datagram. Independent losses: the next state ignores this one.
  double g2b = loss, b2g = 1.0 - loss;
  if (burst > 1.0 && std::isfinite(burst)) {
    g2b = loss / (burst * (1.0 - loss));
    b2g = 1.0 / burst;
    if (g2b > 1.0) {
      g2b = 1.0;
      b2g = (1.0 - loss) / loss;
    }
  }
  std::vector<double> good(m + 2, 0.0), bad(m + 2, 0.0), next_good(m + 2), next_bad(m + 2);
  good[0] = 1.0 - loss;
  bad[0] = loss;
  for (uint32_t w : weights) {
    std::fill(next_good.begin(), next_good.end(), 0.0);
    std::fill(next_bad.begin(), next_bad.end(), 0.0);
    for (uint32_t j = 0; j <= m + 1; ++j) {
      const uint32_t lost = static_cast<uint32_t>(std::min<uint64_t>(uint64_t(j) + w, m + 1));
      next_good[j] += good[j] * (1.0 - g2b);
      next_bad[j] += good[j] * g2b;
      next_good[lost] += bad[j] * b2g;
      next_bad[lost] += bad[j] * (1.0 - b2g);
    }
    good.swap(next_good);
    bad.swap(next_bad);
  }
  return good[m + 1] + bad[m + 1];
}

double BlockFailure(uint32_t n, uint32_t m, double loss, double burst) {
  return WeightedFailure(std::vector<uint32_t>(n, 1), m, loss, burst);
}

ParityShape ShapeFor(const std::vector<uint32_t>& lengths, double loss, double burst,
                     const ParityPlanOptions& options, uint8_t tier, uint32_t stride) {
  ParityShape shape;
  loss = Clamp01(loss);
  if (lengths.empty() || loss <= 0.0) return shape;
  const uint32_t max_k = std::max<uint32_t>(1, std::min<uint32_t>(options.max_data_rows, kParityMaxRows - 1));
  shape.symbol_size = SymbolSizeFor(lengths, max_k);
  uint64_t k = 0;
  std::vector<uint32_t> weights;
  for (uint32_t l : lengths) {
    if (!weights.empty()) weights.insert(weights.end(), std::max<uint32_t>(1, stride) - 1, 0u);  // the others' datagrams
    weights.push_back(static_cast<uint32_t>(SymbolsOf(l, shape.symbol_size)));
    k += weights.back();
  }
  if (k >= kParityMaxRows) return shape;  // more members than rows allow: left unprotected
  shape.k = static_cast<uint32_t>(k);
  shape.per_datagram = RowsPerDatagram(shape.symbol_size, lengths.size(), options.packet_bytes);
  const double failure = tier >= 2 ? options.strong_failure : options.block_failure;
  const double rate = std::isnan(options.max_rate) ? 0.0 : std::max(0.0, options.max_rate);
  const uint32_t cap = std::min<uint32_t>(static_cast<uint32_t>(kParityMaxRows) - shape.k,
                                          static_cast<uint32_t>(std::ceil(rate * shape.k)));
  const size_t members = weights.size();
  for (uint32_t m = 0; m <= cap; ++m) {
    // The block's datagrams: members, then ceil(m / c) parity datagrams.
    weights.resize(members);
    for (uint32_t left = m; left > 0;) {
      const uint32_t c = std::min(left, shape.per_datagram);
      weights.push_back(c);
      left -= c;
    }
    shape.m = m;
    if (WeightedFailure(weights, m, loss, burst) <= failure) break;
  }
  return shape;
}

}  // namespace meshstream
