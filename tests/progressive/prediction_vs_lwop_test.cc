// Regression test of the paper's claim on our implementation: under the same
// simulated loss, prediction (Recovery::kPredict) ends closer to the
// zero-loss decode than loss without prediction (Recovery::kLwop), and keeps
// the lossless vertex count. Closeness is the symmetric point-to-surface
// Hausdorff distance of codec/metrics/hausdorff.h, as in
// bench/loss_experiments.cc (qp 11, 12 % independent loss, same seed for the
// two recoveries so that they see the same loss pattern).
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "codec/metrics/hausdorff.h"
#include "tests/common/model_stream.h"

namespace meshstream {
namespace {

using test_util::ModelStream;

constexpr double kLoss = 0.12;

const ModelStream& Stream(const std::string& file, Packing packing) {
  static std::map<std::pair<std::string, int>, ModelStream> cache;
  auto key = std::make_pair(file, static_cast<int>(packing));
  auto it = cache.find(key);
  if (it == cache.end()) {
    QuantizationParams q;
    q.qp = 11;
    q.qn = 8;
    q.qt = 10;
    auto s = test_util::EncodeModelStream(file, q, packing);
    if (!s.ok()) {
      std::fprintf(stderr, "%s: %s\n", file.c_str(), s.status().ToString().c_str());
      std::abort();
    }
    it = cache.emplace(key, std::move(s).value()).first;
  }
  return it->second;
}

struct Outcome {
  QuantizedMesh mesh;
  size_t applied = 0;
  uint64_t lost = 0;
};

Outcome DecodeLossy(const ModelStream& s, uint64_t seed, Recovery recovery) {
  LossyDecodeOptions o;
  o.loss.loss = kLoss;
  o.loss.seed = seed;
  o.reconstructor.recovery = recovery;
  LossyDecodeReport report;
  auto reader = DecodeStreamLossy(s.stream, 0, s.base, o, &report);
  EXPECT_TRUE(reader.ok()) << reader.status().ToString();
  Outcome out;
  if (!reader.ok()) return out;
  out.mesh = reader->Mesh();
  out.applied = reader->applied();
  out.lost = report.transmission.datagrams_lost;
  return out;
}

double Hausdorff(const Primitive& reference, const QuantizedMesh& q) {
  auto d = ComputeSurfaceDistance(reference, DequantizeMesh(q, -1));
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return d.ok() ? d->hausdorff : -1;
}

struct Case {
  const char* file;
  Packing packing;
  uint64_t seed;
};

void RunCase(const Case& c, double* hd_predict, double* hd_lwop) {
  const ModelStream& s = Stream(c.file, c.packing);
  const Primitive reference = DequantizeMesh(s.lossless, -1);
  const Outcome predict = DecodeLossy(s, c.seed, Recovery::kPredict);
  const Outcome lwop = DecodeLossy(s, c.seed, Recovery::kLwop);
  ASSERT_EQ(predict.applied, s.refinements);
  ASSERT_EQ(lwop.applied, s.refinements);
  ASSERT_GT(predict.lost, 0u) << "the seed must lose datagrams";
  ASSERT_EQ(predict.lost, lwop.lost);  // the same loss pattern
  // Prediction recovers every lost split: the lossless vertex count.
  EXPECT_EQ(predict.mesh.vertex_count(), s.lossless.vertex_count());
  EXPECT_EQ(predict.mesh.face_count(), s.lossless.face_count());
  *hd_predict = Hausdorff(reference, predict.mesh);
  *hd_lwop = Hausdorff(reference, lwop.mesh);
}

// How the set was chosen: a sweep of seeds 1..12 on spot, fandisk and the
// bunny in both packings (72 runs, this file's RunCase with a loop; about 30 s
// of CPU) found prediction strictly closer in 66 of 72:
//   - split packing (the default): 36 of 36;
//   - bundled packing: 30 of 36; not closer were fandisk seeds 5, 6, 7, 8
//     and 11 (predict 0.364 vs LwoP 0.345, 0.0871 vs 0.0836, 0.2777 vs
//     0.2763, 0.290 vs 0.236, 0.374 vs 0.324) and the bunny seed 11 (0.00672
//     vs 0.00559). On fandisk's sharp creases, when structure and geometry of
//     a split are lost together, predicted positions can land farther from
//     the surface than LwoP's coarser mesh, and the Hausdorff distance is a
//     maximum.
// So the strict claim is asserted where it held on every seed tried: split
// packing, seeds 1..4 (the first four, not picked), the three models. Bundled
// packing is left out of the strict assertion rather than given only the
// seeds that happen to pass.
const Case kCases[] = {
    {"spot.obj", Packing::kSplit, 1},           {"spot.obj", Packing::kSplit, 2},
    {"spot.obj", Packing::kSplit, 3},           {"spot.obj", Packing::kSplit, 4},
    {"fandisk.obj", Packing::kSplit, 1},        {"fandisk.obj", Packing::kSplit, 2},
    {"fandisk.obj", Packing::kSplit, 3},        {"fandisk.obj", Packing::kSplit, 4},
    {"stanford-bunny.obj", Packing::kSplit, 1}, {"stanford-bunny.obj", Packing::kSplit, 2},
    {"stanford-bunny.obj", Packing::kSplit, 3}, {"stanford-bunny.obj", Packing::kSplit, 4},
};

TEST(PredictionVsLwop, PredictionIsStrictlyCloserToTheLosslessDecodeOnEveryFixedSeed) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.file) + " seed " + std::to_string(c.seed));
    double predict = -1, lwop = -1;
    RunCase(c, &predict, &lwop);
    std::printf("  %s seed %llu: Hausdorff predict %.6g, LwoP %.6g\n", c.file,
                static_cast<unsigned long long>(c.seed), predict, lwop);
    EXPECT_GE(predict, 0);
    EXPECT_LT(predict, lwop);
  }
}

}  // namespace
}  // namespace meshstream
