#include "codec/progressive/residual_error.h"

#include <algorithm>
#include <cmath>

#include "codec/progressive/normal_prediction.h"

namespace meshstream {

std::vector<double> ResidualErrors(const ProgressiveMesh& mesh, const RefinementState& finest) {
  const size_t levels = mesh.refinements.size();
  const size_t vertices = finest.positions.size();
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
      if (w < vertices && born < vertices) {
        // The area-weighted normals of both vertices, added (exact, then to double).
        const WideVec3 a = VertexNormal(finest, static_cast<uint32_t>(w));
        const WideVec3 b = VertexNormal(finest, static_cast<uint32_t>(born));
        const double n[3] = {static_cast<double>(a[0] + b[0]), static_cast<double>(a[1] + b[1]),
                             static_cast<double>(a[2] + b[2])};
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
