#include "codec/triangle_grid.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <cstdlib>

namespace meshstream {

namespace {

inline Vec3d Sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline double Dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3d Cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline Vec3d AddScaled(const Vec3d& a, const Vec3d& d, double s) {
  return {a[0] + d[0] * s, a[1] + d[1] * s, a[2] + d[2] * s};
}
inline double Dist2(const Vec3d& a, const Vec3d& b) {
  const Vec3d d = Sub(a, b);
  return Dot(d, d);
}

Vec3d ClosestPointOnSegment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = Sub(b, a);
  const double len2 = Dot(ab, ab);
  if (!(len2 > 0)) return a;
  const double t = std::clamp(Dot(Sub(p, a), ab) / len2, 0.0, 1.0);
  return AddScaled(a, ab, t);
}

// Squared distance from p to the box [lo, hi] (empty boxes are not passed).
inline double BoxDist2(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
  double s = 0;
  for (int i = 0; i < 3; ++i) {
    const double d = std::max({lo[i] - p[i], 0.0, p[i] - hi[i]});
    s += d * d;
  }
  return s;
}

}  // namespace

Vec3d ClosestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = Sub(b, a), ac = Sub(c, a);
  const Vec3d n = Cross(ab, ac);
  const double n2 = Dot(n, n);
  // Zero area, or so thin (sin of the angle at a below 1e-10) that the plane
  // is meaningless: the triangle is the union of its three edges.
  if (!(n2 > 1e-20 * Dot(ab, ab) * Dot(ac, ac))) {
    Vec3d best = ClosestPointOnSegment(p, a, b);
    double best2 = Dist2(p, best);
    for (const Vec3d& q : {ClosestPointOnSegment(p, b, c), ClosestPointOnSegment(p, c, a)}) {
      const double d2 = Dist2(p, q);
      if (d2 < best2) {
        best2 = d2;
        best = q;
      }
    }
    return best;
  }
  // Voronoi regions of the corners, then of the edges, else the interior.
  const Vec3d ap = Sub(p, a);
  const double d1 = Dot(ab, ap), d2 = Dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = Sub(p, b);
  const double d3 = Dot(ab, bp), d4 = Dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return AddScaled(a, ab, d1 / (d1 - d3));
  const Vec3d cp = Sub(p, c);
  const double d5 = Dot(ab, cp), d6 = Dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return AddScaled(a, ac, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    return AddScaled(b, Sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  // Inside: project onto the plane.
  return AddScaled(p, n, -Dot(n, ap) / n2);
}

uint32_t TriangleGrid::CellCoord(double v, int axis) const {
  const double t = (v - origin_[axis]) * inv_cell_;
  if (!(t > 0)) return 0;
  if (t >= static_cast<double>(dims_[axis])) return dims_[axis] - 1;
  return static_cast<uint32_t>(t);
}

StatusOr<TriangleGrid> TriangleGrid::Build(std::vector<Triangle> triangles) {
  if (triangles.empty()) return InvalidInput("no triangles to index");
  if (triangles.size() >= kNone) {
    return ResourceExhausted("too many triangles to index: " + std::to_string(triangles.size()));
  }
  TriangleGrid g;
  const size_t count = triangles.size();

  // Bounding boxes, per triangle and overall.
  std::vector<Item> items(count);
  Vec3d lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  for (size_t t = 0; t < count; ++t) {
    Item& item = items[t];
    item.tri = triangles[t];
    const Triangle& tri = item.tri;
    for (int i = 0; i < 3; ++i) {
      if (!std::isfinite(tri.a[i]) || !std::isfinite(tri.b[i]) || !std::isfinite(tri.c[i])) {
        return InvalidInput("triangle " + std::to_string(t) + " has a non-finite coordinate");
      }
      item.lo[i] = std::min({tri.a[i], tri.b[i], tri.c[i]});
      item.hi[i] = std::max({tri.a[i], tri.b[i], tri.c[i]});
      lo[i] = std::min(lo[i], item.lo[i]);
      hi[i] = std::max(hi[i], item.hi[i]);
    }
  }
  std::vector<Triangle>().swap(triangles);

  // Cell size: about two cells per triangle over the non-flat axes.
  const Vec3d ext = Sub(hi, lo);
  const double max_ext = std::max({ext[0], ext[1], ext[2]});
  g.origin_ = lo;
  if (max_ext > 0) {
    const double mult = getenv("TG_MULT") ? atof(getenv("TG_MULT")) : 2.0;
    const uint64_t target = std::min<uint64_t>(mult * static_cast<uint64_t>(count), kMaxCells);
    double volume = 1;
    int flat_dims = 0;
    for (int i = 0; i < 3; ++i) {
      if (ext[i] > 1e-9 * max_ext) {
        volume *= ext[i];
        ++flat_dims;
      }
    }
    double h = std::pow(volume / static_cast<double>(target), 1.0 / flat_dims);
    if (!(h > 0) || !std::isfinite(h)) h = max_ext;
    for (;;) {
      uint64_t cells = 1;
      for (int i = 0; i < 3; ++i) {
        const double d = std::floor(ext[i] / h) + 1;
        g.dims_[i] = d < 1e7 ? static_cast<uint32_t>(d) : 10000000u;
        cells *= g.dims_[i];
      }
      if (cells <= kMaxCells) break;
      h *= 1.1;
    }
    g.cell_ = h;
  } else {
    g.cell_ = 1;
    g.dims_ = {1, 1, 1};
  }
  g.inv_cell_ = 1.0 / g.cell_;
  for (int i = 0; i < 3; ++i) g.upper_[i] = g.origin_[i] + g.dims_[i] * g.cell_;

  // Store the triangles in the order of the cells of their box centres.
  {
    std::vector<std::pair<uint64_t, uint32_t>> order(count);
    for (uint32_t t = 0; t < count; ++t) {
      const Item& item = items[t];
      order[t] = {g.CellIndex(g.CellCoord(0.5 * (item.lo[0] + item.hi[0]), 0),
                              g.CellCoord(0.5 * (item.lo[1] + item.hi[1]), 1),
                              g.CellCoord(0.5 * (item.lo[2] + item.hi[2]), 2)),
                  t};
    }
    std::sort(order.begin(), order.end());
    g.items_.resize(count);
    g.ids_.resize(count);
    for (size_t k = 0; k < count; ++k) {
      g.items_[k] = items[order[k].second];
      g.ids_[k] = order[k].second;
    }
  }
  std::vector<Item>().swap(items);

  // Counting pass, then filling pass, over the same cell test.
  const uint64_t cells = uint64_t{g.dims_[0]} * g.dims_[1] * g.dims_[2];
  const double half_diagonal = g.cell_ * 0.8660254037844387;  // sqrt(3) / 2
  std::vector<uint64_t> count_per_cell(cells + 1, 0);
  auto for_each_cell = [&g, half_diagonal](uint32_t t, auto&& visit) {
    const Triangle& tri = g.items_[t].tri;
    const Item& box = g.items_[t];
    const Vec3d n = Cross(Sub(tri.b, tri.a), Sub(tri.c, tri.a));
    const double n_len = std::sqrt(Dot(n, n));
    const uint32_t x0 = g.CellCoord(box.lo[0], 0), x1 = g.CellCoord(box.hi[0], 0);
    const uint32_t y0 = g.CellCoord(box.lo[1], 1), y1 = g.CellCoord(box.hi[1], 1);
    const uint32_t z0 = g.CellCoord(box.lo[2], 2), z1 = g.CellCoord(box.hi[2], 2);
    const bool single = x0 == x1 && y0 == y1 && z0 == z1;
    for (uint32_t z = z0; z <= z1; ++z) {
      for (uint32_t y = y0; y <= y1; ++y) {
        for (uint32_t x = x0; x <= x1; ++x) {
          if (!single && n_len > 0) {
            const Vec3d centre = {g.origin_[0] + (x + 0.5) * g.cell_,
                                  g.origin_[1] + (y + 0.5) * g.cell_,
                                  g.origin_[2] + (z + 0.5) * g.cell_};
            if (std::fabs(Dot(n, Sub(centre, tri.a))) > n_len * half_diagonal * (1 + 1e-9)) {
              continue;  // the triangle's plane misses this cell
            }
          }
          visit(g.CellIndex(x, y, z));
        }
      }
    }
  };
  uint64_t entries = 0;
  for (uint32_t t = 0; t < count; ++t) {
    for_each_cell(t, [&](uint64_t cell) {
      ++count_per_cell[cell];
      ++entries;
    });
  }
  if (entries >= kNone) {
    return ResourceExhausted("triangle grid would need " + std::to_string(entries) + " entries");
  }
  g.offsets_.resize(cells + 1);
  uint32_t running = 0;
  for (uint64_t c = 0; c < cells; ++c) {
    g.offsets_[c] = running;
    running += static_cast<uint32_t>(count_per_cell[c]);
  }
  g.offsets_[cells] = running;
  std::vector<uint64_t>().swap(count_per_cell);
  g.entries_.resize(entries);
  std::vector<uint32_t> fill(g.offsets_.begin(), g.offsets_.end() - 1);
  for (uint32_t t = 0; t < count; ++t) {
    for_each_cell(t, [&](uint64_t cell) { g.entries_[fill[cell]++] = t; });
  }
  return g;
}

StatusOr<TriangleGrid> TriangleGrid::FromPrimitive(const Primitive& primitive) {
  MS_RETURN_IF_ERROR(ValidatePrimitive(primitive));
  std::vector<Triangle> triangles(primitive.face_count());
  auto get = [&primitive](uint32_t v) -> Vec3d {
    const Vec3f& p = primitive.positions[v];
    return {p[0], p[1], p[2]};
  };
  for (size_t f = 0; f < triangles.size(); ++f) {
    triangles[f] = {get(primitive.indices[3 * f]), get(primitive.indices[3 * f + 1]),
                    get(primitive.indices[3 * f + 2])};
  }
  return Build(std::move(triangles));
}

StatusOr<TriangleGrid> TriangleGrid::FromPoints(const std::vector<Vec3d>& points) {
  std::vector<Triangle> triangles(points.size());
  for (size_t i = 0; i < points.size(); ++i) triangles[i] = {points[i], points[i], points[i]};
  return Build(std::move(triangles));
}

TriangleGrid::Searcher::Searcher(const TriangleGrid& grid)
    : grid_(&grid), stamp_(grid.triangle_count(), 0) {}

void TriangleGrid::Searcher::Test(uint32_t t, const Vec3d& p, double& best2, Hit& hit) {
  if (stamp_[t] == query_) return;
  stamp_[t] = query_;
  const Item& item = grid_->items_[t];
  if (BoxDist2(p, item.lo, item.hi) >= best2) return;
  const Triangle& tri = item.tri;
  Vec3d q;
  if (tri.a == tri.b && tri.a == tri.c) {
    q = tri.a;
  } else {
    q = ClosestPointOnTriangle(p, tri.a, tri.b, tri.c);
  }
  const double d2 = Dist2(p, q);
  if (d2 < best2) {
    best2 = d2;
    hit.triangle = t;
    hit.point = q;
  }
}

TriangleGrid::Hit TriangleGrid::Searcher::Closest(const Vec3d& p) {
  const TriangleGrid& g = *grid_;
  if (++query_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    query_ = 1;
  }
  Hit hit;
  double best2 = std::numeric_limits<double>::infinity();
  if (last_ != kNone) Test(last_, p, best2, hit);

  // Cell boxes are widened by `slack` so that rounding in CellCoord can never
  // make a lower bound exceed a true distance.
  const double slack = 1e-9 * g.cell_;
  const int64_t dims[3] = {g.dims_[0], g.dims_[1], g.dims_[2]};
  const int64_t c[3] = {g.CellCoord(p[0], 0), g.CellCoord(p[1], 1), g.CellCoord(p[2], 2)};
  auto lo_of = [&](int axis, int64_t cell) { return g.origin_[axis] + cell * g.cell_ - slack; };
  auto hi_of = [&](int axis, int64_t cell) { return g.origin_[axis] + (cell + 1) * g.cell_ + slack; };
  // Squared distance from p to the slab of cells [from, to] along one axis.
  auto axis_gap2 = [&](int axis, int64_t from, int64_t to) {
    const double d = std::max({lo_of(axis, from) - p[axis], 0.0, p[axis] - hi_of(axis, to)});
    return d * d;
  };

  for (int64_t r = 0; best2 > 0; ++r) {
    if (r > 0) {
      // Every unvisited cell lies beyond one face of the visited block
      // c +- (r - 1); bound the distance to the part of the grid beyond each.
      double bound2 = std::numeric_limits<double>::infinity();
      for (int axis = 0; axis < 3; ++axis) {
        double others = 0;
        for (int o = 0; o < 3; ++o) {
          if (o != axis) others += axis_gap2(o, 0, dims[o] - 1);
        }
        if (c[axis] - (r - 1) > 0) {
          bound2 = std::min(bound2, others + axis_gap2(axis, 0, c[axis] - r));
        }
        if (c[axis] + (r - 1) < dims[axis] - 1) {
          bound2 = std::min(bound2, others + axis_gap2(axis, c[axis] + r, dims[axis] - 1));
        }
      }
      if (bound2 >= best2) break;  // also when the block covers the grid
    }
    const int64_t x0 = std::max<int64_t>(c[0] - r, 0), x1 = std::min(c[0] + r, dims[0] - 1);
    const int64_t y0 = std::max<int64_t>(c[1] - r, 0), y1 = std::min(c[1] + r, dims[1] - 1);
    const int64_t z0 = std::max<int64_t>(c[2] - r, 0), z1 = std::min(c[2] + r, dims[2] - 1);
    auto visit = [&](int64_t x, int64_t y, int64_t z, double yz2) {
      if (yz2 + axis_gap2(0, x, x) >= best2) return;
      const uint64_t cell = g.CellIndex(static_cast<uint32_t>(x), static_cast<uint32_t>(y),
                                        static_cast<uint32_t>(z));
      for (uint32_t e = g.offsets_[cell], end = g.offsets_[cell + 1]; e < end; ++e) {
        Test(g.entries_[e], p, best2, hit);
      }
    };
    for (int64_t z = z0; z <= z1; ++z) {
      const double z2 = axis_gap2(2, z, z);
      if (z2 >= best2) continue;
      const bool z_face = (z == c[2] - r || z == c[2] + r);
      for (int64_t y = y0; y <= y1; ++y) {
        const double yz2 = z2 + axis_gap2(1, y, y);
        if (yz2 >= best2) continue;
        if (z_face || y == c[1] - r || y == c[1] + r) {
          for (int64_t x = x0; x <= x1; ++x) visit(x, y, z, yz2);
        } else {
          if (c[0] - r >= 0) visit(c[0] - r, y, z, yz2);
          if (c[0] + r < dims[0]) visit(c[0] + r, y, z, yz2);
        }
      }
    }
  }
  hit.distance = std::sqrt(best2);
  last_ = hit.triangle;
  if (hit.triangle != kNone) hit.triangle = g.ids_[hit.triangle];
  return hit;
}

}  // namespace meshstream
