// The four cases of the paper (section 4.3) on a mesh whose answer is known:
// a flat hexagonal fan around w = vertex 0 in the plane z = 100, split into
// w (moving to x = 88) and a new vertex 7 (at x = 112) that takes the
// triangles next to the ring vertex 1 at +x; its wings are vertices 6 and 2.
#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "codec/progressive/midpoint.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"
#include "codec/recovery/prediction.h"
#include "codec/recovery/recover_split.h"

namespace meshstream {
namespace {

const Vec3i kW = {100, 100, 100};
const std::vector<Vec3i> kRing = {{140, 100, 100}, {115, 135, 100}, {75, 135, 100},
                                  {60, 100, 100},  {75, 65, 100},   {115, 65, 100}};
const Vec3i kU = {88, 100, 100}, kV = {112, 100, 100};

RefinementState Fan() {
  QuantizedMesh m;
  m.positions.push_back(kW);
  m.positions.insert(m.positions.end(), kRing.begin(), kRing.end());
  for (uint32_t k = 0; k < 6; ++k) m.indices.insert(m.indices.end(), {0, k + 1, (k + 1) % 6 + 1});
  RefinementState s;
  EXPECT_TRUE(s.Reset(m).ok());
  return s;
}

// The split as the encoder would code it.
Refinement TrueSplit() {
  RefinementState s = Fan();
  std::vector<uint32_t> ring;
  EXPECT_TRUE(s.connectivity.CyclicRing(0, ring));
  EXPECT_EQ(ring, (std::vector<uint32_t>{1, 2, 3, 4, 5, 6}));
  Refinement r;
  r.vertices_before = 7;
  r.split_vertices = {0};
  r.wings = {WingsOf(ring, /*a_at=*/1, /*b_at=*/5)};  // a = vertex 2, b = vertex 6
  r.position_delta = {{kU[0] - kV[0], kU[1] - kV[1], kU[2] - kV[2]}};
  for (int k = 0; k < 3; ++k) EXPECT_EQ(Midpoint(kU[k], kV[k]), kW[k]);
  return r;
}

std::set<uint32_t> Neighbours(const RefinementState& s, uint32_t v) {
  std::vector<uint32_t> out;
  s.connectivity.SortedNeighbours(v, out);
  return {out.begin(), out.end()};
}

bool AnyCollinear(const RefinementState& s) {
  for (const Face& f : s.connectivity.faces()) {
    const Vec3i &a = s.positions[f[0]], &b = s.positions[f[1]], &c = s.positions[f[2]];
    const int64_t e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, g[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    if (e[1] * g[2] - e[2] * g[1] == 0 && e[2] * g[0] - e[0] * g[2] == 0 && e[0] * g[1] - e[1] * g[0] == 0) return true;
  }
  return false;
}

RefinementState Recover(bool structure, bool geometry, RecoveryStats* stats, Recovery mode = Recovery::kPredict) {
  RefinementState s = Fan();
  const Refinement r = TrueSplit();
  RecoveryScratch scratch;
  EXPECT_TRUE(RecoverSplit(r, 0, structure, geometry, mode, &s, &scratch, stats).ok());
  return s;
}

TEST(SplitPrediction, Case1BothArrivedIsTheExactSplit) {
  RecoveryStats stats;
  const RefinementState s = Recover(true, true, &stats);
  EXPECT_EQ(stats.exact, 1u);
  EXPECT_EQ(s.positions[0], kU);
  EXPECT_EQ(s.positions[7], kV);
  EXPECT_EQ(Neighbours(s, 7), (std::set<uint32_t>{0, 1, 2, 6}));
  EXPECT_EQ(Neighbours(s, 0), (std::set<uint32_t>{2, 3, 4, 5, 6, 7}));
  EXPECT_TRUE(std::all_of(s.reliable.begin(), s.reliable.end(), [](uint8_t r) { return r == 1; }));
}

TEST(SplitPrediction, Case3StructureFromArrivedGeometryFindsTheTrueWings) {
  RecoveryStats stats;
  const RefinementState s = Recover(false, true, &stats);
  EXPECT_EQ(stats.predicted_structure, 1u);
  EXPECT_EQ(s.positions[0], kU);  // geometry arrived: exact positions
  EXPECT_EQ(s.positions[7], kV);
  EXPECT_EQ(Neighbours(s, 7), (std::set<uint32_t>{0, 1, 2, 6}));
  // Predicted structure: w, the new vertex and the ring vertices it joined.
  for (uint32_t v : {0u, 7u, 1u, 2u, 6u}) EXPECT_EQ(s.reliable[v], 0) << v;
  for (uint32_t v : {3u, 4u, 5u}) EXPECT_EQ(s.reliable[v], 1) << v;
}

TEST(SplitPrediction, Case4GeometryPredictedOnTheArrivedStructure) {
  RecoveryStats stats;
  const RefinementState s = Recover(true, false, &stats);
  EXPECT_EQ(stats.predicted_geometry, 1u);
  EXPECT_EQ(Neighbours(s, 7), (std::set<uint32_t>{0, 1, 2, 6}));  // structure as coded
  const Vec3i u = s.positions[0], v = s.positions[7];
  // The fan is symmetric about y = 100 and flat: the prediction stays on the
  // axis, the new vertex on the +x side it was joined to, w opposite, their
  // midpoint on w's coarse position.
  EXPECT_EQ(v[1], 100);
  EXPECT_EQ(u[1], 100);
  EXPECT_EQ(v[2], 100);
  EXPECT_EQ(u[2], 100);
  EXPECT_GT(v[0], 100);
  EXPECT_LT(u[0], 100);
  EXPECT_LE(std::abs((u[0] + v[0]) / 2 - 100), 1);
  EXPECT_EQ(s.reliable[0], 0);
  EXPECT_EQ(s.reliable[7], 0);
  for (uint32_t x = 1; x <= 6; ++x) EXPECT_EQ(s.reliable[x], 1) << x;  // rings as coded
  EXPECT_FALSE(AnyCollinear(s));
}

TEST(SplitPrediction, Case2BothPredictedJoinsTheFarthestEdge) {
  RecoveryStats stats;
  const RefinementState s = Recover(false, false, &stats);
  EXPECT_EQ(stats.predicted_both, 1u);
  EXPECT_EQ(s.positions.size(), 8u);
  EXPECT_EQ(s.connectivity.face_count(), 8u);
  // The ring edge farthest from w in the plane z = 100: (vertex 3, 4) or
  // (4, 5) are at 36.8, the others nearer; the first wins.
  double far = -1;
  uint32_t far_k = 0;
  for (uint32_t k = 0; k < 6; ++k) {
    const Vec3i &p = kRing[k], &q = kRing[(k + 1) % 6];
    const double dx = q[0] - p[0], dy = q[1] - p[1];
    const double t = std::clamp(((kW[0] - p[0]) * dx + (kW[1] - p[1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
    const double d = std::hypot(p[0] + t * dx - kW[0], p[1] + t * dy - kW[1]);
    if (d > far) {
      far = d;
      far_k = k;
    }
  }
  const std::set<uint32_t> n = Neighbours(s, 7);
  EXPECT_TRUE(n.count(0));
  EXPECT_TRUE(n.count(far_k + 1) && n.count((far_k + 1) % 6 + 1)) << "farthest edge " << far_k;
  const Vec3i u = s.positions[0], v = s.positions[7];
  EXPECT_EQ(u[2], 100);  // stays in the plane
  EXPECT_EQ(v[2], 100);
  for (int c = 0; c < 2; ++c) EXPECT_LE(std::abs((u[c] + v[c]) / 2 - kW[c]), 1) << c;
  EXPECT_FALSE(AnyCollinear(s));
  EXPECT_EQ(s.reliable[0], 0);
  EXPECT_EQ(s.reliable[7], 0);
}

TEST(SplitPrediction, StructureThatDoesNotFitTheRingFallsBackToPrediction) {
  RefinementState s = Fan();
  Refinement r = TrueSplit();
  r.wings[0] = {9, 3};  // rank 9 among 6 neighbours
  RecoveryStats stats;
  RecoveryScratch scratch;
  ASSERT_TRUE(RecoverSplit(r, 0, true, true, Recovery::kPredict, &s, &scratch, &stats).ok());
  EXPECT_EQ(stats.structure_fallbacks, 1u);
  EXPECT_EQ(stats.predicted_structure, 1u);
  EXPECT_EQ(Neighbours(s, 7), (std::set<uint32_t>{0, 1, 2, 6}));  // derived from the geometry
}

TEST(SplitPrediction, LwopAbandonsALostSplitAndKeepsItsIdFree) {
  RecoveryStats stats;
  const RefinementState s = Recover(true, false, &stats, Recovery::kLwop);
  EXPECT_EQ(stats.abandoned, 1u);
  EXPECT_EQ(s.positions[0], kW);  // w stays where it was
  EXPECT_TRUE(s.flags[7] & kAbsent);
  EXPECT_EQ(s.connectivity.face_count(), 6u);
  const QuantizedMesh snapshot = s.Snapshot(QuantizedMesh{});
  EXPECT_EQ(snapshot.vertex_count(), 7u);  // the id is reserved, the vertex left out
  // A later split of a vertex next to the abandoned one is abandoned too.
  EXPECT_EQ(s.flags[1] & kRingInexact, kRingInexact);
}

}  // namespace
}  // namespace meshstream
