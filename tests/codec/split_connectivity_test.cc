// SplitConnectivity (codec/progressive/split_connectivity.h): CyclicRing on
// closed fans, open fans and non-manifold vertices; SplitAt as the exact
// inverse of the edge collapse (the collapse gives the original triangles
// back, face for face); the new vertex's id and rings; SortedNeighbours;
// Reset's checks; Indices() round trip.
#include "codec/progressive/split_connectivity.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "codec/progressive/refinement.h"
#include "tests/common/hierarchy.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

using Ids = std::vector<uint32_t>;

// A closed bipyramid: apexes 0 (top) and 1 (bottom), equator 2 .. 2 + k - 1.
Ids Bipyramid(uint32_t k) {
  Ids out;
  for (uint32_t i = 0; i < k; ++i) {
    const uint32_t a = 2 + i, b = 2 + (i + 1) % k;
    out.insert(out.end(), {0, a, b});
    out.insert(out.end(), {1, b, a});
  }
  return out;
}

// Undoes SplitAt(w, ...) that created n: n becomes w again and the two faces
// the split appended (the last two) go.
Ids Collapse(Ids indices, uint32_t w, uint32_t n) {
  indices.resize(indices.size() - 6);
  for (uint32_t& i : indices)
    if (i == n) i = w;
  return indices;
}

TEST(SplitConnectivity, ResetRefusesIndicesOutOfRangeAndPartialFaces) {
  SplitConnectivity c;
  const Status out = c.Reset(3, {0, 1, 2, 0, 2, 3});
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.code(), StatusCode::kInvalidInput);
  EXPECT_NE(out.message().find("face 1"), std::string::npos) << out.message();
  EXPECT_NE(out.message().find("vertex 3"), std::string::npos) << out.message();
  EXPECT_FALSE(c.Reset(3, {0, 1}).ok());
  EXPECT_FALSE(c.Reset(0, {0, 0, 0}).ok());
  EXPECT_TRUE(c.Reset(4, {0, 1, 2, 0, 2, 3}).ok());  // the boundary id itself is in range
  EXPECT_TRUE(c.Reset(5, {}).ok());
  EXPECT_EQ(c.vertex_count(), 5u);
  EXPECT_EQ(c.face_count(), 0u);
}

TEST(SplitConnectivity, IndicesRoundTripAndFaceLists) {
  const Ids in = Bipyramid(5);
  SplitConnectivity c;
  ASSERT_TRUE(c.Reset(9, in).ok());  // vertex 8 has no faces
  EXPECT_EQ(c.Indices(), in);
  EXPECT_EQ(c.vertex_count(), 9u);
  EXPECT_EQ(c.face_count(), 10u);
  EXPECT_EQ(c.faces_of(0).size(), 5u);
  EXPECT_EQ(c.faces_of(2).size(), 4u);
  EXPECT_EQ(c.faces_of(8).size(), 0u);
  for (uint32_t v = 0; v < 7; ++v)
    for (uint32_t f : c.faces_of(v)) {
      const Face& face = c.faces()[f];
      EXPECT_TRUE(std::find(face.begin(), face.end(), v) != face.end()) << v;
    }
  // A degenerate face lists a repeated vertex once.
  ASSERT_TRUE(c.Reset(2, {0, 0, 1}).ok());
  EXPECT_EQ(c.faces_of(0).size(), 1u);
  EXPECT_EQ(c.Indices(), (Ids{0, 0, 1}));
}

TEST(SplitConnectivity, CyclicRingOfAClosedFanFollowsTheTriangles) {
  SplitConnectivity c;
  ASSERT_TRUE(c.Reset(8, Bipyramid(6)).ok());
  Ids ring;
  ASSERT_TRUE(c.CyclicRing(0, ring));
  EXPECT_EQ(ring, (Ids{2, 3, 4, 5, 6, 7}));  // x -> y of (0, x, y), from the first triangle
  ASSERT_TRUE(c.CyclicRing(1, ring));
  EXPECT_EQ(ring, (Ids{3, 2, 7, 6, 5, 4}));  // the other orientation
  ASSERT_TRUE(c.CyclicRing(4, ring));
  ASSERT_EQ(ring.size(), 4u);  // 0, 3, 1, 5 up to rotation
  auto at = std::find(ring.begin(), ring.end(), 0u);
  ASSERT_NE(at, ring.end());
  std::rotate(ring.begin(), at, ring.end());
  EXPECT_EQ(ring, (Ids{0, 3, 1, 5}));
}

