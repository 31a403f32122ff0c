#include "codec/hausdorff.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "codec/triangle_grid.h"

namespace meshstream {

namespace {

struct DirectionStats {
  double max = 0;
  double sum = 0;  // over the samples the mean is taken from
  uint64_t count = 0;

  double mean() const { return count ? sum / static_cast<double>(count) : 0.0; }
};

Vec3d ToDouble(const Vec3f& p) { return {p[0], p[1], p[2]}; }

std::vector<char> ReferencedMask(const Primitive& p) {
  std::vector<char> referenced(p.positions.size(), 0);
  for (uint32_t i : p.indices) referenced[i] = 1;
  return referenced;
}

std::vector<Vec3d> ReferencedPoints(const Primitive& p) {
  const std::vector<char> referenced = ReferencedMask(p);
  std::vector<Vec3d> points;
  for (size_t v = 0; v < p.positions.size(); ++v) {
    if (referenced[v]) points.push_back(ToDouble(p.positions[v]));
  }
  return points;
}

double Diagonal(const std::vector<Vec3d>& points) {
  if (points.empty()) return 0;
  Vec3d lo = points[0], hi = points[0];
  for (const Vec3d& q : points) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], q[i]);
      hi[i] = std::max(hi[i], q[i]);
    }
  }
  double s = 0;
  for (int i = 0; i < 3; ++i) s += (hi[i] - lo[i]) * (hi[i] - lo[i]);
  return std::sqrt(s);
}

double Relative(double value, double diagonal) {
  if (diagonal > 0) return value / diagonal;
  return value == 0 ? 0.0 : std::numeric_limits<double>::infinity();
}

double TriangleArea(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
}

// Distances from the samples of `from` (see the header) to the surface in `to`.
DirectionStats SampleToSurface(const Primitive& from, const TriangleGrid& to, int64_t budget) {
  TriangleGrid::Searcher searcher(to);
  DirectionStats stats;
  // Vertex and edge samples are not spread by area: they count for the
  // maximum, and for the mean only when there are no area samples.
  DirectionStats fixed;
  auto measure = [&](const Vec3d& q) {
    const double d = searcher.Closest(q).distance;
    fixed.max = std::max(fixed.max, d);
    fixed.sum += d;
    ++fixed.count;
  };

  // 1. Referenced vertices.
  const std::vector<char> referenced = ReferencedMask(from);
  uint64_t vertex_samples = 0;
  for (size_t v = 0; v < from.positions.size(); ++v) {
    if (referenced[v]) {
      measure(ToDouble(from.positions[v]));
      ++vertex_samples;
    }
  }

  // 2. Midpoints of distinct undirected edges.
  std::vector<uint64_t> edges;
  edges.reserve(from.indices.size());
  for (size_t f = 0; f + 2 < from.indices.size(); f += 3) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = from.indices[f + k], j = from.indices[f + (k + 1) % 3];
      if (i == j) continue;
      edges.push_back((uint64_t{std::min(i, j)} << 32) | std::max(i, j));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (uint64_t e : edges) {
    const Vec3d p = ToDouble(from.positions[e >> 32]);
    const Vec3d q = ToDouble(from.positions[e & 0xffffffffu]);
    measure({0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])});
  }

  // 3. Area-weighted stratified samples with the rest of the budget, but at
  // least half of it.
  const int64_t rest = std::max(budget - static_cast<int64_t>(vertex_samples) -
                                    static_cast<int64_t>(edges.size()),
                                budget / 2);
  if (rest <= 0) return fixed;
  const size_t faces = from.face_count();
  std::vector<double> areas(faces);
  double total_area = 0;
  for (size_t f = 0; f < faces; ++f) {
    areas[f] = TriangleArea(ToDouble(from.positions[from.indices[3 * f]]),
                            ToDouble(from.positions[from.indices[3 * f + 1]]),
                            ToDouble(from.positions[from.indices[3 * f + 2]]));
    total_area += areas[f];
  }
  if (!(total_area > 0) || !std::isfinite(total_area)) return fixed;
  const double per_area = static_cast<double>(rest) / total_area;
  double carry = 0;
  for (size_t f = 0; f < faces; ++f) {
    carry += areas[f] * per_area;
    if (carry < 1) continue;
    const int64_t k = std::max<int64_t>(1, static_cast<int64_t>(std::sqrt(carry)));
    carry -= static_cast<double>(k * k);
    const Vec3d a = ToDouble(from.positions[from.indices[3 * f]]);
    const Vec3d b = ToDouble(from.positions[from.indices[3 * f + 1]]);
    const Vec3d c = ToDouble(from.positions[from.indices[3 * f + 2]]);
    const Vec3d ab = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Vec3d ac = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double inv = 1.0 / (3.0 * static_cast<double>(k));
    auto at = [&](double u, double v) {
      const double d = searcher.Closest({a[0] + u * ab[0] + v * ac[0],
                                         a[1] + u * ab[1] + v * ac[1],
                                         a[2] + u * ab[2] + v * ac[2]})
                           .distance;
      stats.max = std::max(stats.max, d);
      stats.sum += d;
      ++stats.count;
    };
    // Sub-triangle (i, j) pointing up has corners (i, j), (i+1, j), (i, j+1)
    // in units of 1/k; pointing down, (i+1, j), (i, j+1), (i+1, j+1).
    for (int64_t i = 0; i < k; ++i) {
      for (int64_t j = 0; i + j < k; ++j) {
        at(static_cast<double>(3 * i + 1) * inv, static_cast<double>(3 * j + 1) * inv);
        if (i + j + 2 <= k) {
          at(static_cast<double>(3 * i + 2) * inv, static_cast<double>(3 * j + 2) * inv);
        }
      }
    }
  }
  if (stats.count == 0) return fixed;
  stats.max = std::max(stats.max, fixed.max);
  return stats;
}

