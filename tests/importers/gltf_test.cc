// glTF import and export on real assets from ../shared/models/gltf.
#include <gtest/gtest.h>

#include "codec/metrics/grid_equality.h"
#include "codec/metrics/hausdorff.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ModelPath;
using test_util::TempDir;

Scene MustImport(const std::string& path) {
  auto scene = ImportFile(path);
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  return scene.ok() ? std::move(scene).value() : Scene{};
}

TEST(GltfImport, TwoCylinderEngineHasItsSceneGraph) {
  const Scene s = MustImport(ModelPath("gltf/2CylinderEngine.glb"));
  EXPECT_EQ(s.nodes.size(), 82u);
  EXPECT_EQ(s.meshes.size(), 29u);
  EXPECT_EQ(s.total_primitives(), 34u);
  EXPECT_EQ(s.total_vertices(), 55843u);
  EXPECT_EQ(s.source_vertices, 55843u);
  EXPECT_EQ(s.total_faces(), 75730u);
  EXPECT_EQ(s.scenes.size(), 1u);
  EXPECT_NE(s.materials_json, "[]");
  for (const Mesh& m : s.meshes)
    for (const Primitive& p : m.primitives) {
      EXPECT_FALSE(p.normals.empty());
      EXPECT_GE(p.material, 0);
    }
}

TEST(GltfImport, DracoCopyOfTheEngineHasTheSameGeometry) {
  const Scene plain = MustImport(ModelPath("gltf/2CylinderEngine.glb"));
  const Scene draco = MustImport(ModelPath("gltf/draco-2CylinderEngine/2CylinderEngine.gltf"));
  EXPECT_EQ(draco.nodes.size(), plain.nodes.size());
  EXPECT_EQ(draco.meshes.size(), plain.meshes.size());
  EXPECT_EQ(draco.total_primitives(), plain.total_primitives());
  const Primitive a = FlattenScene(plain), b = FlattenScene(draco);
  auto d = ComputeSurfaceDistance(a, b);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  // The Draco copy was quantized by its author: the surfaces agree to within
  // a few quantization steps (measured 1.2e-4 of the diagonal).
  EXPECT_LT(d->hausdorff_rel, 5e-4);
  EXPECT_GT(d->hausdorff_rel, 0.0);  // it really is a different (quantized) encoding
}

// Skins and morph targets are carried (tests/importers/gltf_carry_test.cc).
TEST(GltfImport, CarriesSkinsAndMorphTargets) {
  const Scene skin = MustImport(ModelPath("gltf/simple_skin/simple_skin.gltf"));
  EXPECT_EQ(skin.skins.size(), 1u);
  const Scene morph = MustImport(ModelPath("gltf/AnimatedMorphCube/AnimatedMorphCube.gltf"));
  ASSERT_EQ(morph.meshes.size(), 1u);
  EXPECT_EQ(morph.meshes[0].carried.size(), 1u);
}

TEST(GltfExport, PlainRoundTripIsExact) {
  TempDir dir;
  const Scene source = MustImport(ModelPath("gltf/2CylinderEngine.glb"));
  for (const std::string name : {"engine.glb", "engine.gltf"}) {
    ASSERT_TRUE(ExportGltfFile(source, dir.File(name), {}).ok());
    const Scene back = MustImport(dir.File(name));
    ASSERT_EQ(back.meshes.size(), source.meshes.size());
    for (size_t m = 0; m < source.meshes.size(); ++m) {
      ASSERT_EQ(back.meshes[m].primitives.size(), source.meshes[m].primitives.size());
      for (size_t k = 0; k < source.meshes[m].primitives.size(); ++k) {
        const Primitive& a = source.meshes[m].primitives[k];
        const Primitive& b = back.meshes[m].primitives[k];
        EXPECT_EQ(a.positions, b.positions) << name << " mesh " << m;
        EXPECT_EQ(a.indices, b.indices) << name << " mesh " << m;
        EXPECT_EQ(a.material, b.material);
      }
    }
    EXPECT_EQ(back.materials_json, source.materials_json);
    EXPECT_EQ(back.nodes.size(), source.nodes.size());
    for (size_t i = 0; i < source.nodes.size(); ++i) {
      EXPECT_EQ(back.nodes[i].children, source.nodes[i].children);
      EXPECT_EQ(back.nodes[i].matrix, source.nodes[i].matrix);
    }
  }
}

TEST(GltfExport, TexturedBoxKeepsImageAndMaterialThroughDraco) {
  TempDir dir;
  const Scene source = MustImport(ModelPath("gltf/BoxTextured.glb"));
  ASSERT_EQ(source.images.size(), 1u);
  EXPECT_EQ(source.images[0].mime_type, "image/png");
  ExportOptions options;
  options.draco = true;
  ASSERT_TRUE(ExportGltfFile(source, dir.File("box.glb"), options).ok());
  const Scene back = MustImport(dir.File("box.glb"));
  ASSERT_EQ(back.images.size(), 1u);
  EXPECT_EQ(back.images[0].bytes, source.images[0].bytes);
  EXPECT_EQ(back.materials_json, source.materials_json);
  EXPECT_EQ(back.textures_json, source.textures_json);
  ASSERT_EQ(back.meshes[0].primitives[0].texcoords.size(), 1u);
  auto same = CompareOnGrid(source.meshes[0].primitives[0], back.meshes[0].primitives[0], 11);
  ASSERT_TRUE(same.ok());
  EXPECT_TRUE(same->equal) << same->differing() << " faces differ";
}

TEST(GltfExport, DracoPositionsLandOnTheBriefGridOfEveryPrimitive) {
  const Scene source = MustImport(ModelPath("gltf/2CylinderEngine.glb"));
  ExportOptions options;
  options.draco = true;
  options.draco_options.qp = 14;
  auto glb = ExportGlb(source, options);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  auto back = ImportGltfBytes(glb.value(), "", "memory.glb", {});
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  for (size_t m = 0; m < source.meshes.size(); ++m) {
    for (size_t k = 0; k < source.meshes[m].primitives.size(); ++k) {
      Primitive a = source.meshes[m].primitives[k];
      // Faces that repeat a vertex cannot be Draco-encoded and are dropped.
      std::vector<uint32_t> kept;
      for (size_t f = 0; f < a.face_count(); ++f) {
        const uint32_t* t = &a.indices[3 * f];
        if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) kept.insert(kept.end(), t, t + 3);
      }
      a.indices = kept;
      auto same = CompareOnGrid(a, back->meshes[m].primitives[k], 14);
      ASSERT_TRUE(same.ok());
      EXPECT_TRUE(same->equal) << "mesh " << m << " primitive " << k << ": " << same->differing() << " faces differ";
    }
  }
}

TEST(GltfExport, RefusesUnknownOutputExtension) {
  TempDir dir;
  const Scene source = MustImport(ModelPath("gltf/BoxTextured.glb"));
  const Status s = ExportGltfFile(source, dir.File("box.fbx"), {});
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshstream
