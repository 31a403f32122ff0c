// EncodeProgressiveGlbReleasing (importers/progressive_glb.h): the encoder
// that drops each refined primitive's arrays once quantized writes the bytes
// EncodeProgressiveGlb writes, and leaves the rest of the scene as it was.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

TEST(ReleasingEncode, SameBytesAndOnlyTheRefinedArraysReleased) {
  for (const char* file : {"gltf/2CylinderEngine.glb", "gltf/BoxTextured.glb", "spot.obj"}) {
    SCOPED_TRACE(file);
    auto scene = ImportFile(test_util::ModelPath(file));
    ASSERT_TRUE(scene.ok()) << scene.status().ToString();
    ProgressiveGlbReport kept_report, released_report;
    auto kept = EncodeProgressiveGlb(scene.value(), ProgressiveGlbOptions{}, &kept_report);
    ASSERT_TRUE(kept.ok()) << kept.status().ToString();
    const Scene before = scene.value();
    auto released = EncodeProgressiveGlbReleasing(&scene.value(), ProgressiveGlbOptions{}, &released_report);
    ASSERT_TRUE(released.ok()) << released.status().ToString();
    EXPECT_TRUE(kept.value() == released.value());
    EXPECT_EQ(kept_report.file_bytes, released_report.file_bytes);
    // Refined primitives: no arrays left, material kept; the rest unchanged.
    const Scene& after = scene.value();
    ASSERT_EQ(after.meshes.size(), before.meshes.size());
    size_t refined = 0;
    for (size_t m = 0; m < after.meshes.size(); ++m) {
      ASSERT_EQ(after.meshes[m].primitives.size(), before.meshes[m].primitives.size());
      for (size_t k = 0; k < after.meshes[m].primitives.size(); ++k) {
        const Primitive& a = after.meshes[m].primitives[k];
        const Primitive& b = before.meshes[m].primitives[k];
        EXPECT_EQ(a.material, b.material);
        if (b.face_count() == 0) {
          EXPECT_EQ(a.positions, b.positions);
          continue;
        }
        ++refined;
        EXPECT_EQ(a.positions.capacity(), 0u);  // freed, not only emptied
        EXPECT_EQ(a.indices.capacity(), 0u);
        EXPECT_TRUE(a.normals.empty());
        EXPECT_TRUE(a.colors.empty());
      }
      EXPECT_EQ(after.meshes[m].carried.size(), before.meshes[m].carried.size());
    }
    EXPECT_EQ(refined, released_report.primitives.size());
    EXPECT_EQ(after.nodes.size(), before.nodes.size());
    EXPECT_EQ(after.warnings, before.warnings);
  }
}

}  // namespace
}  // namespace meshstream
