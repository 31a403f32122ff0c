// What a session sends, planned from a real artifact of the pipeline: every
// block is the stream's own (ProgressiveStream::Parse of the stored blob),
// the refinements go level by level across the primitives, max_level cuts
// them, and a layout of another artifact is refused.
#include <algorithm>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/streaming/session_messages.h"
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

TEST(SessionPlan, EveryBlockIsTheStreamsOwnInTheScenesOrder) {
  // The engine has many primitives: the scene's order is visible.
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
  // The scene's order (codec/progressive/scene_levels.h): by the error the
  // primitive still has before the refinement, larger first; each
  // primitive's own in order; levels are prefixes of it.
  std::vector<uint32_t> next(plan->primitives.size(), 0);
  double before = std::numeric_limits<double>::infinity();
  uint32_t level = 1;
  bool interleaved = false;  // some refinement comes before a lower one of another primitive
  for (const PlannedRefinement& r : plan->refinements) {
    const std::vector<double>& errors = layout->primitives[r.primitive].residual_error;
    ASSERT_EQ(errors.size(), plan->primitives[r.primitive].refinements + 1) << "the pipeline records the errors";
    EXPECT_EQ(r.refinement, next[r.primitive]++) << "primitive " << r.primitive;
    EXPECT_LE(errors[r.refinement], before);
    before = errors[r.refinement];
    EXPECT_GE(r.level, level);
    level = r.level;
    const std::vector<uint32_t>& at = plan->primitives[r.primitive].level_refinements;
    ASSERT_EQ(at.size(), plan->levels);
    EXPECT_TRUE(r.level == 1 ? r.refinement < at[0] : at[r.level - 2] <= r.refinement && r.refinement < at[r.level - 1]);
    for (uint32_t n : next) interleaved = interleaved || n + 1 < r.refinement;
  }
  EXPECT_TRUE(interleaved) << "the engine's errors differ enough that the order is not level by level";
  for (size_t i = 0; i < plan->primitives.size(); ++i) {
    EXPECT_EQ(next[i], plan->primitives[i].refinements);
    EXPECT_EQ(plan->primitives[i].level_refinements.back(), plan->primitives[i].refinements);
  }
  std::set<std::pair<uint32_t, uint32_t>> seen;
  for (const PlannedRefinement& r : plan->refinements) EXPECT_TRUE(seen.insert({r.primitive, r.refinement}).second);
  EXPECT_EQ(static_cast<int64_t>(plan->levels), p.summary.levels);

  // A session cut at a level gets that level's refinements of each primitive.
  const SessionPlan cut = CutPlan(plan.value(), 5);
  EXPECT_EQ(cut.levels, 5u);
  size_t expected = 0;
  for (size_t i = 0; i < cut.primitives.size(); ++i) {
    EXPECT_EQ(cut.primitives[i].refinements, plan->primitives[i].level_refinements[4]);
    EXPECT_EQ(cut.primitives[i].level_refinements.size(), 5u);
    expected += cut.primitives[i].refinements;
  }
  EXPECT_EQ(cut.refinements.size(), expected);
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

TEST(SessionPlan, AViewOrdersTheEngineAndKeepsEveryRefinement) {
  const ProcessResult p = Process("gltf/2CylinderEngine.glb");
  auto full = PlanSession(p.glb, p.summary.layout_json, -1);
  ASSERT_TRUE(full.ok()) << full.status().ToString();
  ASSERT_TRUE(ViewCanOrder(full.value()));
  // Every primitive has its box in the scene (nodes applied): the scene's box holds them.
  Box all = full->primitives[0].bounds;
  for (const PlannedPrimitive& pr : full->primitives) {
    ASSERT_TRUE(pr.has_bounds);
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(pr.bounds.lo[a], pr.bounds.hi[a]);
      all.lo[a] = std::min(all.lo[a], pr.bounds.lo[a]);
      all.hi[a] = std::max(all.hi[a], pr.bounds.hi[a]);
    }
  }
  // A camera at one end of the engine's longest axis, looking along it.
  int axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (all.hi[a] - all.lo[a] > all.hi[axis] - all.lo[axis]) axis = a;
  }
  Vec3d eye, target;
  for (int a = 0; a < 3; ++a) eye[a] = target[a] = (all.lo[a] + all.hi[a]) / 2;
  const double extent = all.hi[axis] - all.lo[axis];
  eye[axis] = all.hi[axis] + 0.2 * extent;
  const View view = LookAtView(eye, target, 40, 1280, 720, extent * 0.01, extent * 10);
  const SessionPlan seen = ViewPlan(full.value(), view, -1);
  ASSERT_EQ(seen.refinements.size(), full->refinements.size());
  std::multiset<std::pair<uint32_t, uint32_t>> a, b;
  for (const PlannedRefinement& r : full->refinements) a.insert({r.primitive, r.refinement});
  for (const PlannedRefinement& r : seen.refinements) b.insert({r.primitive, r.refinement});
  EXPECT_EQ(a, b);
  // Each primitive's own refinements keep their order; the whole order changed.
  std::vector<int64_t> last(seen.primitives.size(), -1);
  bool differs = false;
  for (size_t k = 0; k < seen.refinements.size(); ++k) {
    const PlannedRefinement& r = seen.refinements[k];
    EXPECT_EQ(static_cast<int64_t>(r.refinement), last[r.primitive] + 1);
    last[r.primitive] = r.refinement;
    differs = differs || r.primitive != full->refinements[k].primitive;
  }
  EXPECT_TRUE(differs);
  // The levels are the view's: non-decreasing, each primitive's last all of it.
  for (const PlannedPrimitive& pr : seen.primitives) {
    ASSERT_EQ(pr.level_refinements.size(), seen.levels);
    EXPECT_EQ(pr.level_refinements.back(), pr.refinements);
  }
  // Cut at a level: the view's first refinements.
  const SessionPlan three = ViewPlan(full.value(), view, 3);
  EXPECT_EQ(three.levels, 3u);
  for (size_t k = 0; k < three.refinements.size(); ++k) {
    EXPECT_EQ(three.refinements[k].primitive, seen.refinements[k].primitive);
    EXPECT_EQ(three.refinements[k].refinement, seen.refinements[k].refinement);
  }
}

TEST(SessionPlan, AViewFromTheWireIsCheckedFieldByField) {
  v1::View v;
  for (int i = 0; i < 3; ++i) v.add_camera_position(0);
  const View good = LookAtView({0, 0, 5}, {0, 0, 0}, 60, 640, 480, 0.1, 100);
  for (double m : good.view_projection) v.add_view_projection(m);
  v.set_viewport_width(640);
  v.set_viewport_height(480);
  EXPECT_TRUE(FromProto(v).ok());
  v1::View short_camera = v;
  short_camera.mutable_camera_position()->RemoveLast();
  EXPECT_NE(FromProto(short_camera).status().message().find("camera_position"), std::string::npos);
  v1::View long_matrix = v;
  long_matrix.add_view_projection(1);
  EXPECT_NE(FromProto(long_matrix).status().message().find("view_projection"), std::string::npos);
  v1::View no_width = v;
  no_width.set_viewport_width(0);
  EXPECT_EQ(FromProto(no_width).status().code(), StatusCode::kInvalidArgument);
  v1::View nan = v;
  nan.set_view_projection(3, std::numeric_limits<double>::quiet_NaN());
  EXPECT_NE(FromProto(nan).status().message().find("view_projection[3]"), std::string::npos);
}

}  // namespace
}  // namespace meshstream
