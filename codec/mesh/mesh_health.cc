#include "codec/mesh/mesh_health.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace meshstream {

void BoundingBox::Extend(const Vec3f& p) {
  for (int c = 0; c < 3; ++c) {
    if (empty) {
      min[c] = max[c] = p[c];
    } else {
      min[c] = std::min<double>(min[c], p[c]);
      max[c] = std::max<double>(max[c], p[c]);
    }
  }
  empty = false;
}

void BoundingBox::Extend(const BoundingBox& other) {
  if (other.empty) return;
  Extend(Vec3f{static_cast<float>(other.min[0]), static_cast<float>(other.min[1]),
               static_cast<float>(other.min[2])});
  Extend(Vec3f{static_cast<float>(other.max[0]), static_cast<float>(other.max[1]),
               static_cast<float>(other.max[2])});
}

double BoundingBox::Diagonal() const {
  if (empty) return 0;
  double s = 0;
  for (int c = 0; c < 3; ++c) s += (max[c] - min[c]) * (max[c] - min[c]);
  return std::sqrt(s);
}

void MeshHealth::Add(const MeshHealth& o) {
  vertices += o.vertices;
  faces += o.faces;
  unreferenced_vertices += o.unreferenced_vertices;
  degenerate_faces += o.degenerate_faces;
  nonmanifold_edges += o.nonmanifold_edges;
  bbox.Extend(o.bbox);
  referenced_bbox.Extend(o.referenced_bbox);
}

namespace {

bool Collinear(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const double ux = double(b[0]) - a[0], uy = double(b[1]) - a[1], uz = double(b[2]) - a[2];
  const double vx = double(c[0]) - a[0], vy = double(c[1]) - a[1], vz = double(c[2]) - a[2];
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return cx == 0 && cy == 0 && cz == 0;
}

}  // namespace

MeshHealth ComputeHealth(const Primitive& p) {
  MeshHealth h;
  h.vertices = p.vertex_count();
  h.faces = p.face_count();
  std::vector<bool> used(p.vertex_count(), false);
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(p.indices.size());
  for (size_t f = 0; f < p.face_count(); ++f) {
    const uint32_t v[3] = {p.indices[3 * f], p.indices[3 * f + 1], p.indices[3 * f + 2]};
    for (uint32_t i : v) used[i] = true;
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2] ||
        Collinear(p.positions[v[0]], p.positions[v[1]], p.positions[v[2]])) {
      ++h.degenerate_faces;
    }
    for (int k = 0; k < 3; ++k) {
      uint32_t a = v[k], b = v[(k + 1) % 3];
      if (a == b) continue;
      if (a > b) std::swap(a, b);
      edges.emplace_back(a, b);
    }
  }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i > 2) ++h.nonmanifold_edges;
    i = j;
  }
  for (size_t i = 0; i < used.size(); ++i) {
    h.bbox.Extend(p.positions[i]);
    if (used[i]) {
      h.referenced_bbox.Extend(p.positions[i]);
    } else {
      ++h.unreferenced_vertices;
    }
  }
  return h;
}

}  // namespace meshstream
