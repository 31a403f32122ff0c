// A level of a scene in the progressive .glb (docs/spec/progressive-format.md,
// "Levels of a scene"): `decode --lod K` applies to each primitive the
// refinements the scene's level K has (codec/progressive/scene_levels.h, from
// the file's "residual_error"); a file without them keeps K refinements of
// each.
#include <algorithm>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

// The refined primitives' vertex counts, in stream order.
std::vector<size_t> VertexCounts(const Scene& scene) {
  std::vector<size_t> out;
  for (const Mesh& m : scene.meshes) {
    for (const Primitive& p : m.primitives) {
      if (p.face_count() > 0) out.push_back(p.vertex_count());
    }
  }
  return out;
}

TEST(SceneLevelsGlb, ALevelAppliesEachPrimitivesCountOfIt) {
  auto scene = ImportFile(test_util::ModelPath("gltf/2CylinderEngine.glb"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  ProgressiveGlbReport report;
  auto glb = EncodeProgressiveGlb(scene.value(), ProgressiveGlbOptions{}, &report);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  std::vector<std::vector<uint32_t>> vertices;
  std::vector<std::vector<double>> errors;
  for (const PrimitiveStreamReport& p : report.primitives) {
    ASSERT_EQ(p.residual_error.size(), p.level_vertices.size());
    vertices.push_back(p.level_vertices);
    errors.push_back(p.residual_error);
  }
  const SceneLevels levels = SceneLevelsOf(vertices, errors);
  ASSERT_GT(levels.levels, 3u);
  EXPECT_EQ(report.Total().level_vertices, SceneLevelVertices(levels, vertices));

  bool differs = false;  // some level is not one refinement of each
  for (uint32_t k : {0u, 1u, levels.levels / 3, levels.levels}) {
    SCOPED_TRACE("level " + std::to_string(k));
    ProgressiveDecodeOptions options;
    options.lod = static_cast<int>(k);
    ProgressiveDecodeReport decoded;
    auto at = DecodeProgressiveGlb(glb.value(), options, &decoded);
    ASSERT_TRUE(at.ok()) << at.status().ToString();
    const std::vector<size_t> counts = VertexCounts(at.value());
    ASSERT_EQ(counts.size(), vertices.size());
    size_t total = 0;
    for (size_t p = 0; p < counts.size(); ++p) {
      EXPECT_EQ(counts[p], vertices[p][levels.At(p, k)]) << "primitive " << p;
      differs = differs || levels.At(p, k) != std::min<uint32_t>(k, vertices[p].size() - 1);
      total += counts[p];
    }
    EXPECT_EQ(decoded.level_vertices[k], total);
    EXPECT_EQ(decoded.levels_applied, k) << "the scene's level, not a primitive's refinement count";
  }
  EXPECT_TRUE(differs);

  // The same file without the errors (as made before them): the JSON
  // blanked in place (spaces keep the GLB's framing), the rest the same.
  std::vector<uint8_t> old = glb.value();
  std::string text(old.begin(), old.end());
  const std::regex field(R"(,"residual_error":\[[^\]]*\])");
  size_t blanked = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), field); it != std::sregex_iterator(); ++it) {
    std::fill(old.begin() + it->position(), old.begin() + it->position() + it->length(), ' ');
    ++blanked;
  }
  ASSERT_EQ(blanked, vertices.size());
  ProgressiveDecodeOptions one;
  one.lod = 1;
  auto plain = DecodeProgressiveGlb(old, one, nullptr);
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  const std::vector<size_t> counts = VertexCounts(plain.value());
  ASSERT_EQ(counts.size(), vertices.size());
  for (size_t p = 0; p < counts.size(); ++p) {
    EXPECT_EQ(counts[p], vertices[p][std::min<size_t>(1, vertices[p].size() - 1)]) << "primitive " << p;
  }
}

}  // namespace
}  // namespace meshstream
