// The progressive encoder and decoder in memory, with a stand-in base coder
// that returns the base mesh with its vertices in reverse order (Draco's real
// coder is exercised in the importers tests).
#include <algorithm>
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "codec/progressive/encoder.h"
#include "codec/progressive/midpoint.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/residual_error.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

// The rippled sphere of tests/common/sphere.h, with its positions as normals.
Primitive Sphere(int rings, int segments) {
  Primitive p = test_util::RippledSphere(rings, segments);
  p.normals = p.positions;
  return p;
}

// Reverses the vertex order, as a real coder may reorder.
StatusOr<EncodedBase> ReversingCoder(const QuantizedMesh& base, int) {
  EncodedBase e;
  e.decoded = base;
  const size_t n = base.vertex_count();
  const int ch = base.layout.channels();
  for (size_t v = 0; v < n; ++v) {
    e.decoded.positions[v] = base.positions[n - 1 - v];
    std::copy(base.attributes.begin() + (n - 1 - v) * ch, base.attributes.begin() + (n - v) * ch,
              e.decoded.attributes.begin() + v * ch);
  }
  for (auto& i : e.decoded.indices) i = static_cast<uint32_t>(n - 1 - i);
  e.bytes = {1, 2, 3};
  return e;
}

QuantizedMesh DecodeAll(const ProgressiveEncoded& enc) {
  RefinementState state;
  EXPECT_TRUE(state.Reset(enc.mesh.base).ok());
  for (const Refinement& r : enc.mesh.refinements) EXPECT_TRUE(state.ApplyRefinement(r).ok());
  return state.Snapshot(enc.mesh.base);
}

// Multiset of triangles as position triples, rotated to a canonical corner.
std::vector<std::array<Vec3i, 3>> Triangles(const QuantizedMesh& m) {
  std::vector<std::array<Vec3i, 3>> out;
  for (size_t i = 0; i < m.indices.size(); i += 3) {
    std::array<Vec3i, 3> t = {m.positions[m.indices[i]], m.positions[m.indices[i + 1]], m.positions[m.indices[i + 2]]};
    const int lo = static_cast<int>(std::min_element(t.begin(), t.end()) - t.begin());
    std::rotate(t.begin(), t.begin() + lo, t.end());
    out.push_back(t);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ProgressiveCodec, LosslessOnASphereAtEveryQp) {
  for (int qp : {8, 11, 14}) {
    ProgressiveEncodeOptions options;
    options.quantization.qp = qp;
    const Primitive sphere = Sphere(24, 32);
    auto q = QuantizePrimitive(sphere, options.quantization);
    ASSERT_TRUE(q.ok());
    auto enc = EncodeProgressiveQuantized(q.value(), options, ReversingCoder);
    ASSERT_TRUE(enc.ok()) << enc.status().ToString();
    EXPECT_GT(enc->mesh.refinements.size(), 3u);
    EXPECT_LT(enc->mesh.base.vertex_count(), sphere.vertex_count() / 4);
    const QuantizedMesh full = DecodeAll(enc.value());
    EXPECT_EQ(full.vertex_count(), q->vertex_count());
    EXPECT_EQ(Triangles(full), Triangles(q.value())) << "qp " << qp;
  }
}

// An n x n grid of squares in the plane z = 0, two triangles each.
Primitive FlatGrid(int n) {
  Primitive p;
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) p.positions.push_back({float(x), float(y), 0.0f});
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
      p.indices.insert(p.indices.end(), {a, b, d, a, d, c});
    }
  }
  return p;
}

