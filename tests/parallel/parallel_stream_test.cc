// The parallel decode at the codec's level, with no importer and no Draco
// (so that the ThreadSanitizer pass of `make test` builds only codec/ and
// parallel/): a sphere with normals and texture coordinates, encoded with
// every tool and the ring predictor's 2-ring term wherever it saves,
// decoded through the lossy-decode path on the caller's thread and on 2 and
// 4 threads, with and without loss: the same mesh and reliability bits, bit
// for bit, and the splits planned on the workers. The sphere's poles make
// vertices of many triangles, so that some plans stop holding in their turn
// (RefinementPlan::Holds): without that check the meshes differ.
#include <cmath>

#include <gtest/gtest.h>

#include "codec/bitstream/writer.h"
#include "codec/loss/lossy_decode.h"
#include "parallel/fork_join_pool.h"
#include "tests/common/hierarchy.h"
#include "tests/common/uv_sphere.h"

namespace meshstream {
namespace {

Primitive TexturedSphere(int rings, int segments) {
  Primitive p;
  p.texcoords.resize(1);
  test_util::BuildUvSphere(rings, segments, &p, [&](double theta, double phi) {
    const double r = 1 + 0.05 * std::sin(5 * phi) * std::sin(3 * theta);
    const Vec3f n = {float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                     float(std::cos(theta))};
    p.positions.push_back({float(r * n[0]), float(r * n[1]), float(r * n[2])});
    p.normals.push_back(n);
    p.texcoords[0].push_back({float(phi / (2 * M_PI)), float(theta / M_PI)});
  });
  return p;
}

struct Encoded {
  ProgressiveStream stream;
  QuantizedMesh base;
};

const Encoded& Sphere() {
  static const Encoded* e = [] {
    ProgressiveEncodeOptions options;
    const ProgressiveEncoded enc = test_util::EncodeWithoutDraco(TexturedSphere(90, 120), options);
    StreamWriteOptions wo;
    wo.ring_term_bits = 0;  // the 2-ring term wherever it saves: the plans read the umbrellas too
    auto stream = WriteStream(enc, options.quantization, wo);
    EXPECT_TRUE(stream.ok()) << stream.status().ToString();
    return new Encoded{stream.ok() ? std::move(stream).value() : ProgressiveStream{}, enc.mesh.base};
  }();
  return *e;
}

TEST(ParallelStream, DecodesAsTheOneThreadDecodeWithAndWithoutLoss) {
  const Encoded& e = Sphere();
  ASSERT_FALSE(e.stream.control.empty());
  ForkJoinPool two(2), four(4);
  for (const double loss : {0.0, 0.12}) {
    for (const uint64_t seed : {1, 2}) {
      LossyDecodeOptions options;
      options.loss.loss = loss;
      options.loss.seed = seed;
      LossyDecodeReport serial_report;
      auto serial = DecodeStreamLossy(e.stream, 0, e.base, options, &serial_report);
      ASSERT_TRUE(serial.ok()) << serial.status().ToString();
      for (ForkJoinPool* pool : {&two, &four}) {
        SCOPED_TRACE("loss " + std::to_string(loss) + ", seed " + std::to_string(seed) + ", " +
                     std::to_string(pool->workers()) + " threads");
        options.reconstructor.runner = pool;
        LossyDecodeReport report;
        auto parallel = DecodeStreamLossy(e.stream, 0, e.base, options, &report);
        ASSERT_TRUE(parallel.ok()) << parallel.status().ToString();
        const QuantizedMesh a = parallel->Mesh(), b = serial->Mesh();
        EXPECT_EQ(a.positions, b.positions);
        EXPECT_EQ(a.attributes, b.attributes);
        EXPECT_EQ(a.indices, b.indices);
        EXPECT_EQ(parallel->reliable(), serial->reliable());
        EXPECT_EQ(report.recovery.exact, serial_report.recovery.exact);
        EXPECT_EQ(report.recovery.predicted(), serial_report.recovery.predicted());
        EXPECT_EQ(serial_report.recovery.planned, 0u);
        if (loss == 0) {
          // All but the few whose plan no longer held in their turn (a ring
          // vertex's triangles grew past the umbrellas' limit: 28 here).
          EXPECT_LE(report.recovery.planned, report.recovery.exact);
          EXPECT_GT(report.recovery.planned, report.recovery.exact * 95 / 100);
        } else {
          EXPECT_LE(report.recovery.planned, report.recovery.exact);
        }
        options.reconstructor.runner = nullptr;
      }
    }
  }
}

}  // namespace
}  // namespace meshstream
