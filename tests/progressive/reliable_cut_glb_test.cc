// The reliable cut in the progressive .glb (importers/progressive_glb.h,
// docs/spec/progressive-format.md section 1 "delivery"): the encoder records the
// ranking and the cut for its share; DecodeProgressiveGlb sends that cut's
// refinements reliably (as a session does), none with share 0, another cut
// for another share; a hostile "delivery" is refused by name.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "fec/reed_solomon.h"
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
      {R"({"share":0.1,"ranking":[0,1],"reliable":[0],"parity":[2,1]})", "parity is not ascending"},
      {R"({"share":0.1,"ranking":[0,1],"reliable":[0],"parity":[0,1]})", "which travels on the reliable cut"},
      {R"({"share":0.1,"ranking":[0],"reliable":[],"parity":[7]})", "delivery.parity[0]"},
      {R"({"share":0.1,"ranking":[0],"reliable":[],"harm":[0.1,0.2]})", "harm is not an array of 3"},
      {R"({"share":0.1,"ranking":[0],"reliable":[],"harm":[0.1,-1,0]})", "harm[1]"},
      {R"({"share":0.1,"ranking":[0],"reliable":[],"harm":[0.1,"x",0]})", "harm[1]"},
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
  d.parity = {1};
  d.harm = {0.02, 0.004, 0.0};
  auto back = ParseDeliveryRecord(DeliveryRecordJson(d), 3);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->ranking, d.ranking);
  EXPECT_EQ(back->reliable, d.reliable);
  EXPECT_DOUBLE_EQ(back->share, 0.1);
  EXPECT_EQ(back->parity, d.parity);
  ASSERT_EQ(back->harm.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(static_cast<float>(back->harm[i]), static_cast<float>(d.harm[i]));
}

// Issue 27: the encoder records each refinement's harm and which ones parity
// protects; the record survives the .glb, and decode --loss sends parity for
// exactly those, which rebuilds datagrams the simulated network lost.
TEST(ReliableCutGlb, TheProtectionChoiceIsRecordedAndUsed) {
  ProgressiveGlbReport report;
  const std::vector<uint8_t> glb = EncodeSpot(kDefaultReliableShare, &report);
  ASSERT_EQ(report.primitives.size(), 1u);
  const PrimitiveStreamReport& p = report.primitives[0];
  ASSERT_FALSE(p.parity.empty()) << "the spot's unreliable refinements harm more than 0.1 %";
  for (uint32_t r : p.parity) {
    EXPECT_TRUE(std::find(p.reliable_cut.begin(), p.reliable_cut.end(), r) == p.reliable_cut.end())
        << "refinement " << r << " is on the cut and protected";
  }
  // The same record read back from the file.
  const std::string json(glb.begin() + 20, glb.begin() + 20 + (glb[12] | (glb[13] << 8) | (glb[14] << 16)));
  const size_t at = json.find("\"delivery\":");
  ASSERT_NE(at, std::string::npos);
  size_t depth = 0, end = at + 11;
  for (; end < json.size(); ++end) {
    if (json[end] == '{') ++depth;
    if (json[end] == '}' && --depth == 0) break;
  }
  auto record = ParseDeliveryRecord(json.substr(at + 11, end - at - 10), p.level_vertices.size() - 1);
  ASSERT_TRUE(record.ok()) << record.status().ToString();
  EXPECT_EQ(record->parity, p.parity);
  EXPECT_EQ(record->reliable, p.reliable_cut);
  ASSERT_EQ(record->harm.size(), p.level_vertices.size() - 1);
  for (double h : record->harm) EXPECT_GT(h, 0.0);
  // decode --loss with parity (as the CLI does) rebuilds lost datagrams.
  ProgressiveDecodeOptions o;
  o.loss.loss = 0.12;
  o.loss.seed = 3;
  ProgressiveDecodeReport plain, with;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, o, &plain).ok());
  o.parity = &fec::DefaultErasureCode();
  ASSERT_TRUE(DecodeProgressiveGlb(glb, o, &with).ok());
  EXPECT_EQ(plain.parity_datagrams, 0u);
  EXPECT_GT(with.parity_datagrams, 0u);
  EXPECT_EQ(with.lost_datagrams, plain.lost_datagrams) << "parity does not change the data's loss pattern";
  EXPECT_GT(with.recovered_datagrams, 0u);
  EXPECT_LE(with.predicted_vertices, plain.predicted_vertices);
}

}  // namespace
}  // namespace meshstream
