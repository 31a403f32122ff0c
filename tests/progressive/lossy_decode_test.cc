// DecodeStreamLossy (codec/loss/lossy_decode.h) on a real stream (fandisk,
// tests/common/real_stream.h): the client's whole path, simulator ->
// reconstructor -> reader.
//
// The tests that lose data datagrams need StreamReader's recovery
// (prediction and LwoP). Until FinishRefinement can recover a split whose
// structure or geometry is missing they skip themselves, with a message; once
// it can, they run and must pass.
#include <algorithm>
#include <numeric>

#include <gtest/gtest.h>

#include "codec/loss/lossy_decode.h"
#include "codec/mesh/mesh_health.h"
#include "tests/common/real_stream.h"

namespace meshstream {
namespace {

using test_util::Fandisk;
using test_util::kRealStreamId;
using test_util::RealStream;

void ExpectSameMesh(const QuantizedMesh& got, const QuantizedMesh& want, const std::string& what) {
  EXPECT_EQ(got.positions, want.positions) << what;
  EXPECT_EQ(got.attributes, want.attributes) << what;
  EXPECT_EQ(got.indices, want.indices) << what;
}

uint64_t TotalSplits(size_t refinements) {
  const auto& v = Fandisk().level_vertices;
  return v[refinements] - v[0];
}

TEST(LossyDecode, ZeroLossIsTheLosslessDecodeLevelByLevel) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  std::vector<size_t> levels;
  options.on_level = [&](size_t level, const StreamReader& reader) {
    levels.push_back(level);
    EXPECT_EQ(reader.applied(), level);
    ExpectSameMesh(reader.Mesh(), s.levels[level], "level " + std::to_string(level));
  };
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  const size_t n = s.stream.control.size();
  ExpectSameMesh(reader->Mesh(), s.levels[n], "last level");
  std::vector<size_t> want(n);
  std::iota(want.begin(), want.end(), 1);
  EXPECT_EQ(levels, want);
  EXPECT_EQ(report.levels_applied, n);
  EXPECT_EQ(report.transmission.datagrams_sent, s.stream.datagram_count());
  EXPECT_EQ(report.transmission.datagrams_lost + report.transmission.ends_lost, 0u);
  EXPECT_EQ(report.reconstructor.accepted, s.stream.datagram_count());
  EXPECT_EQ(report.reconstructor.finished_complete, n);
}

TEST(LossyDecode, ReorderingAndDuplicatesAreLosslessAndDeterministic) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.loss.reorder = 0.5;
  options.loss.duplicate = 0.3;
  options.loss.seed = 4;
  options.timing.reorder_delay_us = 40000;
  LossyDecodeReport a, b;
  auto first = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &a);
  auto second = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &b);
  ASSERT_TRUE(first.ok() && second.ok());
  ExpectSameMesh(first->Mesh(), s.levels.back(), "reordered");
  EXPECT_EQ(a.reconstructor.duplicates, b.reconstructor.duplicates);
  EXPECT_EQ(a.transmission.reordered, b.transmission.reordered);
  EXPECT_GT(a.transmission.duplicated, 0u);
}

TEST(LossyDecode, LodSendsAndDecodesOnlyThatManyRefinements) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.reconstructor.lod = 3;
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  EXPECT_EQ(report.levels_applied, 3u);
  EXPECT_EQ(report.transmission.ends_sent, 3u);
  ExpectSameMesh(reader->Mesh(), s.levels[3], "lod 3");
}

TEST(LossyDecode, BadArgumentsAreErrors) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.loss.loss = 2;
  EXPECT_EQ(DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, nullptr).status().code(),
            StatusCode::kInvalidArgument);
  options = {};
  options.reconstructor.lod = -2;
  EXPECT_EQ(DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, nullptr).status().code(),
            StatusCode::kInvalidArgument);
  QuantizedMesh wrong = s.base;
  wrong.indices.resize(wrong.indices.size() - 3);
  EXPECT_FALSE(DecodeStreamLossy(s.stream, kRealStreamId, wrong, LossyDecodeOptions{}, nullptr).ok());
}

// --- With loss: these need StreamReader's recovery. ---

MeshHealth Health(const QuantizedMesh& m) { return ComputeHealth(DequantizeMesh(m, -1)); }

void ExpectNoWorseThanLossless(const QuantizedMesh& got, size_t level, const std::string& what) {
  const MeshHealth h = Health(got), lossless = Health(Fandisk().levels[level]);
  EXPECT_LE(h.unreferenced_vertices, lossless.unreferenced_vertices) << what;
  EXPECT_LE(h.degenerate_faces, lossless.degenerate_faces) << what;
  EXPECT_LE(h.nonmanifold_edges, lossless.nonmanifold_edges) << what;
}

