// A uniform-grid spatial index over triangles, answering "which stored
// triangle is closest to this point, and how far is it" exactly.
//
// Build: the triangles' bounding box is cut into cubic cells (one edge length
// for all three axes, about kCellsPerTriangle cells per triangle over the
// axes that are not flat, at most kMaxCells cells); a triangle is listed in
// every cell that its bounding box overlaps and that lies within half a cell
// diagonal of its plane. The triangles are stored in Morton order of their
// box centres, and a bounding-box tree over that order (halves by index,
// kLeafSize triangles per leaf) backs up the grid for far queries.
// Degenerate triangles (zero area: segments or points) are legal and are
// measured as the segments or the point they are, so a point set is stored as
// triangles with three equal corners (FromPoints) and the same query finds
// nearest neighbours.
//
// Query (Searcher::Closest): exact point-to-triangle distance in double
// precision. The searcher's previous answer gives a first upper bound; then
// the rings of cells around the point's cell (Chebyshev radius 0, 1, ...,
// kMaxRing) are visited, skipping every cell, triangle box and triangle plane
// that is farther than the best distance so far. The search stops as soon as
// a lower bound on the distance to every unvisited cell is at least the best
// distance, so the answer is proven, not approximate. A ring search costs the
// cube of its radius, so when rings 0..kMaxRing do not prove the answer the
// tree finishes the search with the same pruning (nearer child first). Points
// outside the grid's box are fine.
//
// Contract: Build/FromPrimitive/FromPoints fail with kInvalidInput on no
// triangles or a non-finite coordinate (FromPrimitive also on a primitive that
// ValidatePrimitive rejects) and with kResourceExhausted beyond 2^32 - 2
// triangles or cell entries. Build is O(T log T + cells). A query costs O(1)
// expected when the point is within about a cell of the stored surface
// (consecutive nearby queries are the fast case); farther away it costs
// O(log T + k), k the number of triangles whose box and plane lie closer than
// the answer, which grows with the distance on curved surfaces.
// Memory: about 130 bytes per triangle, 28 bytes per cell entry (2 to 4 per
// triangle), 4 bytes per cell, 32 bytes per tree node (T / 2 nodes).
// Thread safety: a built TriangleGrid is immutable and may be shared between
// threads; a Searcher holds per-query scratch state, so use one per thread.
#ifndef MESHSTREAM_CODEC_METRICS_TRIANGLE_GRID_H_
#define MESHSTREAM_CODEC_METRICS_TRIANGLE_GRID_H_

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

// The point of triangle (a, b, c) closest to p. Degenerate triangles (zero
// area, including repeated corners, or with an angle below about 1e-10 rad)
// are handled as the union of their three edges.
Vec3d ClosestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c);

class TriangleGrid {
 public:
  struct Triangle {
    Vec3d a, b, c;
  };

  static constexpr uint32_t kNone = 0xffffffffu;
  static constexpr uint64_t kMaxCells = uint64_t{1} << 22;
  static constexpr double kCellsPerTriangle = 8.0;
  // Rings searched on the grid before the tree takes over.
  static constexpr int kMaxRing = 1;
  static constexpr uint32_t kLeafSize = 4;
  static constexpr int kMaxTreeDepth = 34;  // > log2(2^32 / kLeafSize) + 1

  struct Hit {
    double distance = std::numeric_limits<double>::infinity();
    uint32_t triangle = kNone;  // index into the triangles as given to Build
    Vec3d point = {0, 0, 0};    // the closest point on that triangle
  };

  static StatusOr<TriangleGrid> Build(const std::vector<Triangle>& triangles);
  // Every face of the primitive (degenerate ones included), in face order, so
  // Hit::triangle is the face index.
  static StatusOr<TriangleGrid> FromPrimitive(const Primitive& primitive);
  // One triangle with three equal corners per point, in the given order.
  static StatusOr<TriangleGrid> FromPoints(const std::vector<Vec3d>& points);

  size_t triangle_count() const { return items_.size(); }
  const std::array<uint32_t, 3>& dims() const { return dims_; }
  double cell_size() const { return cell_; }
  size_t entry_count() const { return entries_.size(); }

  // Per-thread query state over one grid; the grid must outlive it.
  class Searcher {
   public:
    explicit Searcher(const TriangleGrid& grid);
    // The closest stored triangle to p (ties: any of them).
    Hit Closest(const Vec3d& p);

   private:
    void Test(uint32_t item, const Vec3d& p, double& best2, uint32_t& best, Vec3d& point);
    void SearchTree(const Vec3d& p, double& best2, uint32_t& best, Vec3d& point);

    const TriangleGrid* grid_;
    std::vector<uint32_t> stamp_;  // per item: last query that tested it
    uint32_t query_ = 0;
    uint32_t last_ = kNone;  // item of the previous answer, the starting upper bound
  };

  // A triangle prepared for distance queries (an implementation detail,
  // public only so that the .cc's helpers can name it).
  struct Item {
    Vec3d a, ab, ac;     // corner a and the edges b - a, c - a
    Vec3d normal;        // unit normal, zero when degenerate
    double offset = 0;   // normal . a
    uint32_t kind = 0;   // 0: triangle, 1: degenerate (three segments), 2: point
  };

 private:
  // A node of the bounding-box tree: a leaf when count > 0 (items
  // [first, first + count)), else an inner node with children first, first + 1.
  struct Node {
    std::array<float, 6> box;  // lo, hi, rounded outwards
    uint32_t first = 0;
    uint32_t count = 0;
  };

  TriangleGrid() = default;
  static void BuildTree(const std::vector<std::array<float, 6>>& boxes, uint32_t node,
                        uint32_t begin, uint32_t end, std::vector<Node>& nodes);
  uint64_t CellIndex(uint32_t x, uint32_t y, uint32_t z) const {
    return (static_cast<uint64_t>(z) * dims_[1] + y) * dims_[0] + x;
  }
  uint32_t CellCoord(double v, int axis) const;

  // In Morton order of the box centres, so that a cell's triangles and a
  // tree leaf's are close together in memory.
  std::vector<Item> items_;
  std::vector<uint32_t> ids_;       // per item: its index as given to Build
  std::vector<Node> nodes_;         // the tree, root first
  std::vector<uint32_t> offsets_;   // per cell, into entries_ (size cells + 1)
  std::vector<uint32_t> entries_;   // item indices, grouped by cell
  // Per entry: its item's bounding box rounded outwards to float (lo, hi),
  // so that a cell's boxes are tested from contiguous memory.
  std::vector<std::array<float, 6>> entry_boxes_;
  Vec3d origin_ = {0, 0, 0};
  double cell_ = 1.0;
  double inv_cell_ = 1.0;
  // Cell walls are widened by this much in lower bounds, so that rounding (in
  // CellCoord and in origin + x * cell) never makes a bound exceed a distance.
  double slack_ = 0;
  std::array<uint32_t, 3> dims_ = {1, 1, 1};
};

// A triangle prepared once for many distance queries (ClosestPointOnTriangle
// prepares it again on every call): the same answers.
using PreparedTriangle = TriangleGrid::Item;
PreparedTriangle PrepareTriangle(const Vec3d& a, const Vec3d& b, const Vec3d& c);
Vec3d ClosestPoint(const PreparedTriangle& t, const Vec3d& p);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_METRICS_TRIANGLE_GRID_H_
