// codec/mesh/spatial_parts.h: the cut keeps every triangle once, shares the
// mesh's grids, leaves no part two fans at a vertex, and is the same on
// every call.
#include "codec/mesh/spatial_parts.h"

#include <algorithm>
#include <array>
#include <set>
#include <vector>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

// A wavy height field of n x n quads (two triangles each), split by both
// diagonals in a checkerboard so that vertices have 4 and 8 neighbours, its
// vertices jittered.
QuantizedMesh Terrain(int n) {
  QuantizedMesh m;
  m.position_grid.bits = 12;
  m.position_grid.components = 3;
  m.position_grid.range = 1.0f;
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      // Jittered like a scan, so that the cut runs ragged (bowties appear
      // without the repair).
      const uint32_t h = static_cast<uint32_t>(x * 73856093) ^ static_cast<uint32_t>(y * 19349663);
      const int jx = static_cast<int>(h % 15) - 7, jy = static_cast<int>((h / 15) % 15) - 7;
      m.positions.push_back({x * 16 + 8 + jx, y * 16 + 8 + jy, ((x * 7 + y * 13) % 11) * 3});
    }
  }
  auto id = [n](int x, int y) { return static_cast<uint32_t>(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const uint32_t a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), d = id(x, y + 1);
      if (((static_cast<uint32_t>(x * 2654435761u) ^ static_cast<uint32_t>(y * 40503u)) >> 7) % 2 == 0) {
        m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      } else {
        m.indices.insert(m.indices.end(), {a, b, d, b, c, d});
      }
    }
  }
  return m;
}

using Triangle = std::array<Vec3i, 3>;

// Triangles by their positions, corners rotated so the smallest comes first.
std::multiset<Triangle> TrianglesOf(const QuantizedMesh& m) {
  std::multiset<Triangle> out;
  for (size_t f = 0; f < m.face_count(); ++f) {
    Triangle t = {m.positions[m.indices[3 * f]], m.positions[m.indices[3 * f + 1]], m.positions[m.indices[3 * f + 2]]};
    const size_t first = std::min_element(t.begin(), t.end()) - t.begin();
    std::rotate(t.begin(), t.begin() + first, t.end());
    out.insert(t);
  }
  return out;
}

// Vertices of `m` whose triangles are more than one fan (connected through
// edges at the vertex).
size_t Bowties(const QuantizedMesh& m) {
  std::vector<std::vector<uint32_t>> around(m.vertex_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    for (int c = 0; c < 3; ++c) around[m.indices[3 * f + c]].push_back(static_cast<uint32_t>(f));
  }
  size_t bowties = 0;
  for (uint32_t v = 0; v < m.vertex_count(); ++v) {
    const std::vector<uint32_t>& tris = around[v];
    if (tris.empty()) continue;
    std::vector<bool> reached(tris.size(), false);
    std::vector<size_t> stack = {0};
    reached[0] = true;
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      for (size_t j = 0; j < tris.size(); ++j) {
        if (reached[j]) continue;
        // Share an edge (v, w): another common vertex.
        int common = 0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) common += m.indices[3 * tris[i] + a] == m.indices[3 * tris[j] + b];
        if (common >= 2) {
          reached[j] = true;
          stack.push_back(j);
        }
      }
    }
    if (std::find(reached.begin(), reached.end(), false) != reached.end()) ++bowties;
  }
  return bowties;
}

TEST(PartCount, PowersOfTwoAboveTheSize) {
  EXPECT_EQ(PartCount(1000000, 0), 1u);
  EXPECT_EQ(PartCount(100, 100), 1u);
  EXPECT_EQ(PartCount(101, 100), 2u);
  EXPECT_EQ(PartCount(300, 100), 4u);
  EXPECT_EQ(PartCount(400, 100), 4u);
  EXPECT_EQ(PartCount(401, 100), 8u);
  EXPECT_EQ(PartCount(uint64_t{1} << 40, 1), kMaxParts);
}