TEST(LossyDecode, PredictionKeepsEveryLevelsVertexCountUnderLoss) {
  const RealStream& s = Fandisk();
  const size_t n = s.stream.control.size();
  for (double burst : {0.0, 3.0}) {
    for (uint64_t seed : {1, 2, 3}) {
      const std::string what = "burst " + std::to_string(burst) + " seed " + std::to_string(seed);
      LossyDecodeOptions options;
      options.loss.loss = 0.1;
      options.loss.burst = burst;
      options.loss.reorder = 0.1;
      options.loss.duplicate = 0.05;
      options.loss.seed = seed;
      options.reconstructor.recovery = Recovery::kPredict;
      options.on_level = [&](size_t level, const StreamReader& reader) {
        EXPECT_EQ(reader.Mesh().vertex_count(), s.level_vertices[level]) << what << " level " << level;
      };
      LossyDecodeReport report;
      auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
      ASSERT_TRUE(reader.ok()) << what << ": " << reader.status().ToString();
      EXPECT_EQ(report.levels_applied, n) << what;
      EXPECT_EQ(reader->Mesh().vertex_count(), s.level_vertices.back()) << what;
      EXPECT_GT(report.transmission.datagrams_lost, 0u) << what;
      EXPECT_GT(report.recovery.predicted(), 0u) << what;
      EXPECT_EQ(report.recovery.exact + report.recovery.predicted(), TotalSplits(n)) << what;
      ExpectNoWorseThanLossless(reader->Mesh(), n, what);
    }
  }
}

// The reliability flags under loss: a vertex the reader marks reliable sits
// where the lossless decode has it, for a stream with every tool and for
// each tool alone (each reads the ring's positions differently: the split
// vector's prediction, its frame, the wings' rank, the predicted channels),
// with prediction and with LwoP. Without the marks of ApplyCoded for
// splits computed from predicted ring positions, the single-tool streams
// fail here.
TEST(LossyDecode, VerticesMarkedReliableAreExactForEveryToolUnderLoss) {
  // -1: every tool, with the ring predictor's 2-ring term wherever it saves
  // anything (it reads the ring's neighbours, whose flags then count).
  for (int tools_or_ring : {int{kAllTools}, -1, int{kToolGeometryPrediction}, int{kToolLocalFrame}, int{kToolWingRank}}) {
    const ToolSet tools = tools_or_ring < 0 ? kAllTools : static_cast<ToolSet>(tools_or_ring);
    const RealStream s = tools_or_ring == int{kAllTools} ? Fandisk()
                         : tools_or_ring < 0 ? test_util::BuildRealStream(kAllTools, "fandisk.obj", Packing::kSplit, 200, 0.0)
                                             : test_util::BuildRealStream(tools);
    const QuantizedMesh& lossless = s.levels.back();
    for (Recovery recovery : {Recovery::kPredict, Recovery::kLwop}) {
      for (uint64_t seed : {1, 2}) {
        const std::string what = "tools " + std::to_string(tools) + (tools_or_ring < 0 ? " 2-ring" : "") + (recovery == Recovery::kLwop ? " lwop" : " predict") +
                                 " seed " + std::to_string(seed);
        LossyDecodeOptions options;
        options.loss.loss = 0.06;
        options.loss.seed = seed;
        options.reconstructor.recovery = recovery;
        LossyDecodeReport report;
        auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
        ASSERT_TRUE(reader.ok()) << what << ": " << reader.status().ToString();
        ASSERT_GT(report.transmission.datagrams_lost, 0u) << what;
        const std::vector<uint8_t>& reliable = reader->reliable();
        const RefinementState& state = reader->state();
        ASSERT_EQ(reliable.size(), lossless.vertex_count()) << what;
        size_t marked = 0, wrong = 0;
        for (size_t v = 0; v < reliable.size(); ++v) {
          if (!reliable[v]) {
            ++marked;
            continue;
          }
          const bool same = state.positions[v] == lossless.positions[v] &&
                            std::equal(lossless.attributes.begin() + v * lossless.layout.channels(),
                                       lossless.attributes.begin() + (v + 1) * lossless.layout.channels(),
                                       state.attributes.begin() + v * lossless.layout.channels());
          wrong += !same;
        }
        EXPECT_GT(marked, 0u) << what;
        EXPECT_EQ(wrong, 0u) << what << ": vertices marked reliable that are not where the lossless decode has them";
      }
    }
  }
}

TEST(LossyDecode, PredictionSurvivesLosingEverything) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.loss.loss = 1;
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  EXPECT_EQ(reader->Mesh().vertex_count(), s.level_vertices.back());
  EXPECT_EQ(report.recovery.predicted_both, TotalSplits(s.stream.control.size()));
  EXPECT_EQ(report.reconstructor.finished_timeout, s.stream.control.size());
  ExpectNoWorseThanLossless(reader->Mesh(), s.stream.control.size(), "everything lost");
}

TEST(LossyDecode, LossWithoutPredictionAbandonsButStaysValid) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.loss.loss = 0.15;
  options.loss.seed = 8;
  options.reconstructor.recovery = Recovery::kLwop;
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  EXPECT_GT(report.recovery.abandoned, 0u);
  EXPECT_LT(reader->Mesh().vertex_count(), s.level_vertices.back());
  EXPECT_EQ(report.recovery.predicted(), 0u);
  ExpectNoWorseThanLossless(reader->Mesh(), s.stream.control.size(), "lwop");
}

TEST(LossyDecode, SameSeedSameMeshUnderLoss) {
  const RealStream& s = Fandisk();
  LossyDecodeOptions options;
  options.loss.loss = 0.2;
  options.loss.burst = 2;
  options.loss.seed = 31;
  auto a = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, nullptr);
  auto b = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, nullptr);
  ASSERT_TRUE(a.ok() && b.ok());
  ExpectSameMesh(a->Mesh(), b->Mesh(), "same seed");
}

}  // namespace
}  // namespace meshstream
