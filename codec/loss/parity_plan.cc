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
  const uint32_t most = std::max<uint32_t>(1, std::min<uint32_t>(options.block_datagrams, kParityMaxRows - 1));
  const uint32_t span = std::max<uint32_t>(1, options.max_span);
  ParityBlockPlan open;
  for (uint32_t r = 0; r < limit; ++r) {
    if (!protect[r]) continue;
    for (uint32_t d = 0; d < stream.datagrams[r].size(); ++d) {
      if (!open.members.empty() &&
          (open.members.size() >= most || r - open.first_refinement() >= span || open.tier != protect[r])) {
        blocks.push_back(std::move(open));
        open = {};
      }
      open.tier = protect[r];
      open.members.push_back({r, d});
    }
  }
  if (!open.members.empty()) blocks.push_back(std::move(open));
  return blocks;
}

double BlockFailure(uint32_t n, uint32_t m, double loss, double burst) {
  loss = Clamp01(loss);
  if (m >= n || loss <= 0.0) return 0.0;
  if (loss >= 1.0) return 1.0;
  // dist[s][j]: probability of j losses so far with the chain in state s
  // (0 good, 1 bad) for the next datagram. Independent losses: one state.
  double g2b = loss, b2g = 1.0 - loss;  // independent: the next state ignores this one
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
  // Column m + 1 gathers "more than m".
  for (uint32_t i = 0; i < n; ++i) {
    std::fill(next_good.begin(), next_good.end(), 0.0);
    std::fill(next_bad.begin(), next_bad.end(), 0.0);
    for (uint32_t j = 0; j <= m + 1; ++j) {
      // Good: delivered; bad: lost.
      const uint32_t lost = std::min(j + 1, m + 1);
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

uint32_t ParityRowsFor(uint32_t k, double loss, double burst, const ParityPlanOptions& options, uint8_t tier) {
  const double failure = tier >= 2 ? options.strong_failure : options.block_failure;
  loss = Clamp01(loss);
  if (k == 0 || k >= kParityMaxRows || loss <= 0.0) return 0;
  const double rate = std::isnan(options.max_rate) ? 0.0 : std::max(0.0, options.max_rate);
  const uint32_t cap = std::min<uint32_t>(static_cast<uint32_t>(kParityMaxRows) - k,
                                          static_cast<uint32_t>(std::ceil(rate * k)));
  for (uint32_t m = 0; m < cap; ++m) {
    if (BlockFailure(k + m, m, loss, burst) <= failure) return m;
  }
  return cap;
}

}  // namespace meshstream
