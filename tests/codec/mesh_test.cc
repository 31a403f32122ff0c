#include "codec/mesh/mesh.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "codec/mesh/mesh_health.h"
#include "codec/mesh/scene_flatten.h"

namespace meshstream {
namespace {

Primitive TwoTriangles() {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.indices = {0, 1, 2, 0, 2, 3};
  return p;
}

TEST(ValidatePrimitive, AcceptsAConsistentPrimitive) {
  EXPECT_TRUE(ValidatePrimitive(TwoTriangles()).ok());
}

TEST(ValidatePrimitive, NamesTheBadIndex) {
  Primitive p = TwoTriangles();
  p.indices[4] = 9;
  const Status s = ValidatePrimitive(p);
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("indices[4]"), std::string::npos) << s.message();
}

TEST(ValidatePrimitive, RefusesNonFinitePositionsAndShortAttributes) {
  Primitive p = TwoTriangles();
  p.positions[2][1] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(ValidatePrimitive(p).message().find("POSITION[2]"), std::string::npos);
  p = TwoTriangles();
  p.positions[1][0] = std::numeric_limits<float>::infinity();
  EXPECT_NE(ValidatePrimitive(p).message().find("finite"), std::string::npos);
  p = TwoTriangles();
  p.normals.resize(3);
  EXPECT_NE(ValidatePrimitive(p).message().find("NORMAL"), std::string::npos);
}

TEST(MeshHealth, CountsUnreferencedDegenerateAndNonManifold) {
  Primitive p = TwoTriangles();
  p.positions.push_back({5, 5, 5});                 // 4: unreferenced
  p.positions.push_back({0.5f, 0.5f, 1});           // 5
  p.positions.push_back({2, 2, 0});                 // 6: collinear with 0 and 2
  p.indices.insert(p.indices.end(), {0, 2, 5});     // third face on edge 0-2: non-manifold
  p.indices.insert(p.indices.end(), {0, 2, 6});     // collinear: degenerate, fourth face on 0-2
  p.indices.insert(p.indices.end(), {1, 1, 3});     // repeated index: degenerate
  const MeshHealth h = ComputeHealth(p);
  EXPECT_EQ(h.vertices, 7u);
  EXPECT_EQ(h.faces, 5u);
  EXPECT_EQ(h.unreferenced_vertices, 1u);
  EXPECT_EQ(h.degenerate_faces, 2u);
  EXPECT_EQ(h.nonmanifold_edges, 1u);
  EXPECT_EQ(h.bbox.max[0], 5.0);
  EXPECT_EQ(h.referenced_bbox.max[0], 2.0);
}

TEST(SceneFlatten, AppliesNodeTransformsDownTheHierarchy) {
  Scene scene = SceneFromPrimitive(TwoTriangles(), "quad");
  scene.nodes[0].mesh = -1;
  scene.nodes[0].translation = {10, 0, 0};
  scene.nodes[0].children = {1};
  Node child;
  child.mesh = 0;
  child.scale = {2, 2, 2};
  scene.nodes.push_back(child);
  ASSERT_TRUE(ValidateScene(scene).ok());
  const Primitive flat = FlattenScene(scene);
  ASSERT_EQ(flat.vertex_count(), 4u);
  EXPECT_FLOAT_EQ(flat.positions[2][0], 12.0f);
  EXPECT_FLOAT_EQ(flat.positions[2][1], 2.0f);
}

TEST(SceneFlatten, MeshScalesAreTheLargestOfTheirInstances) {
  Scene scene = SceneFromPrimitive(TwoTriangles(), "quad");
  scene.meshes.push_back(scene.meshes[0]);  // mesh 1: no node shows it
  scene.nodes[0].scale = {3, 1, 1};
  scene.nodes[0].children = {1};
  Node child;
  child.mesh = 0;
  child.scale = {0.5, 0.5, 0.5};  // 1.5 in the world, under its parent's 3
  scene.nodes.push_back(child);
  ASSERT_TRUE(ValidateScene(scene).ok());
  const std::vector<double> scales = MeshScales(scene);
  ASSERT_EQ(scales.size(), 2u);
  EXPECT_DOUBLE_EQ(scales[0], 3.0);
  EXPECT_EQ(scales[1], 0.0);
  scene.scenes.clear();  // no scene: every mesh once, unscaled
  EXPECT_EQ(MeshScales(scene), (std::vector<double>{1.0, 1.0}));
}

TEST(SceneFlatten, IdentityKeepsPositionsBitExact) {
  Primitive p = TwoTriangles();
  p.positions[1] = {0.1f, 0.7f, 0.3f};
  const Primitive flat = FlattenScene(SceneFromPrimitive(p, "x"));
  EXPECT_EQ(flat.positions, p.positions);
  EXPECT_EQ(flat.indices, p.indices);
}

TEST(SceneFlatten, RotationQuaternionTurnsXIntoY) {
  Scene scene = SceneFromPrimitive(TwoTriangles(), "quad");
  const double s = std::sqrt(0.5);
  scene.nodes[0].rotation = {0, 0, s, s};  // 90 degrees about +Z
  const Primitive flat = FlattenScene(scene);
  EXPECT_NEAR(flat.positions[1][0], 0.0f, 1e-6);
  EXPECT_NEAR(flat.positions[1][1], 1.0f, 1e-6);
}

}  // namespace
}  // namespace meshstream
