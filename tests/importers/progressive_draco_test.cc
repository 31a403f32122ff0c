// The progressive encoder on the shared models, with Draco coding the base
// mesh: decoding every level without loss gives back the quantized input.
#include <chrono>

#include <gtest/gtest.h>

#include "codec/grid_equality.h"
#include "codec/progressive_encoder.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "tests/common/test_util.h"

namespace meshstream {
namespace {

using test_util::ModelPath;

Primitive Load(const std::string& name) {
  auto scene = ImportFile(ModelPath(name));
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  return scene.ok() ? scene->meshes[0].primitives[0] : Primitive{};
}

TEST(ProgressiveDraco, EverySharedModelIsLosslessAtQp11And14) {
  for (const char* name : {"stanford-bunny.obj", "horse.ply", "fandisk.obj", "rocker-arm.obj", "spot.obj"}) {
    const Primitive input = Load(name);
    for (int qp : {11, 14}) {
      ProgressiveEncodeOptions options;
      options.quantization.qp = qp;
      const auto start = std::chrono::steady_clock::now();
      auto enc = EncodeProgressive(input, options, DracoBaseEncoder(7));
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      ASSERT_TRUE(enc.ok()) << name << " qp " << qp << ": " << enc.status().ToString();
      const auto levels = enc->mesh.level_vertices();
      RefinementState state;
      ASSERT_TRUE(state.Reset(enc->mesh.base).ok());
      for (const Refinement& r : enc->mesh.refinements) ASSERT_TRUE(state.ApplyRefinement(r).ok());
      const Primitive decoded = DequantizeMesh(state.Snapshot(enc->mesh.base), -1);
      auto same = CompareOnGrid(input, decoded, qp);
      ASSERT_TRUE(same.ok());
      EXPECT_TRUE(same->equal) << name << " qp " << qp << ": " << same->differing() << " triangles differ";
      EXPECT_EQ(decoded.vertex_count(), enc->input_vertices);
      std::printf("%s qp %d: %zu levels, base %u of %u vertices, base %zu bytes, method %d, %llu locked, %.0f ms\n",
                  name, qp, enc->mesh.refinements.size(), levels.front(), levels.back(), enc->base_bytes.size(),
                  enc->base_method, static_cast<unsigned long long>(enc->locked_vertices), ms);
    }
  }
}

}  // namespace
}  // namespace meshstream
