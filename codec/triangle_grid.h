// A uniform-grid spatial index over triangles, answering "which stored
// triangle is closest to this point, and how far is it" exactly.
//
// Build: the triangles' bounding box is cut into cubic cells (one edge length
// for all three axes, about two cells per triangle, at most kMaxCells cells);
// a triangle is listed in every cell that its bounding box overlaps and that
// lies within half a cell diagonal of its plane. Degenerate triangles (zero
// area: segments or points) are legal and are measured as the segments or the
// point they are, so a point set is stored as triangles with three equal
// corners (FromPoints) and the same query finds nearest neighbours.
//
// Query (Searcher::Closest): exact point-to-triangle distance in double
// precision, starting from the searcher's previous answer as an upper bound,
// then visiting rings of cells around the point's cell (Chebyshev radius
// 0, 1, 2, ...) and skipping every cell whose box is farther than the best
// distance so far. It stops as soon as a lower bound on the distance to every
// unvisited cell is at least the best distance, so the answer is proven, not
// approximate. Points outside the grid's box are fine.
//
// Contract: Build/FromPrimitive/FromPoints fail with kInvalidInput on no
// triangles or a non-finite coordinate, and FromPrimitive also on a primitive
// that ValidatePrimitive rejects; they fail with kResourceExhausted beyond
// 2^32 - 2 triangles or cell entries. Build is O(T + cells); a query is O(1)
// expected for points near the surface (O(cells) in the worst case).
// Memory: about 124 bytes per triangle plus 4 bytes per cell and per entry.
// Thread safety: a built TriangleGrid is immutable and may be shared between
// threads; a Searcher holds per-query scratch state, so use one per thread.
#ifndef MESHSTREAM_CODEC_TRIANGLE_GRID_H_
#define MESHSTREAM_CODEC_TRIANGLE_GRID_H_

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "codec/mesh.h"
#include "codec/status.h"

namespace meshstream {

// The point of triangle (a, b, c) closest to p. Degenerate triangles (zero
// area, including repeated corners) are handled as the segment or the point
// they collapse to.
Vec3d ClosestPointOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c);

class TriangleGrid {
 public:
  struct Triangle {
    Vec3d a, b, c;
  };

  static constexpr uint32_t kNone = 0xffffffffu;
  static constexpr uint64_t kMaxCells = uint64_t{1} << 22;

  struct Hit {
    double distance = std::numeric_limits<double>::infinity();
    uint32_t triangle = kNone;  // index into the triangles as given to Build
    Vec3d point = {0, 0, 0};    // the closest point on that triangle
  };

  static StatusOr<TriangleGrid> Build(std::vector<Triangle> triangles);
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
    void Test(uint32_t t, const Vec3d& p, double& best2, Hit& hit);

    const TriangleGrid* grid_;
    std::vector<uint32_t> stamp_;  // per item: last query that tested it
    uint32_t query_ = 0;
    uint32_t last_ = kNone;  // item of the previous answer, the starting upper bound
  };

 private:
  // A triangle with its bounding box. Stored sorted by the cell of the
  // centroid, so that one cell's triangles are close together in memory.
  struct Item {
    Triangle tri;
    Vec3d lo, hi;
  };

  TriangleGrid() = default;
  uint64_t CellIndex(uint32_t x, uint32_t y, uint32_t z) const {
    return (static_cast<uint64_t>(z) * dims_[1] + y) * dims_[0] + x;
  }
  uint32_t CellCoord(double v, int axis) const;

  std::vector<Item> items_;
  std::vector<uint32_t> ids_;       // per item: its index as given to Build
  std::vector<uint32_t> offsets_;   // per cell, into entries_ (size cells + 1)
  std::vector<uint32_t> entries_;   // item indices, grouped by cell
  Vec3d origin_ = {0, 0, 0};
  Vec3d upper_ = {0, 0, 0};  // the far corner of the last cell
  double cell_ = 1.0;
  double inv_cell_ = 1.0;
  std::array<uint32_t, 3> dims_ = {1, 1, 1};
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_TRIANGLE_GRID_H_
