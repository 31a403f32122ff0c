#include "codec/progressive/refinement.h"

#include <algorithm>


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

// How many of lanes[0 .. width) (width 8 or 16) lie below v: a reduction
// without branches, which the compiler vectorizes.
uint32_t CountBelow(const uint32_t* lanes, size_t width, uint32_t v) {
  uint32_t below = 0;
  for (size_t i = 0; i < width; ++i) below += lanes[i] < v ? 1u : 0u;
  return below;
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
  // The wing is the first ring entry with exactly wings[0] entries below it
  // (RankInRing).
  const uint32_t rank = wings[0];
  if (rank >= d) return false;  // at most d - 1 entries lie below any entry
  const uint32_t* x = ring.data();
  size_t k = d;
  if (d <= 16) {
    // Small rings (nearly all): each entry's rank counted without branches
    // against 8 or 16 entries (UINT32_MAX pads: never below
    // anything); the first entry of that rank wins.
    uint32_t lanes[16];
    for (size_t i = 0; i < 16; ++i) lanes[i] = i < d ? x[i] : UINT32_MAX;
    const size_t width = d <= 8 ? 8 : 16;
    for (size_t at = 0; at < d && k == d; ++at) {
      if (CountBelow(lanes, width, lanes[at]) == rank) k = at;
    }
  } else {
    // Large rings, O(valence): only the wings[0]-th smallest value v can
    // have that rank, and only when no entry before it in sorted order
    // equals it; the wing is then v's first position.
    std::vector<uint32_t> sorted(ring);
    std::nth_element(sorted.begin(), sorted.begin() + rank, sorted.end());
    const uint32_t v = sorted[rank];
    if (std::find(sorted.begin(), sorted.begin() + rank, v) != sorted.begin() + rank) return false;
    k = static_cast<size_t>(std::find(ring.begin(), ring.end(), v) - ring.begin());
  }
  if (k == d) return false;
  *a_at = k;
  *b_at = (k + wings[1]) % d;
  return true;
}

}  // namespace meshstream
