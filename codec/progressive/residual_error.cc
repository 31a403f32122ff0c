#include "codec/progressive/residual_error.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace meshstream {

namespace {

using Normal = std::array<double, 3>;

// Per vertex, the sum of its triangles' cross products (area-weighted normals).
std::vector<Normal> AreaNormals(const std::vector<Vec3i>& positions, const std::vector<uint32_t>& indices) {
  std::vector<Normal> normals(positions.size(), Normal{0, 0, 0});
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    const uint32_t a = indices[t], b = indices[t + 1], c = indices[t + 2];
    if (a >= positions.size() || b >= positions.size() || c >= positions.size()) continue;
    const double ux = double(positions[b][0]) - positions[a][0], uy = double(positions[b][1]) - positions[a][1],
                 uz = double(positions[b][2]) - positions[a][2];
    const double vx = double(positions[c][0]) - positions[a][0], vy = double(positions[c][1]) - positions[a][1],
                 vz = double(positions[c][2]) - positions[a][2];
    const Normal n = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
    for (uint32_t v : {a, b, c}) {
      for (int k = 0; k < 3; ++k) normals[v][k] += n[k];
    }
  }
  return normals;
}

}  // namespace

std::vector<double> ResidualErrors(const ProgressiveMesh& mesh, const std::vector<Vec3i>& final_positions,
                                   const std::vector<uint32_t>& final_indices) {
  const size_t levels = mesh.refinements.size();
  const std::vector<Normal> normals = AreaNormals(final_positions, final_indices);
  std::vector<double> errors(levels + 1, 0.0);
  for (size_t i = levels; i-- > 0;) {
    const Refinement& r = mesh.refinements[i];
    double largest = 0;
    for (size_t j = 0; j < r.position_delta.size(); ++j) {
      const Vec3i& d = r.position_delta[j];
      const double x = d[0], y = d[1], z = d[2];
      double off = std::sqrt(x * x + y * y + z * z);
      const size_t w = j < r.split_vertices.size() ? r.split_vertices[j] : SIZE_MAX;
      const size_t born = static_cast<size_t>(r.vertices_before) + j;
      if (w < normals.size() && born < normals.size()) {
        const Normal n = {normals[w][0] + normals[born][0], normals[w][1] + normals[born][1],
                          normals[w][2] + normals[born][2]};
        const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (length > 0) off = std::abs(x * n[0] + y * n[1] + z * n[2]) / length;
      }
      largest = std::max(largest, off / 2);
    }
    errors[i] = std::max(errors[i + 1], largest);
  }
  return errors;
}

}  // namespace meshstream
