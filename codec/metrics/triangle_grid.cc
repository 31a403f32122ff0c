#include "codec/metrics/triangle_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace meshstream {

namespace {

using Item = TriangleGrid::Item;

inline Vec3d AddScaled(const Vec3d& a, const Vec3d& d, double s) {
  return {a[0] + d[0] * s, a[1] + d[1] * s, a[2] + d[2] * s};
}
inline double Dist2(const Vec3d& a, const Vec3d& b) {
  const Vec3d d = Sub(a, b);
  return Dot(d, d);
}

// The nearest float at or below / at or above v (v is finite).
float RoundDown(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
float RoundUp(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

Item MakeItem(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  Item item;
  item.a = a;
  item.ab = Sub(b, a);
  item.ac = Sub(c, a);
  item.normal = {0, 0, 0};
  if (a == b && a == c) {
    item.kind = 2;
    return item;
  }
  const Vec3d n = Cross(item.ab, item.ac);
  const double n2 = Dot(n, n);
  // Zero area, or so thin (sine of the angle at a below 1e-10) that the plane
  // is meaningless: the triangle is the union of its three edges.
  if (!(n2 > 1e-20 * Dot(item.ab, item.ab) * Dot(item.ac, item.ac))) {
    item.kind = 1;
    return item;
  }
  const double inv = 1.0 / std::sqrt(n2);
  item.normal = {n[0] * inv, n[1] * inv, n[2] * inv};
  item.offset = Dot(item.normal, a);
  item.kind = 0;
  return item;
}

Vec3d ClosestOnSegment(const Vec3d& p, const Vec3d& a, const Vec3d& ab) {
  const double len2 = Dot(ab, ab);
  if (!(len2 > 0)) return a;
  const double t = std::clamp(Dot(Sub(p, a), ab) / len2, 0.0, 1.0);
  return AddScaled(a, ab, t);
}

Vec3d ClosestOnItem(const Item& item, const Vec3d& p) {
  const Vec3d& a = item.a;
  const Vec3d& ab = item.ab;
  const Vec3d& ac = item.ac;
  if (item.kind == 2) return a;
  if (item.kind == 1) {
    const Vec3d b = Add(a, ab), c = Add(a, ac);
    Vec3d best = ClosestOnSegment(p, a, ab);
    double best2 = Dist2(p, best);
    const Vec3d q1 = ClosestOnSegment(p, b, Sub(c, b));
    const double d1 = Dist2(p, q1);
    if (d1 < best2) {
      best2 = d1;
      best = q1;
    }
    const Vec3d q2 = ClosestOnSegment(p, c, Sub(a, c));
    if (Dist2(p, q2) < best2) best = q2;
    return best;
  }
  // Voronoi regions of the corners, then of the edges, else the interior.
  const Vec3d ap = Sub(p, a);
  const double d1 = Dot(ab, ap), d2 = Dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = Sub(ap, ab);
  const double d3 = Dot(ab, bp), d4 = Dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return Add(a, ab);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return AddScaled(a, ab, d1 / (d1 - d3));
  const Vec3d cp = Sub(ap, ac);
  const double d5 = Dot(ab, cp), d6 = Dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return Add(a, ac);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return AddScaled(a, ac, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    return AddScaled(Add(a, ab), Sub(ac, ab), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  // Inside: project onto the plane.
  return AddScaled(p, item.normal, item.offset - Dot(item.normal, p));
}

std::array<float, 6> FloatBox(const Vec3d& lo, const Vec3d& hi) {
  return {RoundDown(lo[0]), RoundDown(lo[1]), RoundDown(lo[2]),
          RoundUp(hi[0]),   RoundUp(hi[1]),   RoundUp(hi[2])};
}

// Interleaves the low 21 bits of x, y and z (x lowest).
uint64_t Morton(uint32_t x, uint32_t y, uint32_t z) {
  auto spread = [](uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
  };
  return spread(x) | spread(y) << 1 | spread(z) << 2;
}

// Squared distance from p to a float box (lo[3], hi[3]).
inline double BoxDist2(const Vec3d& p, const std::array<float, 6>& box) {
  double s = 0;
  for (int i = 0; i < 3; ++i) {
    const double d = std::max({box[i] - p[i], 0.0, p[i] - box[3 + i]});
    s += d * d;
  }
  return s;
}

}  // namespace

// Items are in Morton order of their box centres; node n covers items
// [begin, end) and splits them in half by index. Children are appended
// together (right = left + 1); depth is at most log2(count) + 1. Boxes are
// computed bottom-up.
void TriangleGrid::BuildTree(const std::vector<std::array<float, 6>>& boxes, uint32_t node,
                             uint32_t begin, uint32_t end, std::vector<Node>& nodes) {
  std::array<float, 6> box;
  if (end - begin <= kLeafSize) {
    box = boxes[begin];
    for (uint32_t k = begin + 1; k < end; ++k) {
      for (int i = 0; i < 3; ++i) {
        box[i] = std::min(box[i], boxes[k][i]);
        box[3 + i] = std::max(box[3 + i], boxes[k][3 + i]);
      }
    }
    nodes[node].first = begin;
    nodes[node].count = end - begin;
  } else {
    const uint32_t mid = begin + (end - begin) / 2;
    const uint32_t left = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    nodes.emplace_back();
    BuildTree(boxes, left, begin, mid, nodes);
    BuildTree(boxes, left + 1, mid, end, nodes);
    for (int i = 0; i < 3; ++i) {
      box[i] = std::min(nodes[left].box[i], nodes[left + 1].box[i]);
      box[3 + i] = std::max(nodes[left].box[3 + i], nodes[left + 1].box[3 + i]);
    }
    nodes[node].first = left;
    nodes[node].count = 0;
  }
  nodes[node].box = box;
}

Vec3d ClosestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return ClosestOnItem(MakeItem(a, b, c), p);
}

PreparedTriangle PrepareTriangle(const Vec3d& a, const Vec3d& b, const Vec3d& c) { return MakeItem(a, b, c); }

Vec3d ClosestPoint(const PreparedTriangle& t, const Vec3d& p) { return ClosestOnItem(t, p); }

uint32_t TriangleGrid::CellCoord(double v, int axis) const {
  const double t = (v - origin_[axis]) * inv_cell_;
  if (!(t > 0)) return 0;
  if (t >= static_cast<double>(dims_[axis])) return dims_[axis] - 1;
  return static_cast<uint32_t>(t);
}

StatusOr<TriangleGrid> TriangleGrid::Build(const std::vector<Triangle>& triangles) {
  if (triangles.empty()) return InvalidInput("no triangles to index");
  if (triangles.size() >= kNone) {
    return ResourceExhausted("too many triangles to index: " + std::to_string(triangles.size()));
  }
  const uint32_t count = static_cast<uint32_t>(triangles.size());
  Vec3d lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  for (uint32_t t = 0; t < count; ++t) {
    const Triangle& tri = triangles[t];
    for (int i = 0; i < 3; ++i) {
      if (!std::isfinite(tri.a[i]) || !std::isfinite(tri.b[i]) || !std::isfinite(tri.c[i])) {
        return InvalidInput("triangle " + std::to_string(t) + " has a non-finite coordinate");
      }
      lo[i] = std::min({lo[i], tri.a[i], tri.b[i], tri.c[i]});
      hi[i] = std::max({hi[i], tri.a[i], tri.b[i], tri.c[i]});
    }
  }

  // Cell size: about kCellsPerTriangle cells per triangle over the axes that
  // are not flat (a plane gets a 2D grid, a line a 1D grid, a point one cell).
  TriangleGrid g;
  const Vec3d ext = Sub(hi, lo);
  const double max_ext = std::max({ext[0], ext[1], ext[2]});
  g.origin_ = lo;
  if (max_ext > 0) {
    const uint64_t target = std::min<uint64_t>(
        static_cast<uint64_t>(kCellsPerTriangle * static_cast<double>(count)), kMaxCells);
    double volume = 1;
    int axes = 0;
    for (int i = 0; i < 3; ++i) {
      if (ext[i] > 1e-9 * max_ext) {
        volume *= ext[i];
        ++axes;
      }
    }
    double h = std::pow(volume / static_cast<double>(std::max<uint64_t>(target, 1)), 1.0 / axes);
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
  double magnitude = 0;
  for (int i = 0; i < 3; ++i) {
    magnitude = std::max({magnitude, std::fabs(g.origin_[i]),
                          std::fabs(g.origin_[i] + static_cast<double>(g.dims_[i]) * g.cell_)});
  }
  g.slack_ = 1e-9 * g.cell_ + 1e-14 * magnitude;

  // Items in Morton order of their box centres: the tree splits that order,
  // and a cell's items end up close together in memory.
  std::vector<Vec3d> box_lo(count), box_hi(count);
  {
    std::vector<std::pair<uint64_t, uint32_t>> order(count);
    const double scale = max_ext > 0 ? 2097151.0 / max_ext : 0.0;  // 2^21 - 1
    for (uint32_t t = 0; t < count; ++t) {
      const Triangle& tri = triangles[t];
      uint32_t q[3];
      for (int i = 0; i < 3; ++i) {
        const double centre = 0.5 * (std::min({tri.a[i], tri.b[i], tri.c[i]}) +
                                     std::max({tri.a[i], tri.b[i], tri.c[i]}));
        q[i] = static_cast<uint32_t>(std::clamp((centre - lo[i]) * scale, 0.0, 2097151.0));
      }
      order[t] = {Morton(q[0], q[1], q[2]), t};
    }
    std::sort(order.begin(), order.end());
    g.items_.resize(count);
    g.ids_.resize(count);
    for (uint32_t k = 0; k < count; ++k) {
      const uint32_t t = order[k].second;
      const Triangle& tri = triangles[t];
      g.items_[k] = MakeItem(tri.a, tri.b, tri.c);
      g.ids_[k] = t;
      for (int i = 0; i < 3; ++i) {
        box_lo[k][i] = std::min({tri.a[i], tri.b[i], tri.c[i]});
        box_hi[k][i] = std::max({tri.a[i], tri.b[i], tri.c[i]});
      }
    }
  }
  {
    std::vector<std::array<float, 6>> boxes(count);
    for (uint32_t k = 0; k < count; ++k) boxes[k] = FloatBox(box_lo[k], box_hi[k]);
    g.nodes_.reserve(2 * (count / kLeafSize) + 2);
    g.nodes_.emplace_back();
    BuildTree(boxes, 0, 0, count, g.nodes_);
  }

  // Cell lists: a counting pass, then a filling pass, over the same cells.
  const uint64_t cells = uint64_t{g.dims_[0]} * g.dims_[1] * g.dims_[2];
  const double half_diagonal = g.cell_ * 0.8660254037844387 * (1 + 1e-9);  // sqrt(3) / 2
  auto for_each_cell = [&g, &box_lo, &box_hi, half_diagonal](uint32_t t, auto&& visit) {
    const Item& item = g.items_[t];
    const uint32_t x0 = g.CellCoord(box_lo[t][0], 0), x1 = g.CellCoord(box_hi[t][0], 0);
    const uint32_t y0 = g.CellCoord(box_lo[t][1], 1), y1 = g.CellCoord(box_hi[t][1], 1);
    const uint32_t z0 = g.CellCoord(box_lo[t][2], 2), z1 = g.CellCoord(box_hi[t][2], 2);
    const bool plane_test = item.kind == 0 && !(x0 == x1 && y0 == y1 && z0 == z1);
    for (uint32_t z = z0; z <= z1; ++z) {
      for (uint32_t y = y0; y <= y1; ++y) {
        for (uint32_t x = x0; x <= x1; ++x) {
          if (plane_test) {
            const Vec3d centre = {g.origin_[0] + (x + 0.5) * g.cell_,
                                  g.origin_[1] + (y + 0.5) * g.cell_,
                                  g.origin_[2] + (z + 0.5) * g.cell_};
            if (std::fabs(Dot(item.normal, centre) - item.offset) > half_diagonal) {
              continue;  // the triangle's plane misses this cell
            }
          }
          visit(g.CellIndex(x, y, z));
        }
      }
    }
  };
  std::vector<uint32_t> per_cell(cells, 0);
  uint64_t entries = 0;
  for (uint32_t t = 0; t < count; ++t) {
    for_each_cell(t, [&](uint64_t cell) {
      ++per_cell[cell];
      ++entries;
    });
    if (entries >= kNone) {
      return ResourceExhausted("triangle grid would need more than " + std::to_string(entries) +
                               " entries");
    }
  }
  g.offsets_.resize(cells + 1);
  uint32_t running = 0;
  for (uint64_t c = 0; c < cells; ++c) {
    g.offsets_[c] = running;
    running += per_cell[c];
    per_cell[c] = g.offsets_[c];  // now the next free slot of the cell
  }
  g.offsets_[cells] = running;
  g.entries_.resize(entries);
  g.entry_boxes_.resize(entries);
  for (uint32_t t = 0; t < count; ++t) {
    const std::array<float, 6> box = FloatBox(box_lo[t], box_hi[t]);
    for_each_cell(t, [&](uint64_t cell) {
      g.entry_boxes_[per_cell[cell]] = box;
      g.entries_[per_cell[cell]++] = t;
    });
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
  return Build(triangles);
}

StatusOr<TriangleGrid> TriangleGrid::FromPoints(const std::vector<Vec3d>& points) {
  std::vector<Triangle> triangles(points.size());
  for (size_t i = 0; i < points.size(); ++i) triangles[i] = {points[i], points[i], points[i]};
  return Build(triangles);
}

TriangleGrid::Searcher::Searcher(const TriangleGrid& grid)
    : grid_(&grid), stamp_(grid.triangle_count(), 0) {}

inline void TriangleGrid::Searcher::Test(uint32_t t, const Vec3d& p, double& best2,
                                         uint32_t& best, Vec3d& point) {
  if (stamp_[t] == query_) return;
  stamp_[t] = query_;
  const Item& item = grid_->items_[t];
  if (item.kind == 0) {
    const double plane = Dot(item.normal, p) - item.offset;
    if (plane * plane >= best2) return;
  }
  const Vec3d q = ClosestOnItem(item, p);
  const double d2 = Dist2(p, q);
  if (d2 < best2) {
    best2 = d2;
    best = t;
    point = q;
  }
}

void TriangleGrid::Searcher::SearchTree(const Vec3d& p, double& best2, uint32_t& best,
                                        Vec3d& point) {
  const std::vector<Node>& nodes = grid_->nodes_;
  // Nearer child first; a node waits with its distance, rechecked when popped.
  std::pair<uint32_t, double> stack[2 * kMaxTreeDepth + 2];
  int top = 0;
  const double root2 = BoxDist2(p, nodes[0].box);
  if (root2 < best2) stack[top++] = {0, root2};
  while (top > 0) {
    const auto [n, d2] = stack[--top];
    if (d2 >= best2) continue;
    const Node& node = nodes[n];
    if (node.count > 0) {
      for (uint32_t t = node.first; t < node.first + node.count; ++t) {
        Test(t, p, best2, best, point);
      }
      continue;
    }
    const uint32_t left = node.first, right = node.first + 1;
    const double dl = BoxDist2(p, nodes[left].box), dr = BoxDist2(p, nodes[right].box);
    const bool left_first = dl <= dr;
    const std::pair<uint32_t, double> near = left_first ? std::make_pair(left, dl)
                                                        : std::make_pair(right, dr);
    const std::pair<uint32_t, double> far = left_first ? std::make_pair(right, dr)
                                                       : std::make_pair(left, dl);
    if (far.second < best2) stack[top++] = far;
    if (near.second < best2) stack[top++] = near;
  }
}

TriangleGrid::Hit TriangleGrid::Searcher::Closest(const Vec3d& p) {
  const TriangleGrid& g = *grid_;
  if (++query_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    query_ = 1;
  }
  double best2 = std::numeric_limits<double>::infinity();
  uint32_t best = kNone;
  Vec3d point = {0, 0, 0};
  if (last_ != kNone) Test(last_, p, best2, best, point);

  const double h = g.cell_;
  const double slack = g.slack_;
  const int64_t dims[3] = {g.dims_[0], g.dims_[1], g.dims_[2]};
  int64_t c[3];
  double below[3], above[3], outside2[3];
  for (int i = 0; i < 3; ++i) {
    c[i] = g.CellCoord(p[i], i);
    const double cell_lo = g.origin_[i] + static_cast<double>(c[i]) * h;
    below[i] = p[i] - cell_lo - slack;       // to the low wall of p's cell
    above[i] = cell_lo + h - p[i] - slack;   // to its high wall
    const double grid_hi = g.origin_[i] + static_cast<double>(dims[i]) * h;
    const double out = std::max({g.origin_[i] - p[i], 0.0, p[i] - grid_hi});
    outside2[i] = out * out;  // distance from p to the grid's slab on this axis
  }
  // Squared distance from p to the slab of cell x on one axis.
  auto gap2 = [&](int axis, int64_t x) {
    const double lo = g.origin_[axis] + static_cast<double>(x) * h - slack;
    const double d = std::max({lo - p[axis], 0.0, p[axis] - lo - h - 2 * slack});
    return d * d;
  };

  for (int64_t r = 0; best2 > 0; ++r) {
    if (r > 0) {
      // Every unvisited cell lies beyond a face of the visited block
      // c +- (r - 1); bound the distance to the part of the grid beyond each.
      double bound2 = std::numeric_limits<double>::infinity();
      const double grow = static_cast<double>(r - 1) * h;
      for (int i = 0; i < 3; ++i) {
        const double others = outside2[(i + 1) % 3] + outside2[(i + 2) % 3];
        if (c[i] - (r - 1) > 0) {
          const double d = std::max(below[i] + grow, 0.0);
          bound2 = std::min(bound2, others + d * d);
        }
        if (c[i] + (r - 1) < dims[i] - 1) {
          const double d = std::max(above[i] + grow, 0.0);
          bound2 = std::min(bound2, others + d * d);
        }
      }
      if (bound2 >= best2) break;  // also when the block covers the grid
      if (r > kMaxRing) {
        SearchTree(p, best2, best, point);
        break;
      }
    }
    const int64_t x0 = std::max<int64_t>(c[0] - r, 0), x1 = std::min(c[0] + r, dims[0] - 1);
    const int64_t y0 = std::max<int64_t>(c[1] - r, 0), y1 = std::min(c[1] + r, dims[1] - 1);
    const int64_t z0 = std::max<int64_t>(c[2] - r, 0), z1 = std::min(c[2] + r, dims[2] - 1);
    auto visit = [&](int64_t x, int64_t y, int64_t z, double yz2) {
      if (yz2 + gap2(0, x) >= best2) return;
      const uint64_t cell = g.CellIndex(static_cast<uint32_t>(x), static_cast<uint32_t>(y),
                                        static_cast<uint32_t>(z));
      for (uint32_t e = g.offsets_[cell], end = g.offsets_[cell + 1]; e < end; ++e) {
        if (BoxDist2(p, g.entry_boxes_[e]) >= best2) continue;
        Test(g.entries_[e], p, best2, best, point);
        if (best2 == 0) return;
      }
    };
    for (int64_t z = z0; z <= z1; ++z) {
      const double z2 = gap2(2, z);
      if (z2 >= best2) continue;
      const bool z_face = (z == c[2] - r || z == c[2] + r);
      for (int64_t y = y0; y <= y1; ++y) {
        const double yz2 = z2 + gap2(1, y);
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
  Hit hit;
  last_ = best;
  if (best != kNone) {
    hit.point = point;
    hit.distance = std::sqrt(best2);
    hit.triangle = g.ids_[best];
  }
  return hit;
}

}  // namespace meshstream
