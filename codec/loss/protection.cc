#include "codec/loss/protection.h"

#include <algorithm>
#include <cmath>

namespace meshstream {
namespace {

// Unknown or NaN harm counts as large.
double HarmOf(const std::vector<double>& harm, size_t i) {
  if (i >= harm.size() || std::isnan(harm[i])) return 1.0;
  return harm[i];
}

}  // namespace

std::vector<uint32_t> ChooseParity(const std::vector<double>& harm, const std::vector<uint32_t>& reliable,
                                   size_t refinements) {
  std::vector<uint8_t> on_cut(refinements, 0);
  for (uint32_t r : reliable) {
    if (r < refinements) on_cut[r] = 1;
  }
  std::vector<uint32_t> out;
  for (size_t i = 0; i < refinements; ++i) {
    if (!on_cut[i] && HarmOf(harm, i) > kHarmTarget) out.push_back(static_cast<uint32_t>(i));
  }
  return out;
}

std::vector<uint8_t> ProtectionTiers(const std::vector<uint32_t>& parity, const std::vector<double>& harm,
                                     size_t refinements) {
  std::vector<uint8_t> tiers(refinements, kUnprotected);
  for (uint32_t r : parity) {
    if (r < refinements) tiers[r] = HarmOf(harm, r) > kHarmWorst ? kStrongParity : kParity;
  }
  return tiers;
}

}  // namespace meshstream
