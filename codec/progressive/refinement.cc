#include "codec/progressive/refinement.h"

namespace meshstream {

std::vector<uint32_t> ProgressiveMesh::level_vertices() const {
  std::vector<uint32_t> out = {static_cast<uint32_t>(base.vertex_count())};
  for (const Refinement& r : refinements) out.push_back(out.back() + static_cast<uint32_t>(r.split_count()));
  return out;
}

namespace {

// Neighbours of w with a smaller id than ring[at] (a closed fan's ring holds
// every neighbour once, so this is its rank by id).
size_t RankInRing(const std::vector<uint32_t>& ring, size_t at) {
  size_t rank = 0;
  for (uint32_t x : ring) rank += x < ring[at] ? 1 : 0;
  return rank;
}

}  // namespace

std::array<uint16_t, 2> WingsOf(const std::vector<uint32_t>& ring, size_t a_at, size_t b_at) {
  const size_t d = ring.size();
  return {static_cast<uint16_t>(RankInRing(ring, a_at)), static_cast<uint16_t>((b_at + d - a_at) % d)};
}

bool WingPositions(const std::vector<uint32_t>& ring, const std::array<uint16_t, 2>& wings, size_t* a_at,
                   size_t* b_at) {
  const size_t d = ring.size();
  if (wings[1] == 0 || wings[1] >= d) return false;
  for (size_t k = 0; k < d; ++k) {
    if (RankInRing(ring, k) == wings[0]) {
      *a_at = k;
      *b_at = (k + wings[1]) % d;
      return true;
    }
  }
  return false;
}

}  // namespace meshstream
