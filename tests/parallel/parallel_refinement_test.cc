// RefinementPlan (codec/progressive/parallel_refinement.h) on a small real
// mesh: planned splits applied in order are the serial splits, and a split
// whose ring holds another split vertex of the refinement (split bits no
// encoder writes, but a hostile stream can) is not planned.
#include <gtest/gtest.h>

#include "codec/progressive/parallel_refinement.h"
#include "codec/progressive/refinement_state.h"
#include "parallel/fork_join_pool.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

QuantizedMesh Sphere() {
  const Primitive p = test_util::RippledSphere(6, 8);  // pole 0; rings of 8 from vertex 1
  QuantizedMesh q;
  for (const Vec3f& v : p.positions) {
    q.positions.push_back({static_cast<int32_t>(v[0] * 1000), static_cast<int32_t>(v[1] * 1000),
                           static_cast<int32_t>(v[2] * 1000)});
  }
  q.indices = p.indices;
  return q;
}

// A version 1 refinement (no coding tools) of the given split vertices, each
// with the wings at ring positions 0 and 2 and a small split vector.
Refinement RefinementOf(const RefinementState& state, const std::vector<uint32_t>& splits) {
  Refinement r;
  r.vertices_before = state.connectivity.vertex_count();
  r.split_vertices = splits;
  std::vector<uint32_t> ring;
  for (uint32_t w : splits) {
    EXPECT_TRUE(state.connectivity.CyclicRing(w, ring)) << w;
    r.wings.push_back(WingsOf(ring, 0, 2));
    r.position_delta.push_back({10, -4, 6});
  }
  return r;
}

TEST(RefinementPlan, PlannedSplitsAppliedInOrderAreTheSerialSplits) {
  RefinementState serial, planned;
  ASSERT_TRUE(serial.Reset(Sphere()).ok());
  ASSERT_TRUE(planned.Reset(Sphere()).ok());
  // Pairwise non-adjacent: the north pole, a vertex of ring 3, one of ring 5.
  const Refinement r = RefinementOf(serial, {0, 20, 35});
  ASSERT_TRUE(serial.ApplyRefinement(r).ok());

  ForkJoinPool pool(2);
  RefinementPlan plan;
  Refinement decoded = r;
  planned.BeginSplits(r);
  plan.Plan(r, SplitCoding{}, planned, 0, r.split_count(), pool);
  for (size_t j = 0; j < r.split_count(); ++j) {
    ASSERT_EQ(plan.kind(j), RefinementPlan::Kind::kPlanned) << j;
    plan.Apply(r, j, SplitCoding{}, &planned, &decoded);
  }
  planned.EndSplits(r);
  EXPECT_EQ(planned.connectivity.Indices(), serial.connectivity.Indices());
  EXPECT_EQ(planned.positions, serial.positions);
  EXPECT_EQ(planned.twin, serial.twin);
  EXPECT_EQ(planned.flags, serial.flags);
}

// What a plan on two threads makes of each split of `r` on `state`.
std::vector<RefinementPlan::Kind> KindsOf(RefinementState& state, const Refinement& r) {
  ForkJoinPool pool(2);
  RefinementPlan plan;
  state.BeginSplits(r);
  plan.Plan(r, SplitCoding{}, state, 0, r.split_count(), pool);
  state.EndSplits(r);
  std::vector<RefinementPlan::Kind> kinds;
  for (size_t j = 0; j < r.split_count(); ++j) kinds.push_back(plan.kind(j));
  return kinds;
}

using Kinds = std::vector<RefinementPlan::Kind>;
constexpr RefinementPlan::Kind kStop = RefinementPlan::Kind::kStop;
constexpr RefinementPlan::Kind kPlanned = RefinementPlan::Kind::kPlanned;

TEST(RefinementPlan, ASplitNextToAnotherSplitVertexIsNotPlanned) {
  RefinementState state;
  ASSERT_TRUE(state.Reset(Sphere()).ok());
  // Vertex 1 is on the pole's ring: the two splits would depend on their order.
  EXPECT_EQ(KindsOf(state, RefinementOf(state, {0, 1, 20})), (Kinds{kStop, kStop, kPlanned}));
}

TEST(RefinementPlan, WingsThatDoNotFitTheRingAreNotPlanned) {
  RefinementState state;
  ASSERT_TRUE(state.Reset(Sphere()).ok());
  Refinement r = RefinementOf(state, {0, 20});
  r.wings[0] = {0, 200};  // beyond the pole's 8 neighbours
  EXPECT_EQ(KindsOf(state, r), (Kinds{kStop, kPlanned}));
}

}  // namespace
}  // namespace meshstream
