// sdk/mesh_changes.h: the ranges between two reads of a mesh, and the
// merge that bounds their number; codec's DequantizeVerticesInto, which
// writes a range of vertices the way DequantizeMesh writes them all.
#include "sdk/mesh_changes.h"

#include <random>

#include <gtest/gtest.h>

#include "codec/mesh/quantized_mesh.h"

namespace meshstream::sdk {
namespace {

// A mesh of n vertices with normals and one texcoord set, and t triangles.
QuantizedMesh Grid(size_t n, size_t t) {
  QuantizedMesh m;
  m.position_grid.bits = 11;
  m.position_grid.range = 2.0;
  m.layout.has_normals = true;
  m.layout.texcoord_sets = 1;
  m.layout.texcoord_grids.resize(1);
  m.layout.texcoord_grids[0].bits = 10;
  m.layout.texcoord_grids[0].range = 1.0;
  for (size_t v = 0; v < n; ++v) {
    m.positions.push_back({static_cast<int32_t>(v), static_cast<int32_t>(2 * v), 7});
    m.attributes.insert(m.attributes.end(), {10, 20, static_cast<int32_t>(v % 1000), 3});
  }
  for (size_t f = 0; f < t; ++f) {
    m.indices.insert(m.indices.end(), {static_cast<uint32_t>(f % n), static_cast<uint32_t>((f + 1) % n),
                                       static_cast<uint32_t>((f + 2) % n)});
  }
  return m;
}

std::vector<Range> R(std::initializer_list<std::pair<uint32_t, uint32_t>> l) {
  std::vector<Range> out;
  for (auto [f, c] : l) out.push_back({f, c});
  return out;
}

void ExpectRanges(const std::vector<Range>& got, const std::vector<Range>& want, const char* what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].first, want[i].first) << what << " range " << i;
    EXPECT_EQ(got[i].count, want[i].count) << what << " range " << i;
  }
}

TEST(MeshChanges, FirstReadIsEverything) {
  MeshChanges c;
  c.Update(Grid(10, 4), {});
  EXPECT_TRUE(c.everything());
  ExpectRanges(c.vertices(), R({{0, 10}}), "vertices");
  ExpectRanges(c.indices(), R({{0, 12}}), "indices");
  EXPECT_EQ(c.previous_vertex_count(), 0u);
}

TEST(MeshChanges, TheSameReadAgainChangesNothing) {
  MeshChanges c;
  const QuantizedMesh m = Grid(10, 4);
  c.Update(m, {});
  c.Update(m, {});
  EXPECT_FALSE(c.everything());
  EXPECT_TRUE(c.vertices().empty());
  EXPECT_TRUE(c.indices().empty());
  EXPECT_EQ(c.previous_vertex_count(), 10u);
  EXPECT_EQ(c.previous_index_count(), 12u);
}

TEST(MeshChanges, ASplitsWorthOfChanges) {
  // What a level does: a vertex moves, one gets a new normal, a triangle is
  // renumbered, vertices and triangles are appended, a flag turns predicted.
  MeshChanges c;
  QuantizedMesh m = Grid(10, 6);
  c.Update(m, std::vector<uint8_t>(10, 1));
  m.positions[3][0] += 1;
  m.attributes[7 * 4 + 1] += 1;  // vertex 7's normal
  m.indices[3 * 2 + 1] = 9;      // triangle 2
  m.positions.push_back({1, 1, 1});
  m.positions.push_back({2, 2, 2});
  m.attributes.insert(m.attributes.end(), 8, 0);
  m.indices.insert(m.indices.end(), {10, 11, 0, 11, 10, 1});
  std::vector<uint8_t> exact(12, 1);
  exact[8] = 0;
  c.Update(m, exact);
  EXPECT_FALSE(c.everything());
  ExpectRanges(c.vertices(), R({{3, 1}, {7, 2}, {10, 2}}), "vertices");
  ExpectRanges(c.indices(), R({{7, 1}, {18, 6}}), "indices");
  EXPECT_EQ(c.changed_vertices(), 5u);
  EXPECT_EQ(c.changed_indices(), 7u);
  EXPECT_EQ(c.predicted()[8], 1);
  EXPECT_EQ(c.predicted()[7], 0);
  // A flag alone turning back is a change too.
  exact[8] = 1;
  c.Update(m, exact);
  ExpectRanges(c.vertices(), R({{8, 1}}), "the flag");
  EXPECT_TRUE(c.indices().empty());
}