TEST(SpatialParts, EveryTriangleOnceOnTheMeshsGridsWithoutBowties) {
  const QuantizedMesh mesh = Terrain(60);
  const std::multiset<Triangle> all = TrianglesOf(mesh);
  for (size_t parts : {1, 2, 3, 4, 7, 8, 16}) {
    SCOPED_TRACE(parts);
    const std::vector<QuantizedMesh> cut = SplitIntoParts(mesh, parts);
    ASSERT_EQ(cut.size(), parts);
    std::multiset<Triangle> together;
    for (const QuantizedMesh& part : cut) {
      EXPECT_GT(part.face_count(), 0u);
      EXPECT_EQ(part.position_grid.range, mesh.position_grid.range);
      EXPECT_EQ(part.position_grid.bits, mesh.position_grid.bits);
      EXPECT_EQ(part.position_grid.origin, mesh.position_grid.origin);
      EXPECT_EQ(Bowties(part), 0u);
      // Every vertex of a part is referenced by it.
      std::vector<bool> used(part.vertex_count(), false);
      for (uint32_t i : part.indices) used[i] = true;
      EXPECT_EQ(std::count(used.begin(), used.end(), false), 0);
      const std::multiset<Triangle> own = TrianglesOf(part);
      together.insert(own.begin(), own.end());
    }
    EXPECT_TRUE(together == all);
    // Alike in size: no part more than twice another's triangles (the
    // repair moves a few fans only).
    size_t lo = SIZE_MAX, hi = 0;
    for (const QuantizedMesh& part : cut) {
      lo = std::min(lo, part.face_count());
      hi = std::max(hi, part.face_count());
    }
    EXPECT_LE(hi, 2 * lo);
    // The same cut on every call.
    const std::vector<QuantizedMesh> again = SplitIntoParts(mesh, parts);
    for (size_t p = 0; p < parts; ++p) {
      EXPECT_EQ(again[p].positions, cut[p].positions);
      EXPECT_EQ(again[p].indices, cut[p].indices);
    }
  }
}

// Bowties of part `part` under a labelling of mesh's triangles.
size_t BowtiesOfLabel(const QuantizedMesh& mesh, const std::vector<uint32_t>& label, uint32_t part) {
  QuantizedMesh only = mesh;
  only.indices.clear();
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    if (label[f] == part) only.indices.insert(only.indices.end(), &mesh.indices[3 * f], &mesh.indices[3 * f] + 3);
  }
  return Bowties(only);
}

TEST(SpatialParts, RepairMovesTheSmallerFanOfABowtie) {
  const QuantizedMesh mesh = Terrain(8);
  // Part 1 is a checkerboard of quads: every inner vertex where two of its
  // quads touch diagonally is a bowtie of both parts.
  std::vector<uint32_t> label(mesh.face_count());
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const size_t quad = f / 2, x = quad % 8, y = quad / 8;
    label[f] = static_cast<uint32_t>((x + y) % 2);
  }
  ASSERT_GT(BowtiesOfLabel(mesh, label, 0) + BowtiesOfLabel(mesh, label, 1), 0u);
  std::vector<uint32_t> none = label;
  EXPECT_GT(RepairBowties(mesh, none, 0), 0u);  // no round: counted, nothing moved
  EXPECT_EQ(none, label);
  EXPECT_EQ(RepairBowties(mesh, label, 64), 0u);
  EXPECT_EQ(BowtiesOfLabel(mesh, label, 0), 0u);
  EXPECT_EQ(BowtiesOfLabel(mesh, label, 1), 0u);
}

TEST(SpatialParts, AttributesTravelWithTheirVertices) {
  QuantizedMesh mesh = Terrain(20);
  mesh.layout.has_normals = true;  // two channels a vertex
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    mesh.attributes.push_back(mesh.positions[v][0] + 1);
    mesh.attributes.push_back(mesh.positions[v][1] + 2);
  }
  for (const QuantizedMesh& part : SplitIntoParts(mesh, 4)) {
    ASSERT_EQ(part.attributes.size(), 2 * part.vertex_count());
    for (size_t v = 0; v < part.vertex_count(); ++v) {
      EXPECT_EQ(part.attributes[2 * v], part.positions[v][0] + 1);
      EXPECT_EQ(part.attributes[2 * v + 1], part.positions[v][1] + 2);
    }
  }
}

TEST(SpatialParts, MorePartsThanTrianglesAndAnEmptyMesh) {
  QuantizedMesh one = Terrain(1);  // two triangles
  EXPECT_EQ(SplitIntoParts(one, 5).size(), 2u);
  QuantizedMesh empty;
  const std::vector<QuantizedMesh> none = SplitIntoParts(empty, 3);
  for (const QuantizedMesh& p : none) EXPECT_EQ(p.face_count(), 0u);
}

}  // namespace
}  // namespace meshstream
