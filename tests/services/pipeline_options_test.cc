// The service's encode options: the CLI's defaults and ranges, messages that
// name the field, the canonical JSON the store keeps, and the artifact cache
// key (it changes with every option and every source digest or name, and
// with nothing else).
#include "services/pipeline/encode_options.h"

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "codec/mesh/quantization.h"
#include "services/store/blob_store.h"

namespace meshstream {
namespace {

std::string RefusalOf(const EncodeSettings& s) {
  auto r = ResolveSettings(s);
  EXPECT_FALSE(r.ok()) << CanonicalJson(s);
  if (r.ok()) return "";
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  return r.status().message();
}

EncodeSettings With(void (*edit)(EncodeSettings&)) {
  EncodeSettings s;
  edit(s);
  return s;
}

TEST(PipelineOptions, DefaultsAreTheEncodersOwn) {
  const ProgressiveGlbOptions cli;
  const EncodeSettings d = DefaultSettings();
  EXPECT_EQ(d.qp, cli.encode.quantization.qp);
  EXPECT_EQ(d.qn, cli.encode.quantization.qn);
  EXPECT_EQ(d.qt, cli.encode.quantization.qt);
  EXPECT_EQ(d.packing, "split");
  EXPECT_EQ(d.packet_bytes, cli.stream.packet_bytes);
  EXPECT_EQ(d.base_ratio, cli.encode.simplify.base_ratio);
  auto resolved = ResolveSettings(EncodeSettings{});
  ASSERT_TRUE(resolved.ok()) << resolved.status().ToString();
  EXPECT_EQ(resolved.value(), d);
}

TEST(PipelineOptions, ExplicitValuesInRangeAreKept) {
  EncodeSettings s{14, 10, 12, "bundled", 200, 0.05};
  auto r = ResolveSettings(s);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r.value(), s);
  // The ends of every range are inside.
  for (EncodeSettings edge : {EncodeSettings{kMinQuantizationBits, kMinNormalBits, kMinQuantizationBits, "split",
                                             kMinPacketBytes, kMinBaseRatio},
                              EncodeSettings{kMaxQuantizationBits, kMaxNormalBits, kMaxQuantizationBits, "bundled",
                                             kMaxPacketBytes, kMaxBaseRatio}}) {
    auto e = ResolveSettings(edge);
    ASSERT_TRUE(e.ok()) << e.status().ToString();
    EXPECT_EQ(e.value(), edge);
  }
}

TEST(PipelineOptions, OutOfRangeValuesAreRefusedNamingTheField) {
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.qp = 40; })), "options.qp: 40 is outside [1, 30]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.qp = -3; })), "options.qp: -3 is outside [1, 30]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.qn = 1; })), "options.qn: 1 is outside [2, 15]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.qn = 16; })), "options.qn: 16 is outside [2, 15]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.qt = 31; })), "options.qt: 31 is outside [1, 30]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.packing = "zip"; })),
            "options.packing: 'zip' is not split or bundled");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.packing = "SPLIT"; })),
            "options.packing: 'SPLIT' is not split or bundled");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.packet_bytes = 63; })),
            "options.packet_bytes: 63 is outside [64, 65507]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.packet_bytes = 65508; })),
            "options.packet_bytes: 65508 is outside [64, 65507]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.base_ratio = 1.5; })),
            "options.base_ratio: 1.5 is outside [1e-06, 1]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.base_ratio = -0.25; })),
            "options.base_ratio: -0.25 is outside [1e-06, 1]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.base_ratio = std::nan(""); })),
            "options.base_ratio: nan is outside [1e-06, 1]");
  EXPECT_EQ(RefusalOf(With([](EncodeSettings& s) { s.base_ratio = std::numeric_limits<double>::infinity(); })),
            "options.base_ratio: inf is outside [1e-06, 1]");
  // An untrusted packing string is shown printable and short.
  const std::string shown = RefusalOf(With([](EncodeSettings& s) { s.packing = std::string("a\nb\xff") + std::string(200, 'x'); }));
  EXPECT_EQ(shown.find('\n'), std::string::npos);
  EXPECT_LT(shown.size(), 150u);
}

