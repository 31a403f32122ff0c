// The harm of one lost datagram (codec/loss/datagram_harm.h): the encoder's
// estimate (EstimateDatagramHarm, a local distance of each predicted split,
// a few decodes) against the measure it stands for (MeasureDatagramHarm: the
// whole stream decoded with the datagram lost, a Hausdorff distance of the
// final levels), on real models: equal where no finer refinement spreads
// the loss, within the documented margin elsewhere, the same protection
// tiers, and the sampled default equal to the largest of every datagram.
#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "codec/loss/datagram_harm.h"
#include "codec/loss/protection.h"
#include "tests/common/model_stream.h"

namespace meshstream {
namespace {

struct Harms {
  test_util::ModelStream model;
  DatagramHarm estimate, estimate_every, measure_every;
};

Harms HarmsOf(const std::string& file, Packing packing) {
  Harms h;
  auto model = test_util::EncodeModelStream(file, QuantizationParams{}, packing);
  EXPECT_TRUE(model.ok()) << model.status().ToString();
  if (!model.ok()) return h;
  h.model = std::move(model).value();
  HarmOptions every;
  every.every_datagram = true;
  auto estimate = EstimateDatagramHarm(h.model.stream, h.model.base);
  auto estimate_every = EstimateDatagramHarm(h.model.stream, h.model.base, nullptr, every);
  auto measure_every = MeasureDatagramHarm(h.model.stream, h.model.base, nullptr, every);
  EXPECT_TRUE(estimate.ok() && estimate_every.ok() && measure_every.ok());
  if (estimate.ok()) h.estimate = std::move(estimate).value();
  if (estimate_every.ok()) h.estimate_every = std::move(estimate_every).value();
  if (measure_every.ok()) h.measure_every = std::move(measure_every).value();
  return h;
}

// The tier a harm gives outside the reliable cut (protection.h).
int Tier(double harm) { return harm > kHarmWorst ? 2 : harm > kHarmTarget ? 1 : 0; }

TEST(DatagramHarm, TheEstimateFollowsTheMeasureOnFandiskAndSpot) {
  for (const char* file : {"fandisk.obj", "spot.obj"}) {
    SCOPED_TRACE(file);
    const Harms h = HarmsOf(file, Packing::kSplit);
    const size_t n = h.model.refinements;
    ASSERT_GT(n, 2u);
    ASSERT_EQ(h.estimate.harm.size(), n);
    ASSERT_EQ(h.measure_every.harm.size(), n);
    EXPECT_NEAR(h.estimate.diagonal, h.measure_every.diagonal, 1e-6 * h.measure_every.diagonal);  // float dequantization
    for (size_t i = 0; i < n; ++i) {
      SCOPED_TRACE("refinement " + std::to_string(i));
      const double measured = h.measure_every.RefinementMax(i), estimated = h.estimate.RefinementMax(i);
      ASSERT_EQ(h.estimate_every.harm[i].size(), h.model.stream.datagrams[i].size()) << "one per datagram";
      ASSERT_EQ(h.estimate.harm[i].size(), 1u) << "the default: one per refinement";
      ASSERT_GT(measured, 0);
      if (i + 1 == n) {
        // Nothing finer to spread to: the local distance is the distance.
        EXPECT_NEAR(estimated, measured, 0.1 * measured);
      } else {
        EXPECT_GE(estimated, 0.5 * measured);
        EXPECT_LE(estimated, 2.0 * measured);
      }
      // Every datagram of a refinement harms alike (round-robin): the
      // sampled default is within a tenth of the largest of all of them.
      EXPECT_NEAR(estimated, h.estimate_every.RefinementMax(i), 0.1 * h.estimate_every.RefinementMax(i));
      EXPECT_EQ(Tier(estimated), Tier(measured));
    }
  }
}

TEST(DatagramHarm, BundledDatagramsLoseStructureAndGeometryTogether) {
  const Harms split = HarmsOf("fandisk.obj", Packing::kSplit);
  const Harms bundled = HarmsOf("fandisk.obj", Packing::kBundled);
  const size_t n = bundled.model.refinements;
  ASSERT_EQ(n, split.model.refinements);
  // A bundled datagram carries both units of its splits: they are predicted
  // whole (case 2), which moves them at least as far as losing either half.
  const double last_split = split.estimate.RefinementMax(n - 1);
  const double last_bundled = bundled.estimate.RefinementMax(n - 1);
  EXPECT_GE(last_bundled, 0.9 * last_split);
  EXPECT_NEAR(last_bundled, bundled.measure_every.RefinementMax(n - 1),
              0.15 * bundled.measure_every.RefinementMax(n - 1));
}

TEST(DatagramHarm, AStreamTheReaderRefusesIsAnError) {
  auto model = test_util::EncodeModelStream("spot.obj", QuantizationParams{}, Packing::kSplit);
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  ProgressiveStream broken = model->stream;
  ASSERT_FALSE(broken.control.empty());
  broken.control[0].assign(3, 0xff);
  EXPECT_FALSE(EstimateDatagramHarm(broken, model->base).ok());
  ProgressiveStream bad_datagram = model->stream;
  ASSERT_FALSE(bad_datagram.datagrams[0].empty());
  bad_datagram.datagrams[0][0].assign(2, 0);
  const auto refused = EstimateDatagramHarm(bad_datagram, model->base);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("refinement 0"), std::string::npos) << refused.status().ToString();
}

}  // namespace
}  // namespace meshstream
