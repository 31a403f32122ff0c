#include "codec/metrics/laplacian.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace meshstream {

namespace {


double Norm(const Vec3d& a, const Vec3d& b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

std::vector<uint32_t> ReferencedVertices(const Primitive& p) {
  std::vector<char> referenced(p.positions.size(), 0);
  for (uint32_t i : p.indices) referenced[i] = 1;
  std::vector<uint32_t> out;
  for (size_t v = 0; v < referenced.size(); ++v) {
    if (referenced[v]) out.push_back(static_cast<uint32_t>(v));
  }
  return out;
}

}  // namespace

std::vector<Vec3d> GeometricLaplacian(const Primitive& p) {
  const size_t n = p.positions.size();
  // Distinct directed edges (i -> j and j -> i for every face edge), sorted
  // by i, so each vertex's neighbours are one contiguous run.
  std::vector<uint64_t> edges;
  edges.reserve(2 * p.indices.size());
  for (size_t f = 0; f + 2 < p.indices.size(); f += 3) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = p.indices[f + k], j = p.indices[f + (k + 1) % 3];
      if (i == j) continue;
      edges.push_back((uint64_t{i} << 32) | j);
      edges.push_back((uint64_t{j} << 32) | i);
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());

  std::vector<Vec3d> gl(n, Vec3d{0, 0, 0});
  size_t e = 0;
  while (e < edges.size()) {
    const uint32_t i = static_cast<uint32_t>(edges[e] >> 32);
    const Vec3d vi = ToDouble(p.positions[i]);
    Vec3d weighted = {0, 0, 0};
    double weights = 0;
    for (; e < edges.size() && (edges[e] >> 32) == i; ++e) {
      const Vec3d vj = ToDouble(p.positions[edges[e] & 0xffffffffu]);
      const double length = Norm(vi, vj);
      if (!(length > 0)) continue;  // zero-length edge: no finite weight
      const double w = 1.0 / length;
      for (int c = 0; c < 3; ++c) weighted[c] += w * vj[c];
      weights += w;
    }
    if (weights > 0) {
      for (int c = 0; c < 3; ++c) gl[i][c] = vi[c] - weighted[c] / weights;
    }
  }
  return gl;
}

StatusOr<double> LaplacianDistortion(const Primitive& a, const Primitive& b) {
  Status status = ValidatePrimitive(a);
  if (!status.ok()) return status.WithContext("A");
  status = ValidatePrimitive(b);
  if (!status.ok()) return status.WithContext("B");
  const std::vector<uint32_t> ra = ReferencedVertices(a);
  const std::vector<uint32_t> rb = ReferencedVertices(b);
  if (ra.empty()) return InvalidInput("A: has no referenced vertex");
  if (ra.size() != rb.size()) {
    return InvalidArgument("Laplacian distortion needs equal referenced vertex counts, A has " +
                           std::to_string(ra.size()) + " and B has " +
                           std::to_string(rb.size()));
  }
  const std::vector<Vec3d> gla = GeometricLaplacian(a);
  const std::vector<Vec3d> glb = GeometricLaplacian(b);
  double position_sum = 0, laplacian_sum = 0;
  for (size_t k = 0; k < ra.size(); ++k) {
    position_sum += Norm(ToDouble(a.positions[ra[k]]), ToDouble(b.positions[rb[k]]));
    laplacian_sum += Norm(gla[ra[k]], glb[rb[k]]);
  }
  return (position_sum + laplacian_sum) / (2.0 * static_cast<double>(ra.size()));
}

}  // namespace meshstream