// Eq. 3 in one direction: max over `from` of the nearest point of `to`.
double VertexToVertex(const std::vector<Vec3d>& from, const TriangleGrid& to) {
  TriangleGrid::Searcher searcher(to);
  double max = 0;
  for (const Vec3d& q : from) max = std::max(max, searcher.Closest(q).distance);
  return max;
}

Status CheckSide(const Primitive& p, const char* side) {
  Status status = ValidatePrimitive(p);
  if (!status.ok()) return status.WithContext(side);
  if (p.face_count() == 0) return InvalidInput(std::string(side) + ": has no faces");
  return Status::Ok();
}

}  // namespace

StatusOr<SurfaceDistance> ComputeSurfaceDistance(const Primitive& a, const Primitive& b,
                                                 const SurfaceDistanceOptions& options) {
  MS_RETURN_IF_ERROR(CheckSide(a, "A"));
  MS_RETURN_IF_ERROR(CheckSide(b, "B"));
  if (options.samples_per_side < 0) {
    return InvalidArgument("samples_per_side must not be negative, got " +
                           std::to_string(options.samples_per_side));
  }
  SurfaceDistance out;

  // Point to surface, both ways.
  {
    MS_ASSIGN_OR_RETURN(const TriangleGrid grid_b, TriangleGrid::FromPrimitive(b));
    const DirectionStats a_to_b = SampleToSurface(a, grid_b, options.samples_per_side);
    MS_ASSIGN_OR_RETURN(const TriangleGrid grid_a, TriangleGrid::FromPrimitive(a));
    const DirectionStats b_to_a = SampleToSurface(b, grid_a, options.samples_per_side);
    out.hausdorff = std::max(a_to_b.max, b_to_a.max);
    out.mean_distance = 0.5 * (a_to_b.mean() + b_to_a.mean());
  }

  // Vertex to vertex (Eq. 3), both ways.
  const std::vector<Vec3d> points_a = ReferencedPoints(a);
  const std::vector<Vec3d> points_b = ReferencedPoints(b);
  {
    MS_ASSIGN_OR_RETURN(const TriangleGrid cloud_b, TriangleGrid::FromPoints(points_b));
    MS_ASSIGN_OR_RETURN(const TriangleGrid cloud_a, TriangleGrid::FromPoints(points_a));
    out.hausdorff_vertex =
        std::max(VertexToVertex(points_a, cloud_b), VertexToVertex(points_b, cloud_a));
  }

  const double diagonal = Diagonal(points_a);
  out.hausdorff_rel = Relative(out.hausdorff, diagonal);
  out.hausdorff_vertex_rel = Relative(out.hausdorff_vertex, diagonal);
  return out;
}

}  // namespace meshstream
