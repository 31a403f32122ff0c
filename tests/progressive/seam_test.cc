// Seams (the seams tool, docs/design/codec.md "Seams"): spot's UV seams collapse on
// both sides together, so its base shrinks, the stream decodes losslessly,
// and under loss the two copies of every seam vertex stay on one point
// (no crack) whatever was lost, with prediction and with LwoP.
#include <algorithm>
#include <array>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "codec/loss/lossy_decode.h"
#include "codec/progressive/seam_twins.h"
#include "tests/common/real_stream.h"

namespace meshstream {
namespace {

using test_util::BuildRealStream;
using test_util::kRealStreamId;
using test_util::RealStream;

constexpr ToolSet kWithoutSeams = kAllTools & ~kToolSeams;

const RealStream& Spot(Packing packing) {
  static const RealStream split = BuildRealStream(kAllTools, "spot.obj", Packing::kSplit, 400);
  static const RealStream bundled = BuildRealStream(kAllTools, "spot.obj", Packing::kBundled, 400);
  return packing == Packing::kSplit ? split : bundled;
}

// The triangles of a mesh by the values of their corners, in a canonical
// order (independent of the vertex numbering).
std::vector<std::vector<int32_t>> Triangles(const QuantizedMesh& m) {
  const int ch = m.layout.channels();
  std::vector<std::vector<int32_t>> out;
  for (size_t f = 0; f < m.face_count(); ++f) {
    std::array<std::vector<int32_t>, 3> corners;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = m.indices[3 * f + k];
      corners[k] = {m.positions[v][0], m.positions[v][1], m.positions[v][2]};
      corners[k].insert(corners[k].end(), m.attributes.begin() + size_t(v) * ch, m.attributes.begin() + size_t(v + 1) * ch);
    }
    const int first = static_cast<int>(std::min_element(corners.begin(), corners.end()) - corners.begin());
    std::vector<int32_t> t;
    for (int k = 0; k < 3; ++k) t.insert(t.end(), corners[(first + k) % 3].begin(), corners[(first + k) % 3].end());
    out.push_back(std::move(t));
  }
  std::sort(out.begin(), out.end());
  return out;
}

size_t StreamBytes(const ProgressiveStream& s) { return s.reliable_bytes() + s.unreliable_bytes(); }

TEST(Seams, SpotsSeamsRefineInsteadOfStayingInTheBase) {
  const RealStream& with = Spot(Packing::kSplit);
  const RealStream without = BuildRealStream(kWithoutSeams, "spot.obj", Packing::kSplit, 400);
  EXPECT_GT(with.seam_pairs, 0u);
  EXPECT_EQ(without.seam_pairs, 0u);
  // 642 base vertices without (every seam vertex locked), 235 with.
  EXPECT_LT(with.encoded_base_vertices * 2, without.encoded_base_vertices)
      << with.encoded_base_vertices << " against " << without.encoded_base_vertices;
  EXPECT_EQ(with.level_vertices.back(), without.level_vertices.back());
  // No level adds less than 5 % of its vertices (SimplifyOptions::min_batch_share):
  // without the rule spot's seams left 2-10 vertex levels at the coarse end.
  for (size_t i = 0; i + 1 < with.level_vertices.size(); ++i) {
    const uint32_t before = with.level_vertices[i], after = with.level_vertices[i + 1];
    EXPECT_GE(double(after - before), 0.05 * after) << "level " << i << ": " << before << " -> " << after;
  }
  // The refinements grow by less than the base shrinks: at least 10 % off
  // the total (docs/design/codec.md has the sizes).
  const size_t total_with = with.base_bytes + StreamBytes(with.stream);
  const size_t total_without = without.base_bytes + StreamBytes(without.stream);
  EXPECT_LT(total_with * 10, total_without * 9) << total_with << " against " << total_without;
  auto header = StreamHeader::Parse(with.stream.header.data(), with.stream.header.size());
  ASSERT_TRUE(header.ok());
  EXPECT_TRUE(header->has(kToolSeams));
  EXPECT_EQ(header->seam_twins.size(), with.seam_pairs);
  // Lossless: the last level is the quantized input, in both packings
  // (the same triangles of (position, channels) as the stream without
  // seams; the encoder verified its replay, BuildRealStream decoded it).
  for (Packing p : {Packing::kSplit, Packing::kBundled}) {
    EXPECT_EQ(Triangles(Spot(p).levels.back()), Triangles(without.levels.back()));
  }
}

// The copies of every seam vertex on one point, and twins that exist alike.
void ExpectSeamsClosed(const StreamReader& reader, const std::string& what, size_t* pairs_checked) {
  const RefinementState& st = reader.state();
  for (uint32_t v = 0; v < st.twin.size(); ++v) {
    const uint32_t t = st.twin[v];
    if (t == kNoTwin || t < v) continue;
    ASSERT_EQ(st.twin[t], v) << what << ": twins of " << v;
    ASSERT_EQ(st.flags[v] & kAbsent, st.flags[t] & kAbsent) << what << ": one side of seam pair " << v << ", " << t
                                                            << " was abandoned";
    if (st.flags[v] & kAbsent) continue;
    ASSERT_EQ(st.positions[v], st.positions[t]) << what << ": seam pair " << v << ", " << t << " parted (a crack)";
    ++*pairs_checked;
  }
}

TEST(Seams, TheTwoSidesOfASeamNeverPartUnderLoss) {
  for (Packing packing : {Packing::kSplit, Packing::kBundled}) {
    const RealStream& s = Spot(packing);
    for (Recovery recovery : {Recovery::kPredict, Recovery::kLwop}) {
      uint64_t lost = 0, predicted = 0, abandoned = 0;
      for (uint64_t seed = 1; seed <= 4; ++seed) {
        const std::string what = std::string(packing == Packing::kSplit ? "split" : "bundled") +
                                 (recovery == Recovery::kPredict ? " predict" : " lwop") + " seed " +
                                 std::to_string(seed);
        LossyDecodeOptions options;
        options.loss.loss = 0.12;
        options.loss.seed = seed;
        options.reconstructor.recovery = recovery;
        size_t pairs = 0;
        options.on_level = [&](size_t, const StreamReader& reader) { ExpectSeamsClosed(reader, what, &pairs); };
        LossyDecodeReport report;
        auto reader = DecodeStreamLossy(s.stream, kRealStreamId, s.base, options, &report);
        ASSERT_TRUE(reader.ok()) << what << ": " << reader.status().ToString();
        EXPECT_GT(pairs, 0u) << what;
        lost += report.transmission.datagrams_lost;
        predicted += report.recovery.predicted();
        abandoned += report.recovery.abandoned;
      }
      // The runs did lose data, and recovered it the way the mode says.
      EXPECT_GT(lost, 0u);
      if (recovery == Recovery::kPredict) EXPECT_GT(predicted, 0u);
      else EXPECT_GT(abandoned, 0u);
    }
  }
}

TEST(Seams, TwinsThatDoNotSplitTogetherAreRefused) {
  std::vector<uint32_t> twin(8, kNoTwin);
  twin[1] = 5;
  twin[5] = 1;
  std::vector<uint32_t> partner;
  ASSERT_TRUE(SeamPartners({1, 3, 5}, twin, &partner).ok());
  EXPECT_EQ(partner, (std::vector<uint32_t>{2, kNoTwin, 0}));
  const Status alone = SeamPartners({1, 3}, twin, &partner);
  EXPECT_FALSE(alone.ok());
  EXPECT_EQ(alone.message(), "seam vertex 1 splits without its twin 5");
  std::vector<uint32_t> table;
  EXPECT_FALSE(TwinTable({{1, 5}, {5, 6}}, 8, &table).ok());
  EXPECT_FALSE(TwinTable({{1, 9}}, 8, &table).ok());
  EXPECT_TRUE(TwinTable({{1, 5}, {2, 6}}, 8, &table).ok());
}

TEST(Seams, AHeaderWithBadTwinsIsRefused) {
  const RealStream& s = Spot(Packing::kSplit);
  auto header = StreamHeader::Parse(s.stream.header.data(), s.stream.header.size());
  ASSERT_TRUE(header.ok());
  auto refused = [&](std::vector<std::array<uint32_t, 2>> twins) {
    StreamHeader h = header.value();
    if (!h.DecodeFixups().ok()) return std::string("the stored header's fixups do not decode");
    h.seam_twins = std::move(twins);
    ByteWriter w;
    h.Serialize(w);
    auto parsed = StreamHeader::Parse(w.bytes().data(), w.bytes().size());
    return parsed.ok() ? std::string() : parsed.status().message();
  };
  const uint32_t n = header->base_vertices;
  EXPECT_EQ(refused({{3, 4}}), "");
  EXPECT_NE(refused({{3, 3}}).find("does not name two base vertices in ascending order"), std::string::npos);
  EXPECT_NE(refused({{3, n}}).find("does not name two base vertices in ascending order"), std::string::npos);
  // A repeated vertex parses, and is refused once the base is known.
  ASSERT_EQ(refused({{1, 2}, {2, 3}}), "");
  StreamHeader h = header.value();
  ASSERT_TRUE(h.DecodeFixups().ok());
  h.seam_twins = {{1, 2}, {2, 3}};
  ByteWriter w;
  h.Serialize(w);
  auto reader = StreamReader::Create(w.bytes().data(), w.bytes().size(), kRealStreamId);
  ASSERT_TRUE(reader.ok());
  const Status base = reader->SetBase(s.base);
  EXPECT_FALSE(base.ok());
  EXPECT_NE(base.message().find("vertex 2 is in more than one pair"), std::string::npos) << base.message();
}

}  // namespace
}  // namespace meshstream
