// The progressive .glb's layout (docs/spec/progressive-format.md, "Layout"): every
// primitive's base mesh (and everything else of the scene) comes before any
// refinement, so that a file read up to its first refinement (an HTTP range)
// shows the whole scene at its base level; and the file still decodes to
// every level.
#include <algorithm>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "tests/common/test_vector.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

TEST(GlbLayout, EveryBaseComesBeforeAnyRefinement) {
  auto scene = ImportFile(test_util::ModelPath("gltf/2CylinderEngine.glb"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  ProgressiveGlbReport report;
  auto glb = EncodeProgressiveGlb(scene.value(), ProgressiveGlbOptions{}, &report);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  ASSERT_GT(report.primitives.size(), 10u);

  const nlohmann::json doc = test_util::GlbJson(glb.value());
  const nlohmann::json& views = doc["bufferViews"];
  uint64_t last_other_end = 0, first_refinement = UINT64_MAX;
  std::vector<bool> refinement_view(views.size(), false);
  size_t refined = 0;
  for (const auto& mesh : doc["meshes"]) {
    for (const auto& p : mesh["primitives"]) {
      if (!p.contains("extensions") || !p["extensions"].contains(kProgressiveExtension)) continue;
      ++refined;
      const size_t v = p["extensions"][kProgressiveExtension]["bufferView"];
      refinement_view[v] = true;
      first_refinement = std::min<uint64_t>(first_refinement, views[v].value("byteOffset", uint64_t{0}));
    }
  }
  ASSERT_EQ(refined, report.primitives.size());
  for (size_t v = 0; v < views.size(); ++v) {
    if (refinement_view[v]) continue;
    last_other_end = std::max<uint64_t>(last_other_end, views[v].value("byteOffset", uint64_t{0}) +
                                                            views[v]["byteLength"].get<uint64_t>());
  }
  EXPECT_LE(last_other_end, first_refinement) << "a base mesh or other view after the first refinement";

  ProgressiveDecodeReport decoded;
  ASSERT_TRUE(DecodeProgressiveGlb(glb.value(), ProgressiveDecodeOptions{}, &decoded).ok());
  EXPECT_FALSE(decoded.level_vertices.empty());
}

}  // namespace
}  // namespace meshstream