TEST(MeshChanges, AnotherLayoutIsEverything) {
  MeshChanges c;
  QuantizedMesh m = Grid(5, 2);
  c.Update(m, {});
  m.layout.texcoord_sets = 0;
  m.layout.texcoord_grids.clear();
  m.attributes.assign(5 * 2, 1);
  c.Update(m, {});
  EXPECT_TRUE(c.everything());
  ExpectRanges(c.vertices(), R({{0, 5}}), "vertices");
}

TEST(MeshChanges, ShrinkingKeepsOnlyWhatIsLeft) {
  MeshChanges c;
  QuantizedMesh m = Grid(10, 6);
  c.Update(m, {});
  QuantizedMesh smaller = Grid(8, 3);
  c.Update(smaller, {});
  EXPECT_TRUE(c.vertices().empty());
  EXPECT_TRUE(c.indices().empty());
  EXPECT_EQ(c.previous_vertex_count(), 10u);
  EXPECT_EQ(c.predicted().size(), 8u);
}

TEST(LimitRanges, MergesTheNearestFirst) {
  std::vector<Range> r = R({{0, 1}, {2, 1}, {10, 1}, {12, 1}, {30, 2}});
  LimitRanges(r, 3);
  ExpectRanges(r, R({{0, 3}, {10, 3}, {30, 2}}), "limit 3");
  LimitRanges(r, 1);
  ExpectRanges(r, R({{0, 32}}), "limit 1");
}

TEST(LimitRanges, EqualGapsCloseOnlyAsManyAsNeeded) {
  std::vector<Range> r = R({{0, 1}, {2, 1}, {4, 1}, {6, 1}});
  LimitRanges(r, 3);
  EXPECT_EQ(r.size(), 3u);
  EXPECT_EQ(RangeElements(r), 5u);
  std::vector<Range> none = r;
  LimitRanges(none, 0);
  EXPECT_EQ(none.size(), 3u);
}

TEST(LimitRanges, NeverLosesAnElementOnRandomRanges) {
  std::mt19937 rng(7);
  for (int round = 0; round < 200; ++round) {
    std::vector<Range> r;
    uint32_t at = 0;
    const int count = 1 + static_cast<int>(rng() % 50);
    for (int i = 0; i < count; ++i) {
      at += 1 + rng() % 20;
      const uint32_t len = 1 + rng() % 5;
      r.push_back({at, len});
      at += len;
    }
    std::vector<Range> limited = r;
    const size_t max = 1 + rng() % 10;
    LimitRanges(limited, max);
    ASSERT_LE(limited.size(), std::max<size_t>(max, 1));
    if (r.size() > max) ASSERT_EQ(limited.size(), max);
    for (const Range& x : r) {  // every element stays covered
      bool covered = false;
      for (const Range& y : limited) covered |= x.first >= y.first && x.first + x.count <= y.first + y.count;
      ASSERT_TRUE(covered) << "round " << round;
    }
  }
}

TEST(DequantizeVerticesInto, WritesWhatDequantizeMeshWrites) {
  QuantizedMesh m = Grid(50, 10);
  m.layout.has_colors = true;
  m.layout.color_grid.bits = 8;
  m.layout.color_grid.range = 1.0;
  std::vector<int32_t> attributes;
  for (size_t v = 0; v < 50; ++v) {
    attributes.insert(attributes.end(), m.attributes.begin() + 4 * v, m.attributes.begin() + 4 * v + 4);
    attributes.insert(attributes.end(), {1, 2, 3, static_cast<int32_t>(v)});
  }
  m.attributes = attributes;
  const Primitive whole = DequantizeMesh(m, -1);
  std::vector<float> p(150, -1), n(150, -1), t(100, -1), c(200, -1);
  FlatVertexArrays out{p.data(), n.data(), t.data(), c.data()};
  DequantizeVerticesInto(m, 5, 20, out);
  for (size_t v = 0; v < 50; ++v) {
    const bool in = v >= 5 && v < 25;
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(p[3 * v + k], in ? whole.positions[v][k] : -1.0f) << v;
      EXPECT_EQ(n[3 * v + k], in ? whole.normals[v][k] : -1.0f) << v;
    }
    for (int k = 0; k < 2; ++k) EXPECT_EQ(t[2 * v + k], in ? whole.texcoords[0][v][k] : -1.0f) << v;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(c[4 * v + k], in ? whole.colors[v][k] : -1.0f) << v;
  }
}

}  // namespace
}  // namespace meshstream::sdk
