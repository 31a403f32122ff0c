// StreamHeader (codec/bitstream/format.h): Serialize/Parse round trips for
// both packings, several quantization settings and attribute layouts;
// level_vertices(); a clean error at every truncation; fix-up blocks kept
// coded until DecodeFixups, which decodes them for the header's vertex count
// and fails (without trusting the count) when the blocks hold fewer values.
#include "codec/bitstream/format.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

using Bytes = std::vector<uint8_t>;

QuantizationGrid Grid(int bits, int components, float base, float range) {
  QuantizationGrid g;
  g.bits = bits;
  g.components = components;
  for (int c = 0; c < components; ++c) g.origin[c] = base - 0.5f * c;
  g.range = range;
  return g;
}

struct Setting {
  Packing packing;
  QuantizationParams q;
  bool normals;
  int texcoord_sets;
  bool colors;
};

StreamHeader MakeHeader(const Setting& s, uint32_t base_vertices) {
  StreamHeader h;
  h.packing = s.packing;
  h.quantization = s.q;
  h.grids.position_grid = Grid(s.q.qp, 3, -1.25f, 3.5f);
  AttributeLayout& l = h.grids.layout;
  l.has_normals = s.normals;
  l.qn = s.q.qn;
  l.texcoord_sets = s.texcoord_sets;
  for (int t = 0; t < s.texcoord_sets; ++t) l.texcoord_grids.push_back(Grid(s.q.qt, 2, 0.125f * t, 1.0f + t));
  l.has_colors = s.colors;
  if (s.colors) l.color_grid = Grid(s.q.qc, 4, 0.0f, 1.0f);
  h.base_vertices = base_vertices;
  h.base_faces = 2 * base_vertices - 4;
  h.base_method = 1;
  h.split_counts = {base_vertices / 2, 0, base_vertices, 3};
  // Fix-ups mostly zero, a few of every size (the zigzag's extremes too).
  h.base_position_fix.assign(size_t{3} * base_vertices, 0);
  h.base_position_fix[0] = 1;
  h.base_position_fix[4] = -1;
  h.base_position_fix.back() = INT32_MIN;
  h.base_attribute_fix.assign(size_t(l.channels()) * base_vertices, 0);
  for (size_t i = 0; i < h.base_attribute_fix.size(); i += 7) h.base_attribute_fix[i] = static_cast<int32_t>(i) - 20;
  if (!h.base_attribute_fix.empty()) h.base_attribute_fix.back() = INT32_MAX;
  return h;
}

Bytes Serialized(const StreamHeader& h) {
  ByteWriter w;
  h.Serialize(w);
  return w.bytes();
}

void ExpectSameGrid(const QuantizationGrid& a, const QuantizationGrid& b, const char* what) {
  EXPECT_EQ(a.bits, b.bits) << what;
  EXPECT_EQ(a.components, b.components) << what;
  for (int c = 0; c < a.components; ++c) EXPECT_EQ(a.origin[c], b.origin[c]) << what << " " << c;
  EXPECT_EQ(a.range, b.range) << what;
}

const Setting kSettings[] = {
    {Packing::kSplit, {11, 8, 10, 8}, true, 1, false},
    {Packing::kBundled, {11, 8, 10, 8}, true, 1, false},
    {Packing::kSplit, {1, 1, 1, 1}, false, 0, false},
    {Packing::kBundled, {30, 30, 30, 30}, true, 8, true},
    {Packing::kSplit, {16, 12, 12, 10}, false, 2, true},
    {Packing::kBundled, {14, 10, 12, 8}, false, 0, true},
};

TEST(StreamHeader, RoundTripsForEveryPackingAndSetting) {
  for (const Setting& s : kSettings) {
    SCOPED_TRACE("qp " + std::to_string(s.q.qp) + " packing " + std::to_string(int(s.packing)));
    const StreamHeader h = MakeHeader(s, 40);
    const Bytes wire = Serialized(h);
    auto p = StreamHeader::Parse(wire.data(), wire.size());
    ASSERT_TRUE(p.ok()) << p.status().ToString();
    EXPECT_EQ(p->packing, s.packing);
    EXPECT_EQ(p->quantization.qp, s.q.qp);
    EXPECT_EQ(p->quantization.qn, s.q.qn);
    EXPECT_EQ(p->quantization.qt, s.q.qt);
    EXPECT_EQ(p->quantization.qc, s.q.qc);
    ExpectSameGrid(p->grids.position_grid, h.grids.position_grid, "position");
    const AttributeLayout& l = p->grids.layout;
    EXPECT_EQ(l.has_normals, s.normals);
    EXPECT_EQ(l.qn, s.q.qn);
    EXPECT_EQ(l.texcoord_sets, s.texcoord_sets);
    ASSERT_EQ(l.texcoord_grids.size(), size_t(s.texcoord_sets));
    for (int t = 0; t < s.texcoord_sets; ++t) ExpectSameGrid(l.texcoord_grids[t], h.grids.layout.texcoord_grids[t], "texcoord");
    EXPECT_EQ(l.has_colors, s.colors);
    if (s.colors) ExpectSameGrid(l.color_grid, h.grids.layout.color_grid, "colour");
    EXPECT_EQ(p->base_vertices, h.base_vertices);
    EXPECT_EQ(p->base_faces, h.base_faces);
    EXPECT_EQ(p->base_method, h.base_method);
    EXPECT_EQ(p->split_counts, h.split_counts);
    EXPECT_EQ(p->level_vertices(), h.level_vertices());
    // Parsing then writing again gives the same bytes.
    ASSERT_TRUE(p->DecodeFixups().ok());
    EXPECT_EQ(Serialized(p.value()), wire);
  }
}