TEST(ProgressiveCodec, ResidualErrorsCountWhatLeavesTheSurfaceNotWhatSlidesAlongIt) {
  ProgressiveEncodeOptions options;
  // A plane: every split vector lies in it, whatever its length.
  auto flat = QuantizePrimitive(FlatGrid(24), options.quantization);
  ASSERT_TRUE(flat.ok());
  auto plane = EncodeProgressiveQuantized(flat.value(), options, ReversingCoder);
  ASSERT_TRUE(plane.ok()) << plane.status().ToString();
  ASSERT_GT(plane->mesh.refinements.size(), 2u);
  ASSERT_EQ(plane->residual_error.size(), plane->mesh.refinements.size() + 1);
  for (double e : plane->residual_error) EXPECT_EQ(e, 0.0);

  // A sphere: errors off the surface, never growing, none left at the end,
  // and below half the longest split vector left.
  auto round = QuantizePrimitive(Sphere(24, 32), options.quantization);
  ASSERT_TRUE(round.ok());
  auto sphere = EncodeProgressiveQuantized(round.value(), options, ReversingCoder);
  ASSERT_TRUE(sphere.ok()) << sphere.status().ToString();
  const std::vector<double>& e = sphere->residual_error;
  ASSERT_EQ(e.size(), sphere->mesh.refinements.size() + 1);
  EXPECT_GT(e.front(), 1.0) << "grid units";
  EXPECT_EQ(e.back(), 0.0);
  double longest = 0;
  for (size_t i = sphere->mesh.refinements.size(); i-- > 0;) {
    EXPECT_GE(e[i], e[i + 1]);
    for (const Vec3i& d : sphere->mesh.refinements[i].position_delta) {
      longest = std::max(longest, std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]));
    }
    EXPECT_LE(e[i], longest / 2 + 1e-9);
  }
  // Without the finest mesh's normals, the whole vector counts.
  const std::vector<double> whole = ResidualErrors(sphere->mesh, RefinementState{});
  EXPECT_DOUBLE_EQ(whole.front(), longest / 2);
}

TEST(ProgressiveCodec, SplitVerticesOfARefinementArePairwiseNonAdjacent) {
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(Sphere(20, 24), options, ReversingCoder);
  ASSERT_TRUE(enc.ok()) << enc.status().ToString();
  RefinementState state;
  ASSERT_TRUE(state.Reset(enc->mesh.base).ok());
  std::vector<uint32_t> neighbours;
  for (const Refinement& r : enc->mesh.refinements) {
    std::vector<uint8_t> split(state.connectivity.vertex_count(), 0);
    for (uint32_t v : r.split_vertices) split[v] = 1;
    for (uint32_t v : r.split_vertices) {
      state.connectivity.SortedNeighbours(v, neighbours);
      for (uint32_t x : neighbours) EXPECT_FALSE(split[x]) << v << " and " << x << " both split";
    }
    EXPECT_TRUE(std::is_sorted(r.split_vertices.begin(), r.split_vertices.end()));
    ASSERT_TRUE(state.ApplyRefinement(r).ok());
  }
}

// Each split refers only to the mesh before its refinement: applied alone,
// first, every split of a refinement succeeds and produces the same vertex
// values as when it is applied in order among the others.
TEST(ProgressiveCodec, EverySplitAppliesAloneOnTheCoarserMesh) {
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(Sphere(16, 20), options, ReversingCoder);
  ASSERT_TRUE(enc.ok());
  RefinementState state;
  ASSERT_TRUE(state.Reset(enc->mesh.base).ok());
  for (const Refinement& r : enc->mesh.refinements) {
    RefinementState in_order = state;
    ASSERT_TRUE(in_order.ApplyRefinement(r).ok());
    for (size_t j = 0; j < r.split_count(); ++j) {
      RefinementState alone = state;
      Refinement one = r;
      one.split_vertices = {r.split_vertices[j]};
      one.wings = {r.wings[j]};
      one.position_delta = {r.position_delta[j]};
      one.attribute_delta.assign(r.attribute_delta.begin() + j * state.channels,
                                 r.attribute_delta.begin() + (j + 1) * state.channels);
      ASSERT_TRUE(alone.ApplySplit(one, 0).ok()) << "split " << j;
      EXPECT_EQ(alone.positions[r.split_vertices[j]], in_order.positions[r.split_vertices[j]]);
      EXPECT_EQ(alone.positions.back(), in_order.positions[r.vertices_before + j]);
    }
    state = in_order;
  }
}