TEST(PipelineOptions, CanonicalJsonIsFixedAndRoundTrips) {
  EXPECT_EQ(CanonicalJson(DefaultSettings()),
            "{\"qp\":11,\"qn\":8,\"qt\":10,\"packing\":\"split\",\"packet_bytes\":1200,\"base_ratio\":0.02}");
  for (const EncodeSettings& s : {DefaultSettings(), EncodeSettings{14, 10, 12, "bundled", 200, 0.1},
                                  EncodeSettings{1, 2, 30, "split", 65507, 1e-6},
                                  EncodeSettings{30, 15, 1, "bundled", 64, 1.0 / 3.0}}) {
    const std::string text = CanonicalJson(s);
    auto back = ParseSettingsJson(text);
    ASSERT_TRUE(back.ok()) << text << ": " << back.status().ToString();
    EXPECT_EQ(back.value(), s) << text;
    EXPECT_EQ(CanonicalJson(back.value()), text);
  }
}

TEST(PipelineOptions, ParseFillsDefaultsAndRefusesWhatIsNotAnOption) {
  auto empty = ParseSettingsJson("{}");
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(empty.value(), DefaultSettings());
  auto partial = ParseSettingsJson("{\"qp\":14,\"packing\":\"\",\"base_ratio\":0}");
  ASSERT_TRUE(partial.ok()) << partial.status().ToString();
  EXPECT_EQ(partial->qp, 14);
  EXPECT_EQ(partial->packing, "split");
  EXPECT_EQ(partial->base_ratio, DefaultSettings().base_ratio);

  auto message = [](const std::string& text) {
    auto r = ParseSettingsJson(text);
    EXPECT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument) << text;
    return r.ok() ? std::string() : r.status().message();
  };
  EXPECT_EQ(message("{\"qp\":40}"), "options.qp: 40 is outside [1, 30]");
  // A value that would wrap to 11 as an int is still out of range.
  EXPECT_EQ(message("{\"qp\":4294967307}"), "options.qp: 4294967307 is outside [1, 30]");
  EXPECT_EQ(message("{\"packet_bytes\":-5}"), "options.packet_bytes: -5 is outside [64, 65507]");
  EXPECT_EQ(message("{\"qp\":11.5}"), "options.qp: not an integer");
  EXPECT_EQ(message("{\"qp\":\"11\"}"), "options.qp: not an integer");
  EXPECT_EQ(message("{\"packing\":1}"), "options.packing: not a string");
  EXPECT_EQ(message("{\"base_ratio\":\"x\"}"), "options.base_ratio: not a number");
  EXPECT_EQ(message("{\"levels\":3}"), "options.levels: not an encode option");
  EXPECT_EQ(message("[1,2]"), "options: not a JSON object");
  EXPECT_EQ(message("{\"qp\":"), "options: not valid JSON");
  EXPECT_NE(message(std::string(5000, ' ') + "{}").find("exceed"), std::string::npos);
}

TEST(PipelineOptions, GlbOptionsAreWhatTheCliFillsForTheSameFlags) {
  const EncodeSettings s{14, 10, 12, "bundled", 200, 0.05};
  const ProgressiveGlbOptions o = ToGlbOptions(s);
  const ProgressiveGlbOptions cli;
  EXPECT_EQ(o.encode.quantization.qp, 14);
  EXPECT_EQ(o.encode.quantization.qn, 10);
  EXPECT_EQ(o.encode.quantization.qt, 12);
  EXPECT_EQ(o.encode.quantization.qc, cli.encode.quantization.qc);
  EXPECT_EQ(o.stream.packing, Packing::kBundled);
  EXPECT_EQ(o.stream.packet_bytes, 200u);
  EXPECT_EQ(o.encode.simplify.base_ratio, 0.05);
  EXPECT_EQ(o.encode.simplify.max_levels, cli.encode.simplify.max_levels);
  EXPECT_EQ(o.draco_compression_level, cli.draco_compression_level);
  EXPECT_FALSE(o.progress);
  EXPECT_EQ(ToGlbOptions(DefaultSettings()).stream.packing, Packing::kSplit);
}

