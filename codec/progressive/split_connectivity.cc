#include "codec/progressive/split_connectivity.h"

#include <algorithm>

namespace meshstream {

uint32_t SplitConnectivity::Take(uint32_t entries) {
  // The pool's tail beyond pool_end_ is spare room, grown geometrically:
  // taking entries is a bump of pool_end_, with no per-slot resize.
  const size_t needed = size_t{pool_end_} + entries;
  if (needed > pool_.size()) {
    size_t size = std::max(needed, 2 * pool_.size());
    if (needed <= pool_.capacity()) size = std::min(size, pool_.capacity());  // what Reserve set aside
    pool_.resize(size);
  }
  const uint32_t offset = pool_end_;
  pool_end_ = static_cast<uint32_t>(needed);
  return offset;
}

uint32_t SplitConnectivity::NewSlot(uint32_t capacity) {
  Slot slot;
  slot.offset = Take(capacity);
  slot.capacity = capacity;
  slots_.push_back(slot);
  return static_cast<uint32_t>(slots_.size() - 1);
}

void SplitConnectivity::Grow(uint32_t v, uint32_t needed) {
  Slot& slot = slots_[v];
  uint32_t capacity = std::max<uint32_t>(kMinCapacity, 2 * slot.capacity);
  while (capacity < needed) capacity *= 2;
  const uint32_t offset = Take(capacity);
  std::copy(pool_.begin() + slot.offset, pool_.begin() + slot.offset + slot.count, pool_.begin() + offset);
  slot.offset = offset;
  slot.capacity = capacity;
}

void SplitConnectivity::Append(uint32_t v, uint32_t face) {
  Slot& slot = slots_[v];
  if (slot.count == slot.capacity) Grow(v, slot.count + 1);
  pool_[slot.offset + slot.count++] = face;
}

Status SplitConnectivity::Reset(uint32_t vertex_count, const std::vector<uint32_t>& indices) {
  if (indices.size() % 3 != 0) return InvalidInput("index count is not a multiple of 3");
  faces_.clear();
  faces_.reserve(indices.size() / 3);
  std::vector<uint32_t> valence(vertex_count, 0);
  for (size_t i = 0; i < indices.size(); ++i) {
    if (indices[i] >= vertex_count) {
      return InvalidInput("face " + std::to_string(i / 3) + " names vertex " + std::to_string(indices[i]));
    }
    ++valence[indices[i]];
  }
  pool_.clear();
  pool_end_ = 0;
  slots_.clear();
  slots_.reserve(vertex_count);
  for (uint32_t v = 0; v < vertex_count; ++v) NewSlot(std::max<uint32_t>(kMinCapacity, valence[v] + 2));
  for (size_t i = 0; i < indices.size(); i += 3) {
    const Face f = {indices[i], indices[i + 1], indices[i + 2]};
    const uint32_t id = static_cast<uint32_t>(faces_.size());
    faces_.push_back(f);
    Append(f[0], id);
    if (f[1] != f[0]) Append(f[1], id);
    if (f[2] != f[0] && f[2] != f[1]) Append(f[2], id);
  }
  return Status::Ok();
}

namespace {

// The walk of a ring of n <= W triangles, (x, y) in xs and ys: every step
// compares the current vertex with all W x's (`pad`, which no x equals,
// fills the lanes beyond n), without a branch per lane.
template <size_t W>
bool WalkSmallRing(const uint32_t* xs, const uint32_t* ys, size_t n, const uint32_t* fs, uint32_t pad,
                   std::vector<uint32_t>& ring, std::vector<uint32_t>& ring_faces) {
  uint32_t lanes[W];
  for (size_t i = 0; i < W; ++i) lanes[i] = i < n ? xs[i] : pad;
  ring.resize(n);
  ring_faces.resize(n);
  uint32_t* out = ring.data();
  uint32_t* out_faces = ring_faces.data();
  const uint32_t start = lanes[0];
  uint32_t cur = start;
  size_t step = 0;
  for (; step < n; ++step) {
    // Two sums over all W lanes (reductions the compiler vectorizes): how
    // many x's are cur, and the sum of their indices, which is the index
    // when there is exactly one.
    uint32_t hits = 0, found = 0;
    for (size_t i = 0; i < W; ++i) {
      const uint32_t match = lanes[i] == cur ? 1u : 0u;
      hits += match;
      found += match * static_cast<uint32_t>(i);
    }
    // None: an open fan (boundary); two or more: not a fan.
    if (hits != 1) break;
    out[step] = cur;
    out_faces[step] = fs[found];
    cur = ys[found];
    if (cur == start) {
      if (step + 1 == n) return true;
      ++step;
      break;
    }
  }
  ring.resize(step);  // not a closed fan: the steps walked
  ring_faces.resize(step);
  return false;
}

}  // namespace

bool SplitConnectivity::CyclicRing(uint32_t w, std::vector<uint32_t>& ring, RingWalk& walk) const {
  ring.clear();
  walk.faces.clear();
  const Slot slot = slots_[w];
  const size_t n = slot.count;
  if (n < 3) return false;
  const uint32_t* fs = pool_.data() + slot.offset;
  // (x, y) for every triangle (w, x, y): the x's, then the y's. The
  // triangles are gathered first, with no branch on what they hold, so that
  // their loads (they often miss the cache) overlap.
  // Grown, never shrunk: a resize per walk would zero what is written next.
  if (walk.xy.size() < 2 * n) walk.xy.resize(2 * n);
  uint32_t* xs = walk.xy.data();
  uint32_t* ys = xs + n;
  bool bad = false;
  static constexpr uint8_t kNext[4] = {1, 2, 0, 1};
  for (size_t i = 0; i < n; ++i) {
    const uint32_t* f = faces_[fs[i]].data();
    // RotateTo(f, w) by index arithmetic (where w sits in a triangle is
    // random, so a branch on it would mispredict): w first, then the other
    // two in order.
    const unsigned at = static_cast<unsigned>(f[0] != w) * (2u - static_cast<unsigned>(f[1] == w));
    const uint32_t x = f[kNext[at]];
    const uint32_t y = f[kNext[at + 1]];
    bad |= (x == w) | (y == w) | (x == y);
    xs[i] = x;
    ys[i] = y;
  }
  if (bad) return false;
  // Follow x -> y. Each step must find exactly one triangle leaving the
  // current vertex, and the walk must close after visiting every triangle
  // (which it can only do when every x is distinct). No x is w, so w pads.
  if (n <= 8) return WalkSmallRing<8>(xs, ys, n, fs, w, ring, walk.faces);
  if (n <= 16) return WalkSmallRing<16>(xs, ys, n, fs, w, ring, walk.faces);
  // Large rings: x -> triangle through an open-addressed table, O(valence).
  size_t bits = 1;
  while ((size_t{1} << bits) < 2 * n) ++bits;
  const size_t mask = (size_t{1} << bits) - 1;
  walk.table.assign(2 * (mask + 1), kEmpty);  // (x, triangle) pairs
  auto home = [bits](uint32_t x) { return static_cast<size_t>((x * 2654435769u) >> (32 - bits)); };
  for (size_t i = 0; i < n; ++i) {
    const uint32_t x = xs[i];
    size_t h = home(x);
    while (walk.table[2 * h + 1] != kEmpty) {
      if (walk.table[2 * h] == x) return false;  // two triangles leave x: not a fan
      h = (h + 1) & mask;
    }
    walk.table[2 * h] = x;
    walk.table[2 * h + 1] = static_cast<uint32_t>(i);
  }
  const uint32_t start = xs[0];
  uint32_t cur = start;
  for (size_t step = 0; step < n; ++step) {
    size_t h = home(cur);
    while (walk.table[2 * h + 1] != kEmpty && walk.table[2 * h] != cur) h = (h + 1) & mask;
    if (walk.table[2 * h + 1] == kEmpty) return false;  // open fan (boundary)
    const uint32_t found = walk.table[2 * h + 1];
    ring.push_back(cur);
    walk.faces.push_back(fs[found]);
    cur = ys[found];
    if (cur == start) return step + 1 == n;
  }
  return false;
}

bool SplitConnectivity::OpenRing(uint32_t w, std::vector<uint32_t>& ring) const {
  ring.clear();
  walk_.faces.clear();
  const Slot slot = slots_[w];
  const size_t n = slot.count;
  if (n == 0) return false;
  const uint32_t* fs = pool_.data() + slot.offset;
  // (x, triangle) sorted by x, and the y's: the start is the one x that is
  // no triangle's y.
  walk_.table.resize(2 * n);
  walk_.xy.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Face r = RotateTo(faces_[fs[i]], w);
    if (r[1] == w || r[2] == w || r[1] == r[2]) return false;
    walk_.table[2 * i] = r[1];
    walk_.table[2 * i + 1] = static_cast<uint32_t>(i);
    walk_.xy[i] = r[2];
  }
  auto* pairs = reinterpret_cast<std::array<uint32_t, 2>*>(walk_.table.data());
  std::sort(pairs, pairs + n);
  for (size_t i = 1; i < n; ++i)
    if (pairs[i][0] == pairs[i - 1][0]) return false;  // two triangles leave one vertex: not a fan
  auto find = [&](uint32_t x) -> const std::array<uint32_t, 2>* {
    const auto* it = std::lower_bound(pairs, pairs + n, std::array<uint32_t, 2>{x, 0});
    return it != pairs + n && (*it)[0] == x ? it : nullptr;
  };
  std::vector<uint32_t>& ys = sorted_ys_;
  ys.assign(walk_.xy.begin(), walk_.xy.end());
  std::sort(ys.begin(), ys.end());
  uint32_t start = kEmpty;
  for (size_t i = 0; i < n; ++i) {
    if (!std::binary_search(ys.begin(), ys.end(), pairs[i][0])) {
      if (start != kEmpty) return false;  // two starts: more than one fan
      start = pairs[i][0];
    }
  }
  if (start == kEmpty) return false;  // closed (or no fan)
  uint32_t cur = start;
  for (size_t step = 0; step < n; ++step) {
    const auto* at = find(cur);
    if (at == nullptr) return false;
    ring.push_back(cur);
    walk_.faces.push_back(fs[(*at)[1]]);
    cur = walk_.xy[(*at)[1]];
  }
  if (find(cur) != nullptr) return false;  // the walk must end where no triangle leaves
  ring.push_back(cur);
  return true;
}

