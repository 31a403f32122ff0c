#include "codec/metrics/hausdorff.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "codec/metrics/triangle_grid.h"

namespace meshstream {

namespace {

struct DirectionStats {
  double max = 0;   // over all samples
  double mean = 0;  // area-weighted, see the header
};


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

// Samples a face with subdivision k adds to those of steps 1 and 2: the
// lattice at spacing 1/(2k) without its 3 corners and 3 edge midpoints, plus
// the k*k sub-triangle centroids. NewSamples(1) = 1 (the centroid).
int64_t NewSamples(int64_t k) { return (2 * k + 1) * (2 * k + 2) / 2 - 6 + k * k; }

// The largest k >= 1 with NewSamples(k) <= max(carry, 1).
int64_t SubdivisionFor(double carry) {
  int64_t k = std::max<int64_t>(1, static_cast<int64_t>(std::sqrt(std::max(carry, 0.0) / 3)));
  while (k > 1 && static_cast<double>(NewSamples(k)) > carry) --k;
  while (static_cast<double>(NewSamples(k + 1)) <= carry) ++k;
  return k;
}

// Distances from the samples of `from` (see the header) to the surface in `to`.
DirectionStats SampleToSurface(const Primitive& from, const TriangleGrid& to, int64_t budget) {
  TriangleGrid::Searcher searcher(to);
  DirectionStats stats;
  auto measure = [&](const Vec3d& q) {
    const double d = searcher.Closest(q).distance;
    stats.max = std::max(stats.max, d);
    return d;
  };
  const size_t faces = from.face_count();
  auto corner = [&](size_t f, int k) { return ToDouble(from.positions[from.indices[3 * f + k]]); };

  // 1. Referenced vertices.
  const std::vector<char> referenced = ReferencedMask(from);
  std::vector<double> vertex_distance(from.positions.size(), 0.0);
  double point_sum = 0;  // vertices and midpoints, for the zero-area fallback
  uint64_t points = 0;
  for (size_t v = 0; v < from.positions.size(); ++v) {
    if (!referenced[v]) continue;
    vertex_distance[v] = measure(ToDouble(from.positions[v]));
    point_sum += vertex_distance[v];
    ++points;
  }

  // 2. Midpoints of distinct undirected edges; every face corner k records
  // the distance at the midpoint of its edge (k, k+1).
  std::vector<std::pair<uint64_t, uint32_t>> edges;  // (vertex pair, 3 f + k)
  edges.reserve(from.indices.size());
  for (size_t f = 0; f < faces; ++f) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = from.indices[3 * f + k], j = from.indices[3 * f + (k + 1) % 3];
      if (i == j) continue;  // a zero-length edge: its midpoint is the vertex
      edges.push_back({(uint64_t{std::min(i, j)} << 32) | std::max(i, j),
                       static_cast<uint32_t>(3 * f + k)});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<double> midpoint_distance(from.indices.size(), 0.0);
  for (size_t e = 0; e < edges.size();) {
    const uint64_t key = edges[e].first;
    const Vec3d p = ToDouble(from.positions[key >> 32]);
    const Vec3d q = ToDouble(from.positions[key & 0xffffffffu]);
    const double d = measure({0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])});
    point_sum += d;
    ++points;
    for (; e < edges.size() && edges[e].first == key; ++e) midpoint_distance[edges[e].second] = d;
  }
  for (size_t f = 0; f < faces; ++f) {
    for (int k = 0; k < 3; ++k) {
      if (from.indices[3 * f + k] == from.indices[3 * f + (k + 1) % 3]) {
        midpoint_distance[3 * f + k] = vertex_distance[from.indices[3 * f + k]];
      }
    }
  }

