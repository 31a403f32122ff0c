#include "codec/progressive/split_connectivity.h"

#include <algorithm>

namespace meshstream {

uint32_t SplitConnectivity::NewSlot(uint32_t capacity) {
  Slot slot;
  slot.offset = static_cast<uint32_t>(pool_.size());
  slot.capacity = capacity;
  pool_.resize(pool_.size() + capacity);
  slots_.push_back(slot);
  return static_cast<uint32_t>(slots_.size() - 1);
}

void SplitConnectivity::Append(uint32_t v, uint32_t face) {
  Slot& slot = slots_[v];
  if (slot.count == slot.capacity) {
    const uint32_t capacity = std::max<uint32_t>(8, 2 * slot.capacity);
    const uint32_t offset = static_cast<uint32_t>(pool_.size());
    pool_.resize(pool_.size() + capacity);
    std::copy(pool_.begin() + slot.offset, pool_.begin() + slot.offset + slot.count, pool_.begin() + offset);
    slot.offset = offset;
    slot.capacity = capacity;
  }
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
  slots_.clear();
  slots_.reserve(vertex_count);
  for (uint32_t v = 0; v < vertex_count; ++v) NewSlot(std::max<uint32_t>(8, valence[v] + 2));
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

bool SplitConnectivity::CyclicRing(uint32_t w, std::vector<uint32_t>& ring) const {
  ring.clear();
  ring_faces_.clear();
  const FaceList fs = faces_of(w);
  const size_t n = fs.size();
  if (n < 3) return false;
  // (x, y) for every triangle (w, x, y).
  scratch_.resize(2 * n);
  for (size_t i = 0; i < n; ++i) {
    const Face r = RotateTo(faces_[fs.first[i]], w);
    if (r[1] == w || r[2] == w || r[1] == r[2]) return false;
    scratch_[2 * i] = r[1];
    scratch_[2 * i + 1] = r[2];
  }
  // Follow x -> y. Each step must find exactly one triangle leaving the
  // current vertex, and the walk must close after visiting every triangle.
  const uint32_t start = scratch_[0];
  uint32_t cur = start;
  for (size_t step = 0; step < n; ++step) {
    size_t found = n;
    for (size_t i = 0; i < n; ++i) {
      if (scratch_[2 * i] == cur) {
        if (found != n) return false;  // two triangles leave cur: not a fan
        found = i;
      }
    }
    if (found == n) return false;  // open fan (boundary)
    ring.push_back(cur);
    ring_faces_.push_back(fs.first[found]);
    cur = scratch_[2 * found + 1];
    if (cur == start) return step + 1 == n;
  }
  return false;
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
  slots_.reserve(vertices);
  faces_.reserve(faces);
}

uint32_t SplitConnectivity::SplitAt(uint32_t w, const std::vector<uint32_t>& ring, size_t a_at, size_t b_at) {
  const uint32_t a = ring[a_at], b = ring[b_at];
  const size_t d = ring.size();
  // Triangles (w, ring[k], ring[k+1]) for k from b up to (not including) a
  // move to n; the others stay with w.
  const size_t path = (a_at + d - b_at) % d;
  const uint32_t n = NewSlot(std::max<uint32_t>(8, static_cast<uint32_t>(path) + 4));
  slots_[w].count = 0;
  for (size_t step = 0; step < d; ++step) {
    const uint32_t f = ring_faces_[(b_at + step) % d];
    if (step < path) {
      for (uint32_t& y : faces_[f]) {
        if (y == w) y = n;
      }
      Append(n, f);
    } else {
      Append(w, f);
    }
  }
  const uint32_t f1 = static_cast<uint32_t>(faces_.size());
  faces_.push_back({w, n, a});
  faces_.push_back({n, w, b});
  Append(w, f1);
  Append(w, f1 + 1);
  Append(n, f1);
  Append(n, f1 + 1);
  Append(a, f1);
  Append(b, f1 + 1);
  return n;
}

std::vector<uint32_t> SplitConnectivity::Indices() const {
  std::vector<uint32_t> out;
  out.reserve(faces_.size() * 3);
  for (const Face& f : faces_) out.insert(out.end(), f.begin(), f.end());
  return out;
}

}  // namespace meshstream