void SplitConnectivity::SortedNeighbours(uint32_t w, std::vector<uint32_t>& out) const {
  out.clear();
  for (uint32_t f : faces_of(w)) {
    for (uint32_t x : faces_[f]) {
      if (x != w) out.push_back(x);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

void SplitConnectivity::Reserve(uint32_t vertices, size_t faces) {
  const size_t extra = vertices > slots_.size() ? vertices - slots_.size() : 0;
  slots_.reserve(vertices);
  faces_.reserve(faces);
  // A split's new vertex takes a slot of kMinCapacity entries (rarely more),
  // and the vertices that gain triangles sometimes move to twice their room:
  // capacity for both keeps the pool from being copied while refining (Take
  // fills it as it goes; nothing is written here).
  pool_.reserve(pool_end_ + extra * (kMinCapacity + kMinCapacity / 2));
}

uint32_t SplitConnectivity::SplitAt(uint32_t w, const uint32_t* ring, const uint32_t* ring_faces, size_t d,
                                    size_t a_at, size_t b_at) {
  const uint32_t a = ring[a_at], b = ring[b_at];
  // Triangles (w, ring[k], ring[k+1]) for k from b up to (not including) a
  // move to n; the others stay with w. Both lists are written in place, in
  // the order the ring walk gives (b .. a for n, a .. b for w, then the two
  // new triangles): the order later rings start from.
  const size_t path = (a_at + d - b_at) % d;
  const uint32_t n = NewSlot(std::max<uint32_t>(kMinCapacity, static_cast<uint32_t>(path) + 4));
  const uint32_t f1 = static_cast<uint32_t>(faces_.size());
  const uint32_t keep = static_cast<uint32_t>(d - path) + 2;  // w's triangles after the split
  if (slots_[w].capacity < keep) Grow(w, keep);
  uint32_t* to_n = pool_.data() + slots_[n].offset;
  uint32_t* to_w = pool_.data() + slots_[w].offset;
  const uint32_t* rf = ring_faces;
  size_t k = b_at;
  for (size_t step = 0; step < path; ++step) {
    const uint32_t f = rf[k];
    Face& t = faces_[f];
    for (uint32_t& y : t) y = y == w ? n : y;
    *to_n++ = f;
    k = k + 1 == d ? 0 : k + 1;
  }
  for (size_t step = path; step < d; ++step) {
    *to_w++ = rf[k];
    k = k + 1 == d ? 0 : k + 1;
  }
  to_n[0] = f1;
  to_n[1] = f1 + 1;
  to_w[0] = f1;
  to_w[1] = f1 + 1;
  slots_[n].count = static_cast<uint32_t>(path) + 2;
  slots_[w].count = keep;
  faces_.push_back({w, n, a});
  faces_.push_back({n, w, b});
  Append(a, f1);
  Append(b, f1 + 1);
  return n;
}

uint32_t SplitConnectivity::SplitOpenAt(uint32_t w, const std::vector<uint32_t>& ring, size_t a_at, bool tail) {
  const uint32_t a = ring[a_at];
  const size_t triangles = ring.size() - 1;
  // Triangle k is (w, ring[k], ring[k + 1]): those at k >= a_at lie after a.
  const size_t moved = tail ? triangles - a_at : a_at;
  const uint32_t n = NewSlot(std::max<uint32_t>(kMinCapacity, static_cast<uint32_t>(moved) + 2));
  const uint32_t f1 = static_cast<uint32_t>(faces_.size());
  const uint32_t keep = static_cast<uint32_t>(triangles - moved) + 1;
  if (slots_[w].capacity < keep) Grow(w, keep);
  uint32_t* to_n = pool_.data() + slots_[n].offset;
  uint32_t* to_w = pool_.data() + slots_[w].offset;
  for (size_t k = 0; k < triangles; ++k) {
    const uint32_t f = walk_.faces[k];
    if ((k >= a_at) == tail) {
      for (uint32_t& y : faces_[f]) y = y == w ? n : y;
      *to_n++ = f;
    } else {
      *to_w++ = f;
    }
  }
  *to_n = f1;
  *to_w = f1;
  slots_[n].count = static_cast<uint32_t>(moved) + 1;
  slots_[w].count = keep;
  faces_.push_back(tail ? Face{w, a, n} : Face{w, n, a});
  Append(a, f1);
  return n;
}

std::vector<uint32_t> SplitConnectivity::Indices() const {
  std::vector<uint32_t> out;
  IndicesInto(out);
  return out;
}

void SplitConnectivity::IndicesInto(std::vector<uint32_t>& out) const {
  out.resize(faces_.size() * 3);
  uint32_t* to = out.data();
  for (const Face& f : faces_) to = std::copy(f.begin(), f.end(), to);
}

}  // namespace meshstream
