#include "codec/loss/reliable_cut.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace meshstream {

std::vector<double> RefinementImportance(const ProgressiveMesh& mesh) {
  const size_t levels = mesh.refinements.size();
  std::vector<double> importance(levels, 0.0);
  if (levels == 0) return importance;
  const Refinement& last = mesh.refinements.back();
  const size_t final_vertices = static_cast<size_t>(last.vertices_before) + last.split_count();
  // descendants[v]: final vertices that descend from vertex v at the level
  // being visited, walked from the finest refinement back to the coarsest.
  std::vector<uint64_t> descendants(final_vertices, 1);
  for (size_t i = levels; i-- > 0;) {
    const Refinement& r = mesh.refinements[i];
    if (r.position_delta.size() != r.split_count()) return std::vector<double>(levels, 0.0);
    double sum = 0;
    for (size_t j = r.split_count(); j-- > 0;) {
      const uint32_t w = r.split_vertices[j];
      const size_t born = static_cast<size_t>(r.vertices_before) + j;
      if (w >= final_vertices || born >= final_vertices) return std::vector<double>(levels, 0.0);
      const uint64_t subtree = descendants[w] + descendants[born];
      descendants[w] = subtree;
      const Vec3i& d = r.position_delta[j];
      const double length = std::sqrt(static_cast<double>(d[0]) * d[0] + static_cast<double>(d[1]) * d[1] +
                                      static_cast<double>(d[2]) * d[2]);
      sum += length * static_cast<double>(subtree);
    }
    importance[i] = sum;
  }
  const double total = std::accumulate(importance.begin(), importance.end(), 0.0);
  if (total > 0) {
    for (double& v : importance) v /= total;
  }
  return importance;
}

std::vector<uint32_t> RankRefinements(const std::vector<double>& importance,
                                      const std::vector<uint64_t>& datagram_bytes) {
  std::vector<uint32_t> order;
  if (importance.size() != datagram_bytes.size()) return order;
  order.reserve(importance.size());
  for (size_t i = 0; i < importance.size(); ++i) {
    if (datagram_bytes[i] > 0 && std::isfinite(importance[i]) && importance[i] > 0) {
      order.push_back(static_cast<uint32_t>(i));
    }
  }
  // Importance per byte, highest first; cross-multiplied (no division), the
  // coarser refinement first on a tie (a stable sort of ascending indices).
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const long double da = static_cast<long double>(importance[a]) * static_cast<long double>(datagram_bytes[b]);
    const long double db = static_cast<long double>(importance[b]) * static_cast<long double>(datagram_bytes[a]);
    return da > db;
  });
  return order;
}

std::vector<uint32_t> CutForBudget(const std::vector<uint32_t>& ranking, const std::vector<uint64_t>& datagram_bytes,
                                   uint64_t budget_bytes) {
  std::vector<uint32_t> cut;
  uint64_t used = 0;
  for (uint32_t i : ranking) {
    if (i >= datagram_bytes.size() || datagram_bytes[i] > budget_bytes - used) break;
    used += datagram_bytes[i];
    cut.push_back(i);
  }
  std::sort(cut.begin(), cut.end());
  // A ranking that names a refinement twice would repeat it here.
  cut.erase(std::unique(cut.begin(), cut.end()), cut.end());
  return cut;
}

std::vector<uint32_t> CutForShare(const std::vector<uint32_t>& ranking, const std::vector<uint64_t>& datagram_bytes,
                                  uint64_t stream_bytes, double share) {
  if (!(share > 0)) return {};
  return CutForBudget(ranking, datagram_bytes, static_cast<uint64_t>(share * static_cast<double>(stream_bytes)));
}

double ReliableShareForLoss(double encoded_share, double loss) {
  if (!(encoded_share > 0)) return 0.0;
  if (!(loss > 0)) loss = 0;
  const double scaled = encoded_share * std::max(0.5, loss / kReferenceLoss);
  return std::min(std::max(kMaxReliableShare, encoded_share), scaled);
}

}  // namespace meshstream
