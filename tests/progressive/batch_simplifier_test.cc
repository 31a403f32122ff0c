// The batch simplifier at scale (issue 24): its candidate edges are kept
// sorted between batches and only the edges at collapsed vertices are
// evaluated again. That must choose exactly what evaluating every edge before
// every batch chose: the check compares the two lists before each batch on
// shared models with seams (spot), coincident vertices and locks (horse), and
// a plain closed surface (the bunny).
#include <gtest/gtest.h>

#include "codec/mesh/quantized_mesh.h"
#include "codec/progressive/batch_simplifier.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

StatusOr<QuantizedMesh> Model(const std::string& file) {
  MS_ASSIGN_OR_RETURN(Scene scene, ImportFile(test_util::ModelPath(file)));
  if (scene.meshes.empty() || scene.meshes[0].primitives.empty()) return InvalidInput(file + ": no primitive");
  return QuantizePrimitive(scene.meshes[0].primitives[0], QuantizationParams{});  // qp 11
}

TEST(BatchSimplifier, CandidatesKeptUpToDateEqualAFreshEvaluationBeforeEveryBatch) {
  for (const char* file : {"stanford-bunny.obj", "horse.ply", "spot.obj"}) {
    auto mesh = Model(file);
    ASSERT_TRUE(mesh.ok()) << file << ": " << mesh.status().ToString();
    SimplifyOptions options;
    options.collapse_seams = true;
    options.check_candidates = true;
    auto h = SimplifyInBatches(mesh.value(), options);
    ASSERT_TRUE(h.ok()) << file << ": " << h.status().ToString();
    EXPECT_GT(h->batches.size(), 10u) << file;
    // And the check is not idle: the same run without it chooses the same.
    options.check_candidates = false;
    auto plain = SimplifyInBatches(mesh.value(), options);
    ASSERT_TRUE(plain.ok()) << file;
    ASSERT_EQ(plain->batches.size(), h->batches.size()) << file;
    for (size_t b = 0; b < h->batches.size(); ++b) {
      ASSERT_EQ(plain->batches[b].collapses.size(), h->batches[b].collapses.size()) << file << " batch " << b;
      for (size_t c = 0; c < h->batches[b].collapses.size(); ++c) {
        const Collapse& x = h->batches[b].collapses[c];
        const Collapse& y = plain->batches[b].collapses[c];
        ASSERT_TRUE(x.u == y.u && x.v == y.v && x.a == y.a && x.b == y.b && x.delta == y.delta)
            << file << " batch " << b << " collapse " << c;
      }
    }
  }
}

TEST(BatchSimplifier, TheHierarchyRecordsSplitVectorsAndTheCleanedTriangleCount) {
  auto mesh = Model("fandisk.obj");
  ASSERT_TRUE(mesh.ok()) << mesh.status().ToString();
  QuantizedMesh m = std::move(mesh).value();
  const uint64_t faces = m.face_count();
  // A triangle that repeats an index is removed, and counted.
  m.indices.insert(m.indices.end(), {0, 0, 1});
  auto h = SimplifyInBatches(m, SimplifyOptions{});
  ASSERT_TRUE(h.ok()) << h.status().ToString();
  EXPECT_EQ(h->removed_faces, 1u);
  EXPECT_EQ(h->input_faces, faces);
  // The first batch acts on the input: each delta is u - v there.
  for (const Collapse& c : h->batches[0].collapses) {
    for (int k = 0; k < 3; ++k) ASSERT_EQ(c.delta[k], m.positions[c.u][k] - m.positions[c.v][k]);
  }
}

// A triangle given twice (here reversed) locks its three vertices: none is
// collapsed, and the other vertices collapse as before.
TEST(BatchSimplifier, ADuplicatedTriangleLocksItsVertices) {
  auto mesh = Model("fandisk.obj");
  ASSERT_TRUE(mesh.ok()) << mesh.status().ToString();
  QuantizedMesh m = std::move(mesh).value();
  auto plain = SimplifyInBatches(m, SimplifyOptions{});
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  const uint32_t a = m.indices[300], b = m.indices[301], c = m.indices[302];
  m.indices.insert(m.indices.end(), {c, b, a});
  auto h = SimplifyInBatches(m, SimplifyOptions{});
  ASSERT_TRUE(h.ok()) << h.status().ToString();
  EXPECT_GT(h->locked_vertices, plain->locked_vertices);
  size_t collapses = 0;
  for (const CollapseBatch& batch : h->batches) {
    for (const Collapse& col : batch.collapses) {
      ++collapses;
      for (uint32_t x : {a, b, c}) {
        ASSERT_NE(col.u, x);
        ASSERT_NE(col.v, x);
      }
    }
  }
  EXPECT_GT(collapses, 0u);
}

}  // namespace
}  // namespace meshstream
