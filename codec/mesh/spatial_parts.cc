#include "codec/mesh/spatial_parts.h"

#include <algorithm>
#include <array>
#include <limits>

namespace meshstream {

size_t PartCount(uint64_t vertices, uint64_t part_vertices) {
  if (part_vertices == 0 || vertices <= part_vertices) return 1;
  const uint64_t needed = (vertices + part_vertices - 1) / part_vertices;
  size_t parts = 1;
  while (parts < needed && parts < kMaxParts) parts *= 2;
  return parts;
}

namespace {

using Centroid = std::array<int64_t, 3>;  // three times the centroid, exact

// Splits triangles[begin, end) into `parts` groups, recursively; `cuts`
// receives the end of each group, in order.
void Split(const std::vector<Centroid>& centroids, std::vector<uint32_t>& triangles, size_t begin, size_t end,
           size_t parts, std::vector<size_t>& cuts) {
  if (parts <= 1 || end - begin <= 1) {
    cuts.push_back(end);
    return;
  }
  std::array<int64_t, 3> lo, hi;
  lo.fill(std::numeric_limits<int64_t>::max());
  hi.fill(std::numeric_limits<int64_t>::min());
  for (size_t i = begin; i < end; ++i) {
    const Centroid& c = centroids[triangles[i]];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
  }
  const size_t left_parts = parts / 2;
  const size_t count = end - begin;
  // The lower half gets its share of the triangles (at least one each side).
  size_t left = static_cast<size_t>((static_cast<unsigned __int128>(count) * left_parts) / parts);
  left = std::clamp<size_t>(left, 1, count - 1);
  auto less = [&](uint32_t a, uint32_t b) {
    const int64_t ka = centroids[a][axis], kb = centroids[b][axis];
    return ka != kb ? ka < kb : a < b;
  };
  std::nth_element(triangles.begin() + begin, triangles.begin() + begin + left, triangles.begin() + end, less);
  Split(centroids, triangles, begin, begin + left, left_parts, cuts);
  Split(centroids, triangles, begin + left, end, parts - left_parts, cuts);
}

}  // namespace

size_t RepairBowties(const QuantizedMesh& mesh, std::vector<uint32_t>& label, int rounds) {
  const size_t vertices = mesh.vertex_count();
  // Triangles around each vertex (CSR).
  std::vector<uint32_t> first(vertices + 1, 0);
  for (uint32_t v : mesh.indices) ++first[v + 1];
  for (size_t v = 0; v < vertices; ++v) first[v + 1] += first[v];
  std::vector<uint32_t> around(mesh.indices.size());
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t c = 0; c < mesh.indices.size(); ++c) around[fill[mesh.indices[c]]++] = static_cast<uint32_t>(c / 3);
  }
  std::vector<uint32_t> fan, parent;
  std::vector<std::pair<uint32_t, uint32_t>> spokes;  // (other end, slot)
  enum class Fix { kClean, kMoved, kStuck };
  // At vertex v: the smallest fan that is not its part's largest moves to
  // the part of a triangle beside it (one that shares a spoke (v, w)), else
  // to any other part at v (the fans meet only across a hole).
  auto fix_vertex = [&](uint32_t v, bool apply) {
    const uint32_t begin = first[v], n = first[v + 1] - begin;
    bool mixed = false;
    for (uint32_t i = 1; i < n && !mixed; ++i) mixed = label[around[begin + i]] != label[around[begin]];
    if (!mixed) return Fix::kClean;
    // Union the slots whose triangles share a spoke (v, w) and a part.
    parent.resize(n);
    for (uint32_t i = 0; i < n; ++i) parent[i] = i;
    auto find = [&](uint32_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    spokes.clear();
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t t = around[begin + i];
      for (int corner = 0; corner < 3; ++corner) {
        const uint32_t w = mesh.indices[3 * size_t{t} + corner];
        if (w != v) spokes.push_back({w, i});
      }
    }
    std::sort(spokes.begin(), spokes.end());
    for (size_t x = 0; x + 1 < spokes.size(); ++x) {
      for (size_t y = x + 1; y < spokes.size() && spokes[y].first == spokes[x].first; ++y) {
        const uint32_t i = spokes[x].second, j = spokes[y].second;
        if (label[around[begin + i]] == label[around[begin + j]]) parent[find(i)] = find(j);
      }
    }
    fan.assign(n, 0);
    for (uint32_t i = 0; i < n; ++i) ++fan[find(i)];
    // The fan to move: the smallest (then the lowest slot) of those that are
    // not their part's largest (ties: the lowest slot stays).
    uint32_t move = UINT32_MAX;
    for (uint32_t r = 0; r < n; ++r) {
      if (find(r) != r) continue;
      const uint32_t part = label[around[begin + r]];
      bool largest = true;
      for (uint32_t o = 0; o < n && largest; ++o) {
        if (find(o) == o && o != r && label[around[begin + o]] == part &&
            (fan[o] > fan[r] || (fan[o] == fan[r] && o < r))) {
          largest = false;
        }
      }
      if (!largest && (move == UINT32_MAX || fan[r] < fan[move])) move = r;
    }
    if (move == UINT32_MAX) return Fix::kClean;
    const uint32_t part = label[around[begin + move]];
    uint32_t target = part;
    for (size_t x = 0; x < spokes.size() && target == part; ++x) {
      if (find(spokes[x].second) != move) continue;
      for (size_t y = 0; y < spokes.size(); ++y) {
        if (spokes[y].first == spokes[x].first && label[around[begin + spokes[y].second]] != part) {
          target = label[around[begin + spokes[y].second]];
          break;
        }
      }
    }
    for (uint32_t j = 0; j < n && target == part; ++j) {
      if (label[around[begin + j]] != part) target = label[around[begin + j]];
    }
    if (target == part) return Fix::kStuck;
    if (!apply) return Fix::kMoved;
    for (uint32_t j = 0; j < n; ++j) {
      if (find(j) == move) label[around[begin + j]] = target;
    }
    return Fix::kMoved;
  };
  for (int round = 0; round < rounds; ++round) {
    size_t moved = 0;
    for (uint32_t v = 0; v < vertices; ++v) {
      for (int tries = 0; tries < 8 && fix_vertex(v, true) == Fix::kMoved; ++tries) ++moved;
    }
    if (moved == 0) break;
  }
  size_t left = 0;
  for (uint32_t v = 0; v < vertices; ++v) left += fix_vertex(v, false) != Fix::kClean;
  return left;
}

