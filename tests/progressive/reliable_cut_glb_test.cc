// The reliable cut in the progressive .glb (importers/progressive_glb.h,
// docs/progressive-format.md section 1 "delivery"): the encoder records the
// ranking and the cut for its share; DecodeProgressiveGlb sends that cut's
// refinements reliably (as a session does), none with share 0, another cut
// for another share; a hostile "delivery" is refused by name.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

std::vector<uint8_t> EncodeSpot(double share, ProgressiveGlbReport* report) {
  auto scene = ImportFile(test_util::ModelPath("spot.obj"));
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  ProgressiveGlbOptions options;
  options.reliable_share = share;
  auto glb = EncodeProgressiveGlb(scene.value(), options, report);
  EXPECT_TRUE(glb.ok()) << glb.status().ToString();
  return glb.ok() ? glb.value() : std::vector<uint8_t>();
}

TEST(ReliableCutGlb, TheEncoderRecordsACutWithinItsShareAndDecodeSendsItReliably) {
  ProgressiveGlbReport report;
  const std::vector<uint8_t> glb = EncodeSpot(kDefaultReliableShare, &report);
  ASSERT_EQ(report.primitives.size(), 1u);
  const PrimitiveStreamReport& p = report.primitives[0];
  ASSERT_FALSE(p.reliable_cut.empty());
  EXPECT_EQ(p.reliable_cut.front(), 0u) << "the coarsest refinement matters most per byte";
  EXPECT_GT(p.reliable_cut_bytes, 0u);
  EXPECT_LE(static_cast<double>(p.reliable_cut_bytes),
            kDefaultReliableShare * static_cast<double>(p.base_bytes + p.reliable_bytes + p.unreliable_bytes));

  ProgressiveDecodeOptions recorded;
  recorded.loss.loss = 0.3;
  recorded.loss.seed = 4;
  ProgressiveDecodeReport with_cut, paper, wider;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, recorded, &with_cut).ok());
  ProgressiveDecodeOptions none = recorded;
  none.reliable_share = 0;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, none, &paper).ok());
  ProgressiveDecodeOptions more = recorded;
  more.reliable_share = 0.3;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, more, &wider).ok());

  EXPECT_EQ(paper.reliable_datagrams, 0u) << "share 0: the paper's scheme";
  EXPECT_EQ(with_cut.reliable_datagram_bytes, p.reliable_cut_bytes) << "the recorded cut, exactly";
  EXPECT_GT(wider.reliable_datagram_bytes, with_cut.reliable_datagram_bytes);
  // The same seed: the cut's datagrams cannot be lost, the others' fate is unchanged.
  EXPECT_LT(with_cut.lost_datagrams, paper.lost_datagrams);
  EXPECT_LE(wider.lost_datagrams, with_cut.lost_datagrams);
  EXPECT_EQ(with_cut.datagrams, paper.datagrams);
}

TEST(ReliableCutGlb, ShareZeroRecordsNoCut) {
  ProgressiveGlbReport report;
  const std::vector<uint8_t> glb = EncodeSpot(0, &report);
  ASSERT_EQ(report.primitives.size(), 1u);
  EXPECT_TRUE(report.primitives[0].reliable_cut.empty());
  ProgressiveDecodeOptions options;
  options.loss.loss = 0.2;
  ProgressiveDecodeReport r;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, options, &r).ok());
  EXPECT_EQ(r.reliable_datagrams, 0u);
}

TEST(ReliableCutGlb, AHostileDeliveryIsRefusedByName) {
  struct Case {
    const char* json;
    const char* names;
  };
  const Case cases[] = {
      {"[]", "is not an object"},
      {R"({"share":0.1,"ranking":[0],"reliable":[0],"extra":1})", "delivery.extra"},
      {R"({"share":1.5,"ranking":[0],"reliable":[]})", "delivery.share"},
      {R"({"share":0.1,"ranking":[0,0],"reliable":[]})", "twice"},
      {R"({"share":0.1,"ranking":[9],"reliable":[]})", "delivery.ranking[0]"},
      {R"({"share":0.1,"ranking":[0,1],"reliable":[1,0]})", "not ascending"},
      {R"({"share":0.1,"ranking":[0],"reliable":[1]})", "which the ranking does not"},
      {R"({"share":0.1,"ranking":"x","reliable":[]})", "is not an array"},
      {R"({"share":0.1})", "needs ranking and reliable"},
  };
  for (const Case& c : cases) {
    auto r = ParseDeliveryRecord(c.json, 3);
    ASSERT_FALSE(r.ok()) << c.json;
    EXPECT_NE(r.status().message().find(c.names), std::string::npos) << c.json << ": " << r.status().ToString();
  }
  DeliveryRecord d;
  d.share = 0.1;
  d.ranking = {2, 0, 1};
  d.reliable = {0, 2};
  auto back = ParseDeliveryRecord(DeliveryRecordJson(d), 3);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->ranking, d.ranking);
  EXPECT_EQ(back->reliable, d.reliable);
  EXPECT_DOUBLE_EQ(back->share, 0.1);
}

}  // namespace
}  // namespace meshstream