  // 3. Faces of positive area: the composite degree-3 rule on the k*k
  // sub-triangles of the face's k-fold subdivision, k >= 1.
  std::vector<double> areas(faces);
  double total_area = 0;
  uint64_t sampled_faces = 0;
  for (size_t f = 0; f < faces; ++f) {
    areas[f] = TriangleArea(corner(f, 0), corner(f, 1), corner(f, 2));
    total_area += areas[f];
    if (areas[f] > 0) ++sampled_faces;
  }
  if (!(total_area > 0) || !std::isfinite(total_area)) {
    stats.mean = points ? point_sum / static_cast<double>(points) : 0.0;
    return stats;
  }
  const int64_t extra = std::max<int64_t>(
      0, budget - static_cast<int64_t>(points) - static_cast<int64_t>(sampled_faces));
  const double per_area = static_cast<double>(extra) / total_area;
  double carry = 0;
  double weighted_sum = 0;
  std::vector<double> rows[3];
  for (size_t f = 0; f < faces; ++f) {
    if (!(areas[f] > 0)) continue;
    carry += 1 + areas[f] * per_area;
    const int64_t k = SubdivisionFor(carry);
    carry -= static_cast<double>(NewSamples(k));
    const Vec3d a = corner(f, 0), b = corner(f, 1), c = corner(f, 2);
    const Vec3d ab = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Vec3d ac = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    auto at = [&](double u, double v) {
      return measure({a[0] + u * ab[0] + v * ac[0], a[1] + u * ab[1] + v * ac[1],
                      a[2] + u * ab[2] + v * ac[2]});
    };
    // Lattice point (i, r) is a + i/(2k) (b - a) + r/(2k) (c - a); its
    // corners and edge midpoints were measured in steps 1 and 2.
    const int64_t n = 2 * k;
    const double inv_n = 1.0 / static_cast<double>(n);
    auto lattice = [&](int64_t i, int64_t r) {
      if (r == 0 && i == 0) return vertex_distance[from.indices[3 * f]];
      if (r == 0 && i == n) return vertex_distance[from.indices[3 * f + 1]];
      if (r == n) return vertex_distance[from.indices[3 * f + 2]];
      if (r == 0 && i == k) return midpoint_distance[3 * f];
      if (r == k && i == k) return midpoint_distance[3 * f + 1];
      if (r == k && i == 0) return midpoint_distance[3 * f + 2];
      return at(static_cast<double>(i) * inv_n, static_cast<double>(r) * inv_n);
    };
    auto fill_row = [&](std::vector<double>& row, int64_t r) {
      row.resize(static_cast<size_t>(n - r + 1));
      for (int64_t i = 0; i <= n - r; ++i) row[static_cast<size_t>(i)] = lattice(i, r);
    };
    const double third = 1.0 / (3.0 * static_cast<double>(k));
    double face_sum = 0;  // of 60 x the rule over each sub-triangle
    fill_row(rows[2], 0);
    for (int64_t j = 0; j < k; ++j) {
      std::swap(rows[0], rows[2]);  // lattice rows 2j, 2j + 1, 2j + 2
      fill_row(rows[1], 2 * j + 1);
      fill_row(rows[2], 2 * j + 2);
      const std::vector<double>& r0 = rows[0];
      const std::vector<double>& r1 = rows[1];
      const std::vector<double>& r2 = rows[2];
      for (int64_t i = 0; i + j < k; ++i) {
        const size_t u = static_cast<size_t>(2 * i);
        // Pointing up: corners (2i, 2j), (2i+2, 2j), (2i, 2j+2).
        face_sum += 3 * (r0[u] + r0[u + 2] + r2[u]) + 8 * (r0[u + 1] + r1[u + 1] + r1[u]) +
                    27 * at(static_cast<double>(3 * i + 1) * third,
                            static_cast<double>(3 * j + 1) * third);
        if (i + j + 2 <= k) {
          // Pointing down: corners (2i+2, 2j), (2i, 2j+2), (2i+2, 2j+2).
          face_sum += 3 * (r0[u + 2] + r2[u] + r2[u + 2]) +
                      8 * (r1[u + 1] + r2[u + 1] + r1[u + 2]) +
                      27 * at(static_cast<double>(3 * i + 2) * third,
                              static_cast<double>(3 * j + 2) * third);
        }
      }
    }
    weighted_sum += areas[f] * face_sum / (60.0 * static_cast<double>(k * k));
  }
  stats.mean = weighted_sum / total_area;
  return stats;
}

// One direction of the point-to-surface distance; one grid alive at a time.
StatusOr<DirectionStats> PointToSurface(const Primitive& from, const Primitive& to,
                                        int64_t budget) {
  MS_ASSIGN_OR_RETURN(const TriangleGrid grid, TriangleGrid::FromPrimitive(to));
  return SampleToSurface(from, grid, budget);
}

// Eq. 3 in one direction: max over `from` of the nearest point of `to`.
StatusOr<double> VertexToVertex(const std::vector<Vec3d>& from, const std::vector<Vec3d>& to) {
  MS_ASSIGN_OR_RETURN(const TriangleGrid grid, TriangleGrid::FromPoints(to));
  TriangleGrid::Searcher searcher(grid);
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
  if (options.samples_per_side < 0 || options.samples_per_side > kMaxSamplesPerSide) {
    return InvalidArgument("samples_per_side must be between 0 and " +
                           std::to_string(kMaxSamplesPerSide) + ", got " +
                           std::to_string(options.samples_per_side));
  }
  SurfaceDistance out;

  // Point to surface, both ways.
  MS_ASSIGN_OR_RETURN(const DirectionStats a_to_b,
                      PointToSurface(a, b, options.samples_per_side));
  MS_ASSIGN_OR_RETURN(const DirectionStats b_to_a,
                      PointToSurface(b, a, options.samples_per_side));
  out.hausdorff = std::max(a_to_b.max, b_to_a.max);
  out.mean_distance = 0.5 * (a_to_b.mean + b_to_a.mean);

  // Vertex to vertex (Eq. 3), both ways.
  const std::vector<Vec3d> points_a = ReferencedPoints(a);
  const std::vector<Vec3d> points_b = ReferencedPoints(b);
  MS_ASSIGN_OR_RETURN(const double vertex_a_to_b, VertexToVertex(points_a, points_b));
  MS_ASSIGN_OR_RETURN(const double vertex_b_to_a, VertexToVertex(points_b, points_a));
  out.hausdorff_vertex = std::max(vertex_a_to_b, vertex_b_to_a);

  const double diagonal = Diagonal(points_a);
  out.hausdorff_rel = Relative(out.hausdorff, diagonal);
  out.hausdorff_vertex_rel = Relative(out.hausdorff_vertex, diagonal);
  return out;
}

}  // namespace meshstream