std::vector<QuantizedMesh> SplitIntoParts(const QuantizedMesh& mesh, size_t parts) {
  const size_t faces = mesh.face_count();
  parts = std::clamp<size_t>(parts, 1, std::max<size_t>(faces, 1));
  std::vector<Centroid> centroids(faces);
  for (size_t f = 0; f < faces; ++f) {
    Centroid c = {0, 0, 0};
    for (int corner = 0; corner < 3; ++corner) {
      const Vec3i& p = mesh.positions[mesh.indices[3 * f + corner]];
      for (int a = 0; a < 3; ++a) c[a] += p[a];
    }
    centroids[f] = c;
  }
  std::vector<uint32_t> triangles(faces);
  for (size_t f = 0; f < faces; ++f) triangles[f] = static_cast<uint32_t>(f);
  std::vector<size_t> cuts;
  Split(centroids, triangles, 0, faces, parts, cuts);
  centroids = std::vector<Centroid>();
  std::vector<uint32_t> label(faces);
  for (size_t p = 0, begin = 0; p < cuts.size(); begin = cuts[p++]) {
    for (size_t i = begin; i < cuts[p]; ++i) label[triangles[i]] = static_cast<uint32_t>(p);
  }
  RepairBowties(mesh, label, 8);
  // The parts' triangles in input order (counting sort by label).
  std::vector<size_t> count(cuts.size() + 1, 0);
  for (uint32_t l : label) ++count[l + 1];
  for (size_t p = 0; p < cuts.size(); ++p) count[p + 1] += count[p];
  for (size_t p = 0; p < cuts.size(); ++p) cuts[p] = count[p + 1];
  for (size_t f = 0; f < faces; ++f) triangles[count[label[f]]++] = static_cast<uint32_t>(f);
  label = std::vector<uint32_t>();

  const int channels = mesh.layout.channels();
  std::vector<QuantizedMesh> out;
  out.reserve(cuts.size());
  std::vector<uint32_t> remap(mesh.vertex_count(), UINT32_MAX);
  size_t begin = 0;
  for (size_t end : cuts) {
    if (end == begin) continue;  // a part the repair emptied
    // The vertices in input order: mark, then number ascending.
    std::vector<uint32_t> used;
    for (size_t i = begin; i < end; ++i) {
      for (int corner = 0; corner < 3; ++corner) {
        const uint32_t v = mesh.indices[3 * size_t{triangles[i]} + corner];
        if (remap[v] == UINT32_MAX) {
          remap[v] = 0;
          used.push_back(v);
        }
      }
    }
    std::sort(used.begin(), used.end());
    QuantizedMesh part;
    part.position_grid = mesh.position_grid;
    part.layout = mesh.layout;
    part.positions.reserve(used.size());
    part.attributes.reserve(used.size() * channels);
    for (size_t i = 0; i < used.size(); ++i) {
      remap[used[i]] = static_cast<uint32_t>(i);
      part.positions.push_back(mesh.positions[used[i]]);
      const int32_t* a = mesh.attribute(used[i]);
      part.attributes.insert(part.attributes.end(), a, a + channels);
    }
    part.indices.reserve(3 * (end - begin));
    for (size_t i = begin; i < end; ++i) {
      for (int corner = 0; corner < 3; ++corner) part.indices.push_back(remap[mesh.indices[3 * size_t{triangles[i]} + corner]]);
    }
    for (uint32_t v : used) remap[v] = UINT32_MAX;
    out.push_back(std::move(part));
    begin = end;
  }
  return out;
}

}  // namespace meshstream