TEST(StreamHeader, LevelVerticesAccumulateTheSplitCounts) {
  StreamHeader h;
  h.base_vertices = 10;
  EXPECT_EQ(h.level_vertices(), (std::vector<uint32_t>{10}));
  h.split_counts = {3, 5, 0, 18};
  EXPECT_EQ(h.level_vertices(), (std::vector<uint32_t>{10, 13, 18, 18, 36}));
}

TEST(StreamHeader, FixupsAreDecodedOnlyByDecodeFixups) {
  const StreamHeader h = MakeHeader(kSettings[4], 40);
  const Bytes wire = Serialized(h);
  auto p = StreamHeader::Parse(wire.data(), wire.size());
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_TRUE(p->base_position_fix.empty());
  EXPECT_TRUE(p->base_attribute_fix.empty());
  EXPECT_FALSE(p->position_fix_block.empty());
  EXPECT_FALSE(p->attribute_fix_block.empty());

  StreamHeader decoded = p.value();
  ASSERT_TRUE(decoded.DecodeFixups().ok());
  EXPECT_EQ(decoded.base_position_fix, h.base_position_fix);
  EXPECT_EQ(decoded.base_attribute_fix, h.base_attribute_fix);

  // A count larger than the blocks hold (a lying header) fails on the
  // bytes, not by allocating what was claimed.
  StreamHeader lying = p.value();
  lying.base_vertices = 1u << 22;
  const Status s = lying.DecodeFixups();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("fix-ups"), std::string::npos) << s.message();
  EXPECT_LT(lying.base_position_fix.size(), size_t{3} << 22);
}

TEST(StreamHeader, EveryTruncationFailsCleanly) {
  for (const Setting& s : kSettings) {
    const Bytes wire = Serialized(MakeHeader(s, 40));
    for (size_t cut = 0; cut < wire.size(); ++cut) {
      const Bytes prefix(wire.begin(), wire.begin() + cut);  // exact size: ASan sees any over-read
      auto p = StreamHeader::Parse(prefix.data(), prefix.size());
      ASSERT_FALSE(p.ok()) << "cut at " << cut << " of " << wire.size();
      EXPECT_EQ(p.status().code(), StatusCode::kInvalidInput) << p.status().ToString();
      EXPECT_FALSE(p.status().message().empty());
    }
  }
}

TEST(StreamHeader, TruncatedFixupBlocksGiveAnErrorOrExactlyTheCount) {
  // Inside a parsed header the blocks are framed, so a cut header is refused
  // by Parse (above). A block cut on its own is not always detected: past its
  // end the range decoder reads zero bytes, which decode as "value 0" at a
  // cost of a fraction of a bit each, so the lost tail comes back as zeros
  // within the four bytes of look-ahead the decoder tolerates (measured: the
  // 580-byte attribute block below cut to 450 bytes decodes without error).
  // What DecodeFixups does guarantee: an error, or exactly the count of values
  // the header asks for, never more.
  const StreamHeader h = MakeHeader(kSettings[3], 40);
  const Bytes wire = Serialized(h);
  auto p = StreamHeader::Parse(wire.data(), wire.size());
  ASSERT_TRUE(p.ok());
  const size_t channels = size_t(p->grids.layout.channels());
  int refused = 0;
  for (int block = 0; block < 2; ++block) {
    const size_t size = block == 0 ? p->position_fix_block.size() : p->attribute_fix_block.size();
    for (size_t keep = 0; keep < size; ++keep) {
      StreamHeader t = p.value();
      (block == 0 ? t.position_fix_block : t.attribute_fix_block).resize(keep);
      const Status s = t.DecodeFixups();
      if (!s.ok()) {
        ++refused;
        EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
        EXPECT_NE(s.message().find("fix-ups"), std::string::npos) << s.message();
        continue;
      }
      EXPECT_EQ(t.base_position_fix.size(), size_t{3} * t.base_vertices);
      EXPECT_EQ(t.base_attribute_fix.size(), channels * t.base_vertices);
    }
  }
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace meshstream
