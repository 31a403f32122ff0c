// What a session sends, planned from a real artifact of the pipeline: every
// block is the stream's own (ProgressiveStream::Parse of the stored blob),
// the refinements go level by level across the primitives, max_level cuts
// them, and a layout of another artifact is refused.
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/streaming/session_plan.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

ProcessResult Process(const std::string& model) {
  auto settings = ResolveSettings(EncodeSettings{});
  EXPECT_TRUE(settings.ok());
  auto r = ProcessSource(test_util::ModelPath(model), settings.value(), nullptr);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(r).value() : ProcessResult();
}

std::vector<uint8_t> Bytes(const std::vector<uint8_t>& file, const ByteRange& r) {
  return std::vector<uint8_t>(file.begin() + static_cast<long>(r.offset),
                              file.begin() + static_cast<long>(r.offset + r.length));
}

TEST(SessionPlan, EveryBlockIsTheStreamsOwnInLevelOrder) {
  // The engine has many primitives: the level-major order is visible.
  const ProcessResult p = Process("gltf/2CylinderEngine.glb");
  ASSERT_FALSE(p.glb.empty());
  auto plan = PlanSession(p.glb, p.summary.layout_json, -1);
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  ASSERT_GT(plan->primitives.size(), 1u);
  auto layout = ParseStreamLayout(p.summary.layout_json);
  ASSERT_TRUE(layout.ok());
  uint64_t unreliable = 0, control = 0;
  for (size_t i = 0; i < plan->primitives.size(); ++i) {
    const PrimitiveLayout& entry = layout->primitives[i];
    auto stream = ProgressiveStream::Parse(p.glb.data() + entry.stream_blob.offset, entry.stream_blob.length);
    ASSERT_TRUE(stream.ok()) << stream.status().ToString();
    EXPECT_EQ(Bytes(p.glb, plan->primitives[i].header), stream->header);
    EXPECT_EQ(plan->primitives[i].refinements, stream->control.size());
    EXPECT_EQ(plan->primitives[i].draco_attributes.count("POSITION"), 1u) << "the base mesh's Draco ids";
    for (const PlannedRefinement& r : plan->refinements) {
      if (r.primitive != i) continue;
      EXPECT_EQ(Bytes(p.glb, r.control), stream->control[r.refinement]);
      ASSERT_EQ(r.datagrams.size(), stream->datagrams[r.refinement].size());
      for (size_t d = 0; d < r.datagrams.size(); ++d) {
        EXPECT_EQ(Bytes(p.glb, r.datagrams[d]), stream->datagrams[r.refinement][d]);
      }
    }
    unreliable += stream->unreliable_bytes();
    for (const auto& c : stream->control) control += c.size();
  }
  EXPECT_EQ(plan->unreliable_bytes, unreliable);
  EXPECT_EQ(plan->unreliable_bytes, p.summary.unreliable_bytes);
  // Level by level: never a refinement before a lower one of any primitive.
  for (size_t k = 1; k < plan->refinements.size(); ++k) {
    EXPECT_LE(plan->refinements[k - 1].refinement, plan->refinements[k].refinement);
  }
  std::set<std::pair<uint32_t, uint32_t>> seen;
  for (const PlannedRefinement& r : plan->refinements) EXPECT_TRUE(seen.insert({r.primitive, r.refinement}).second);
  EXPECT_EQ(static_cast<int64_t>(plan->levels), p.summary.levels);
  EXPECT_GT(control, 0u);
}

TEST(SessionPlan, MaxLevelCutsEveryPrimitive) {
  const ProcessResult p = Process("spot.obj");
  auto full = PlanSession(p.glb, p.summary.layout_json, -1);
  auto three = PlanSession(p.glb, p.summary.layout_json, 3);
  auto base = PlanSession(p.glb, p.summary.layout_json, 0);
  ASSERT_TRUE(full.ok() && three.ok() && base.ok());
  EXPECT_GT(full->levels, 3u);
  EXPECT_EQ(three->levels, 3u);
  EXPECT_EQ(three->refinements.size(), 3u);
  EXPECT_TRUE(base->refinements.empty());
  EXPECT_EQ(base->unreliable_bytes, 0u);
  EXPECT_LT(three->unreliable_bytes, full->unreliable_bytes);
  EXPECT_EQ(base->primitives[0].base, full->primitives[0].base) << "the base mesh is sent whatever the level";
}

TEST(SessionPlan, ALayoutOfAnotherArtifactIsDataLoss) {
  const ProcessResult spot = Process("spot.obj");
  const ProcessResult fandisk = Process("fandisk.obj");
  auto wrong = PlanSession(spot.glb, fandisk.summary.layout_json, -1);
  EXPECT_EQ(wrong.status().code(), StatusCode::kDataLoss) << wrong.status().ToString();
  auto garbage = PlanSession(spot.glb, "{not json", -1);
  EXPECT_EQ(garbage.status().code(), StatusCode::kDataLoss) << garbage.status().ToString();
}

}  // namespace
}  // namespace meshstream