// The encoder works in the input's arrays when it is given them (the
// verification then compares fingerprints taken first): the same result as
// from a copy, the caller's copy untouched, and a triangle that repeats an
// index, in the middle of the input, removed and still verified around.
TEST(ProgressiveCodec, EncodingAGivenUpInputEqualsEncodingACopy) {
  ProgressiveEncodeOptions options;
  auto q = QuantizePrimitive(Sphere(20, 24), options.quantization);
  ASSERT_TRUE(q.ok());
  QuantizedMesh input = std::move(q).value();
  input.indices.insert(input.indices.begin() + 3 * 50, {7, 8, 7});
  const QuantizedMesh kept = input;
  auto from_copy = EncodeProgressiveQuantized(input, options, ReversingCoder);
  ASSERT_TRUE(from_copy.ok()) << from_copy.status().ToString();
  EXPECT_EQ(input.indices, kept.indices);
  EXPECT_EQ(input.positions, kept.positions);
  auto given_up = EncodeProgressiveQuantized(std::move(input), options, ReversingCoder);
  ASSERT_TRUE(given_up.ok()) << given_up.status().ToString();
  EXPECT_EQ(given_up->removed_faces, 1u);
  EXPECT_EQ(given_up->input_faces, kept.face_count() - 1);
  EXPECT_EQ(given_up->mesh.base.positions, from_copy->mesh.base.positions);
  EXPECT_EQ(given_up->mesh.base.indices, from_copy->mesh.base.indices);
  ASSERT_EQ(given_up->mesh.refinements.size(), from_copy->mesh.refinements.size());
  for (size_t i = 0; i < given_up->mesh.refinements.size(); ++i) {
    const Refinement& a = given_up->mesh.refinements[i];
    const Refinement& b = from_copy->mesh.refinements[i];
    EXPECT_EQ(a.split_vertices, b.split_vertices);
    EXPECT_EQ(a.wings, b.wings);
    EXPECT_EQ(a.position_delta, b.position_delta);
    EXPECT_EQ(a.attribute_delta, b.attribute_delta);
  }
  // Decoded in full: the input's triangles less the one removed.
  QuantizedMesh expected = kept;
  expected.indices.erase(expected.indices.begin() + 3 * 50, expected.indices.begin() + 3 * 51);
  EXPECT_EQ(Triangles(DecodeAll(given_up.value())), Triangles(expected));
}

TEST(ProgressiveCodec, AttributesComeBackOnTheirGrid) {
  ProgressiveEncodeOptions options;
  Primitive p = Sphere(16, 20);
  p.texcoords.push_back({});
  for (const Vec3f& v : p.positions) p.texcoords[0].push_back({v[0] * 0.5f + 0.5f, v[1] * 0.25f});
  auto q = QuantizePrimitive(p, options.quantization);
  ASSERT_TRUE(q.ok());
  auto enc = EncodeProgressiveQuantized(q.value(), options, ReversingCoder);
  ASSERT_TRUE(enc.ok()) << enc.status().ToString();
  const QuantizedMesh full = DecodeAll(enc.value());
  // Every input vertex's (position, channels) appears in the output.
  std::map<std::vector<int32_t>, int> in, out;
  const int ch = q->layout.channels();
  EXPECT_EQ(ch, 4);
  for (size_t v = 0; v < q->vertex_count(); ++v) {
    std::vector<int32_t> key(q->positions[v].begin(), q->positions[v].end());
    key.insert(key.end(), q->attributes.begin() + v * ch, q->attributes.begin() + (v + 1) * ch);
    ++in[key];
  }
  for (size_t v = 0; v < full.vertex_count(); ++v) {
    std::vector<int32_t> key(full.positions[v].begin(), full.positions[v].end());
    key.insert(key.end(), full.attributes.begin() + v * ch, full.attributes.begin() + (v + 1) * ch);
    ++out[key];
  }
  EXPECT_EQ(in, out);
}

TEST(ProgressiveCodec, MidpointTransformIsExactlyReversible) {
  for (int32_t a : {-7, -1, 0, 1, 2, 5, 1023, 2047, -2048, 1 << 29}) {
    for (int32_t b : {-9, -2, 0, 1, 3, 1000, 2047, -(1 << 29)}) {
      const int32_t m = Midpoint(a, b);
      EXPECT_EQ(m, static_cast<int32_t>(std::floor((double(a) + b) / 2)));
      EXPECT_EQ(FromMidpoint(m, a - b), a);
    }
  }
}

}  // namespace
}  // namespace meshstream