TEST(SplitConnectivity, CyclicRingRefusesOpenAndNonManifoldFans) {
  SplitConnectivity c;
  Ids ring;
  // Open fan (w on a boundary).
  ASSERT_TRUE(c.Reset(5, {0, 1, 2, 0, 2, 3, 0, 3, 4}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  // Two closed fans sharing w (a bowtie of cones).
  ASSERT_TRUE(c.Reset(7, {0, 1, 2, 0, 2, 3, 0, 3, 1, 0, 4, 5, 0, 5, 6, 0, 6, 4}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  // A closed fan plus a fin on one of its edges: two triangles leave 1.
  ASSERT_TRUE(c.Reset(5, {0, 1, 2, 0, 2, 3, 0, 3, 1, 0, 1, 4}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  // Fewer than three triangles, none, a degenerate one.
  ASSERT_TRUE(c.Reset(3, {0, 1, 2, 0, 2, 1}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  ASSERT_TRUE(c.Reset(4, {0, 1, 2, 0, 2, 3, 0, 3, 1}).ok());
  EXPECT_TRUE(c.CyclicRing(0, ring));  // the smallest closed fan
  ASSERT_TRUE(c.Reset(4, {0, 1, 2, 0, 2, 3, 0, 3, 3}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  ASSERT_TRUE(c.Reset(4, {0, 1, 2, 0, 2, 0, 0, 3, 1}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
  ASSERT_TRUE(c.Reset(4, {1, 2, 3}).ok());
  EXPECT_FALSE(c.CyclicRing(0, ring));
}

TEST(SplitConnectivity, SplitAtCreatesTheNextIdWithTheDocumentedTriangles) {
  const Ids in = Bipyramid(6);
  SplitConnectivity c;
  ASSERT_TRUE(c.Reset(8, in).ok());
  Ids ring;
  ASSERT_TRUE(c.CyclicRing(0, ring));  // 2 3 4 5 6 7
  // Wings a = 5 (ring position 3), b = 2 (position 0): the triangles on the
  // path b -> a, (0,2,3) (0,3,4) (0,4,5), move to n.
  const uint32_t n = c.SplitAt(0, ring, 3, 0);
  EXPECT_EQ(n, 8u);
  EXPECT_EQ(c.vertex_count(), 9u);
  EXPECT_EQ(c.face_count(), 14u);
  EXPECT_EQ(c.faces()[12], (Face{0, 8, 5}));
  EXPECT_EQ(c.faces()[13], (Face{8, 0, 2}));
  Ids r;
  ASSERT_TRUE(c.CyclicRing(8, r));
  std::rotate(r.begin(), std::find(r.begin(), r.end(), 2u), r.end());
  EXPECT_EQ(r, (Ids{2, 3, 4, 5, 0}));
  ASSERT_TRUE(c.CyclicRing(0, r));
  std::rotate(r.begin(), std::find(r.begin(), r.end(), 5u), r.end());
  EXPECT_EQ(r, (Ids{5, 6, 7, 2, 8}));
  Ids nb;
  c.SortedNeighbours(0, nb);
  EXPECT_EQ(nb, (Ids{2, 5, 6, 7, 8}));
  c.SortedNeighbours(8, nb);
  EXPECT_EQ(nb, (Ids{0, 2, 3, 4, 5}));
  c.SortedNeighbours(5, nb);
  EXPECT_EQ(nb, (Ids{0, 1, 4, 6, 8}));
  c.SortedNeighbours(1, nb);  // untouched
  EXPECT_EQ(nb, (Ids{2, 3, 4, 5, 6, 7}));
  // Every vertex still has a closed fan, and the collapse undoes the split.
  for (uint32_t v = 0; v < c.vertex_count(); ++v) EXPECT_TRUE(c.CyclicRing(v, r)) << v;
  EXPECT_EQ(Collapse(c.Indices(), 0, n), in);
}

TEST(SplitConnectivity, RandomSplitSequencesCollapseBackToTheOriginal) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 20; ++trial) {
    const uint32_t k = 3 + trial % 6;
    const Ids in = Bipyramid(k);
    SplitConnectivity c;
    ASSERT_TRUE(c.Reset(k + 2, in).ok());
    struct Done {
      uint32_t w, n;
      Ids before;
    };
    std::vector<Done> done;
    Ids ring;
    for (int s = 0; s < 25; ++s) {
      const uint32_t w = rng() % c.vertex_count();
      ASSERT_TRUE(c.CyclicRing(w, ring)) << "trial " << trial << " split " << s;
      const size_t a = rng() % ring.size();
      const size_t b = (a + 1 + rng() % (ring.size() - 1)) % ring.size();  // b != a
      Ids before = c.Indices();
      const uint32_t expected = c.vertex_count();
      const uint32_t n = c.SplitAt(w, ring, a, b);
      ASSERT_EQ(n, expected);
      ASSERT_EQ(c.face_count() * 3, before.size() + 6);
      done.push_back({w, n, std::move(before)});
    }
    // Every vertex keeps a closed fan; the mesh stays closed (each directed
    // edge once, with its opposite).
    for (uint32_t v = 0; v < c.vertex_count(); ++v) ASSERT_TRUE(c.CyclicRing(v, ring)) << v;
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    for (const Face& f : c.faces())
      for (int e = 0; e < 3; ++e) edges.push_back({f[e], f[(e + 1) % 3]});
    std::sort(edges.begin(), edges.end());
    EXPECT_EQ(std::adjacent_find(edges.begin(), edges.end()), edges.end());
    for (const auto& e : edges) EXPECT_TRUE(std::binary_search(edges.begin(), edges.end(), std::make_pair(e.second, e.first)));
    // Collapsing in reverse order gives every intermediate state back.
    Ids now = c.Indices();
    for (size_t i = done.size(); i-- > 0;) {
      now = Collapse(now, done[i].w, done[i].n);
      ASSERT_EQ(now, done[i].before) << "trial " << trial << " split " << i;
    }
    EXPECT_EQ(now, in);
  }
}

TEST(SplitConnectivity, IsolatedVerticesTakeTheNextId) {
  SplitConnectivity c;
  ASSERT_TRUE(c.Reset(6, Bipyramid(4)).ok());
  EXPECT_EQ(c.AddIsolatedVertex(), 6u);
  EXPECT_EQ(c.faces_of(6).size(), 0u);
  Ids ring, nb;
  EXPECT_FALSE(c.CyclicRing(6, ring));
  c.SortedNeighbours(6, nb);
  EXPECT_TRUE(nb.empty());
  ASSERT_TRUE(c.CyclicRing(0, ring));
  EXPECT_EQ(c.SplitAt(0, ring, 2, 0), 7u);
}

TEST(SplitConnectivity, SortedNeighboursOnNonManifoldVertices) {
  SplitConnectivity c;
  ASSERT_TRUE(c.Reset(8, {0, 5, 6, 0, 6, 2, 0, 1, 2, 0, 2, 7, 3, 0, 1}).ok());
  Ids nb;
  c.SortedNeighbours(0, nb);
  EXPECT_EQ(nb, (Ids{1, 2, 3, 5, 6, 7}));
  c.SortedNeighbours(4, nb);
  EXPECT_TRUE(nb.empty());
}

// A refinement in two phases, as a parallel decoder would apply it
// (docs/results/decode-profile.md): every split's ring walked first, each with its
// own RingWalk, before any split is applied; then the splits applied in
// order from the recorded rings and triangles. The rings and the resulting
// connectivity are the serial walk-then-split ones, on every refinement of
// a real hierarchy (the split vertices are pairwise non-adjacent).
TEST(SplitConnectivity, RingsWalkedBeforeTheirRefinementSplitAsTheSerialOnes) {
  const ProgressiveEncoded enc = test_util::EncodeWithoutDraco(test_util::RippledSphere(40, 60));
  ASSERT_GT(enc.mesh.refinements.size(), 3u);
  SplitConnectivity serial, phased;
  ASSERT_TRUE(serial.Reset(static_cast<uint32_t>(enc.mesh.base.vertex_count()), enc.mesh.base.indices).ok());
  ASSERT_TRUE(phased.Reset(static_cast<uint32_t>(enc.mesh.base.vertex_count()), enc.mesh.base.indices).ok());
  std::vector<uint32_t> ring;
  size_t splits = 0;
  for (const Refinement& r : enc.mesh.refinements) {
    const size_t k = r.split_count();
    std::vector<std::vector<uint32_t>> rings(k);
    std::vector<SplitConnectivity::RingWalk> walks(k);
    for (size_t j = 0; j < k; ++j) ASSERT_TRUE(phased.CyclicRing(r.split_vertices[j], rings[j], walks[j]));
    for (size_t j = 0; j < k; ++j) {
      const uint32_t w = r.split_vertices[j];
      ASSERT_TRUE(serial.CyclicRing(w, ring));
      ASSERT_EQ(rings[j], ring) << "split " << j;
      size_t a_at = 0, b_at = 0;
      ASSERT_TRUE(WingPositions(ring, r.wings[j], &a_at, &b_at));
      ASSERT_EQ(phased.SplitAt(w, rings[j].data(), walks[j].faces.data(), rings[j].size(), a_at, b_at), serial.SplitAt(w, ring, a_at, b_at));
      ++splits;
    }
    ASSERT_EQ(phased.Indices(), serial.Indices());
  }
  EXPECT_GT(splits, 1000u);
}

}  // namespace
}  // namespace meshstream