TEST(PipelineOptions, EncoderIdNamesTheFormatVersions) {
  const std::string id = EncoderId();
  EXPECT_EQ(id.rfind("meshstream-progressive/" + std::to_string(kStreamVersion) + " ", 0), 0u) << id;
  EXPECT_NE(id.find("datagram/" + std::to_string(kDatagramVersion)), std::string::npos) << id;
  EXPECT_NE(id.find("draco/"), std::string::npos) << id;
  EXPECT_EQ(id, EncoderId());
}

SourceFile File(const std::string& name, const std::string& content) {
  return SourceFile{name, Sha256Hex(reinterpret_cast<const uint8_t*>(content.data()), content.size()), content.size()};
}

TEST(PipelineOptions, CacheKeyChangesWithEveryOptionAndSourceAndNothingElse) {
  const SourceFile main = File("scene.gltf", "{}");
  const std::vector<SourceFile> resources = {File("scene.bin", "bin"), File("textures/wood.png", "png")};
  const EncodeSettings base = DefaultSettings();
  const std::string key = ArtifactCacheKey("acme", main, resources, base);
  EXPECT_TRUE(IsSha256Hex(key)) << key;

  std::set<std::string> keys = {key};
  auto differs = [&](const std::string& what, const std::string& other) {
    EXPECT_NE(other, key) << what;
    EXPECT_TRUE(keys.insert(other).second) << what << " gives the key of another change";
  };
  std::vector<EncodeSettings> options(6, base);
  options[0].qp = 12;
  options[1].qn = 9;
  options[2].qt = 11;
  options[3].packing = "bundled";
  options[4].packet_bytes = 1000;
  options[5].base_ratio = 0.03;
  for (size_t i = 0; i < options.size(); ++i) differs("option " + std::to_string(i), ArtifactCacheKey("acme", main, resources, options[i]));

  differs("tenant", ArtifactCacheKey("other-tenant", main, resources, base));
  differs("main digest", ArtifactCacheKey("acme", File("scene.gltf", "{ }"), resources, base));
  differs("main name", ArtifactCacheKey("acme", File("other.gltf", "{}"), resources, base));
  differs("resource digest", ArtifactCacheKey("acme", main, {File("scene.bin", "BIN"), resources[1]}, base));
  differs("resource name", ArtifactCacheKey("acme", main, {File("scene2.bin", "bin"), resources[1]}, base));
  differs("resource added", ArtifactCacheKey("acme", main, {resources[0], resources[1], File("extra.bin", "")}, base));
  differs("resource removed", ArtifactCacheKey("acme", main, {resources[0]}, base));
  // Moving a character between the name and the digest is another key (the
  // fields are length-prefixed).
  SourceFile shifted = main;
  shifted.name = main.name + main.sha256.substr(0, 1);
  shifted.sha256 = main.sha256.substr(1);
  differs("shifted fields", ArtifactCacheKey("acme", shifted, resources, base));

  // Not otherwise: defaults given as 0, the order of the resources, sizes.
  EXPECT_EQ(ArtifactCacheKey("acme", main, resources, EncodeSettings{}), key);
  EXPECT_EQ(ArtifactCacheKey("acme", main, {resources[1], resources[0]}, base), key);
  SourceFile resized = main;
  resized.size = 12345;
  EXPECT_EQ(ArtifactCacheKey("acme", resized, resources, base), key);
  EXPECT_EQ(ArtifactCacheKey("acme", main, resources, base), key);
}

}  // namespace
}  // namespace meshstream
