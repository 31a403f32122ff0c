#include "codec/split_mesh.h"

#include <algorithm>

namespace meshstream {

Status SplitMesh::Reset(uint32_t vertex_count, const std::vector<uint32_t>& indices) {
  if (indices.size() % 3 != 0) return InvalidInput("index count is not a multiple of 3");
  faces_.clear();
  faces_.reserve(indices.size() / 3);
  vertex_faces_.assign(vertex_count, {});
  for (size_t i = 0; i < indices.size(); i += 3) {
    const Face f = {indices[i], indices[i + 1], indices[i + 2]};
    for (uint32_t v : f) {
      if (v >= vertex_count) return InvalidInput("face " + std::to_string(i / 3) + " names vertex " + std::to_string(v));
    }
    const uint32_t id = static_cast<uint32_t>(faces_.size());
    faces_.push_back(f);
    vertex_faces_[f[0]].push_back(id);
    if (f[1] != f[0]) vertex_faces_[f[1]].push_back(id);
    if (f[2] != f[0] && f[2] != f[1]) vertex_faces_[f[2]].push_back(id);
  }
  return Status::Ok();
}

bool SplitMesh::CyclicRing(uint32_t w, std::vector<uint32_t>& ring) const {
  ring.clear();
  ring_faces_.clear();
  const std::vector<uint32_t>& fs = vertex_faces_[w];
  const size_t n = fs.size();
  if (n < 3) return false;
  // (x, y) for every triangle (w, x, y).
  scratch_.resize(2 * n);
  for (size_t i = 0; i < n; ++i) {
    const Face r = RotateTo(faces_[fs[i]], w);
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
    ring_faces_.push_back(fs[found]);
    cur = scratch_[2 * found + 1];
    if (cur == start) return step + 1 == n;
  }
  return false;
}

void SplitMesh::SortedNeighbours(uint32_t w, std::vector<uint32_t>& out) const {
  out.clear();
  for (uint32_t f : vertex_faces_[w]) {
    for (uint32_t x : faces_[f]) {
      if (x != w) out.push_back(x);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

StatusOr<uint32_t> SplitMesh::Split(uint32_t w, uint32_t a, uint32_t b) {
  if (w >= vertex_count() || a >= vertex_count() || b >= vertex_count() || a == b || a == w || b == w) {
    return InvalidInput("split of vertex " + std::to_string(w) + " names invalid wings");
  }
  std::vector<uint32_t> ring;
  if (!CyclicRing(w, ring)) return InvalidInput("vertex " + std::to_string(w) + " is not a closed manifold fan");
  const auto ia = std::find(ring.begin(), ring.end(), a);
  const auto ib = std::find(ring.begin(), ring.end(), b);
  if (ia == ring.end() || ib == ring.end()) {
    return InvalidInput("split of vertex " + std::to_string(w) + ": a wing is not a neighbour");
  }
  return SplitAt(w, ring, static_cast<size_t>(ia - ring.begin()), static_cast<size_t>(ib - ring.begin()));
}

void SplitMesh::Reserve(uint32_t vertices, size_t faces) {
  vertex_faces_.reserve(vertices);
  faces_.reserve(faces);
}

uint32_t SplitMesh::SplitAt(uint32_t w, const std::vector<uint32_t>& ring, size_t a_at, size_t b_at) {
  const uint32_t n = vertex_count();
  const uint32_t a = ring[a_at], b = ring[b_at];
  const size_t d = ring.size();
  vertex_faces_.emplace_back();
  std::vector<uint32_t>& nf = vertex_faces_[n];
  std::vector<uint32_t>& wf = vertex_faces_[w];
  // Triangles (w, ring[k], ring[k+1]) for k from b up to (not including) a
  // move to n; the others stay with w.
  const size_t path = (a_at + d - b_at) % d;
  nf.reserve(path + 2);
  wf.clear();
  for (size_t step = 0; step < d; ++step) {
    const size_t k = (b_at + step) % d;
    const uint32_t f = ring_faces_[k];
    if (step < path) {
      for (uint32_t& y : faces_[f]) {
        if (y == w) y = n;
      }
      nf.push_back(f);
    } else {
      wf.push_back(f);
    }
  }
  const uint32_t f1 = static_cast<uint32_t>(faces_.size());
  faces_.push_back({w, n, a});
  faces_.push_back({n, w, b});
  wf.push_back(f1);
  wf.push_back(f1 + 1);
  nf.push_back(f1);
  nf.push_back(f1 + 1);
  vertex_faces_[a].push_back(f1);
  vertex_faces_[b].push_back(f1 + 1);
  return n;
}

std::vector<uint32_t> SplitMesh::Indices() const {
  std::vector<uint32_t> out;
  out.reserve(faces_.size() * 3);
  for (const Face& f : faces_) out.insert(out.end(), f.begin(), f.end());
  return out;
}

}  // namespace meshstream
