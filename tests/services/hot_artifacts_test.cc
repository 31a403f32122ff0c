// The cache of hot artifacts (services/streaming/hot_artifacts.h) on real
// artifacts of the pipeline and a real blob folder: entries stay between
// sessions, within a bound of bytes, the least recently used going first;
// an entry a session holds is shared beyond the bound; the store's checked
// read happens once per load, and a corrupt blob is refused at load and
// never kept.
#include "services/streaming/hot_artifacts.h"

#include <filesystem>
#include <fstream>
#include <algorithm>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/store/blob_store.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

struct Artifact {
  std::string sha256;
  std::string layout_json;
  std::vector<uint8_t> glb;
};

// An artifact of the pipeline, in `blobs` under its digest.
Artifact Stored(const FileBlobStore& blobs, const std::string& model) {
  auto settings = ResolveSettings(EncodeSettings{});
  EXPECT_TRUE(settings.ok());
  auto r = ProcessSource(test_util::ModelPath(model), settings.value(), nullptr);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  if (!r.ok()) return {};
  auto sha = blobs.Put(r->glb.data(), r->glb.size());
  EXPECT_TRUE(sha.ok()) << sha.status().ToString();
  return {sha.ok() ? sha.value() : "", r->summary.layout_json, r->glb};
}

// The cache over a blob folder, counting the store's reads per digest.
struct Fixture {
  explicit Fixture(const FileBlobStore& b) : blobs(b) {}
  StatusOr<HotArtifacts::Entry> Get(HotArtifacts& cache, const Artifact& a) {
    return cache.Get(a.sha256, a.layout_json, [&] {
      ++reads[a.sha256];
      return blobs.Get(a.sha256, uint64_t{1} << 30);
    });
  }
  const FileBlobStore& blobs;
  std::map<std::string, int> reads;
};

uint64_t CostOf(const Artifact& a) {
  auto hot = MakeHotArtifact(a.sha256, a.layout_json, a.glb);
  EXPECT_TRUE(hot.ok()) << hot.status().ToString();
  return hot.ok() ? hot.value()->cost_bytes : 0;
}

class HotArtifactsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto blobs = FileBlobStore::Open(dir_.path());
    ASSERT_TRUE(blobs.ok()) << blobs.status().ToString();
    blobs_.emplace(std::move(blobs).value());
  }
  test_util::TempDir dir_;
  std::optional<FileBlobStore> blobs_;
};

TEST_F(HotArtifactsTest, EntriesStayWithinTheBoundLeastRecentlyUsedOutFirst) {
  const Artifact spot = Stored(*blobs_, "spot.obj"), fandisk = Stored(*blobs_, "fandisk.obj"),
                 rocker = Stored(*blobs_, "rocker-arm.obj");
  const uint64_t a = CostOf(spot), b = CostOf(fandisk), c = CostOf(rocker);
  ASSERT_GT(a, spot.glb.size());
  // Room for the two larger ones, never for all three.
  const uint64_t bound = a + b + c - std::min({a, b, c});
  HotArtifacts cache(bound);
  Fixture f(*blobs_);
  ASSERT_TRUE(f.Get(cache, spot).ok());
  ASSERT_TRUE(f.Get(cache, fandisk).ok());
  // No session holds them, and still a second session of each reads nothing.
  auto again = f.Get(cache, spot);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(f.reads[spot.sha256], 1) << "the store's read (and its digest) once, not per session";
  EXPECT_EQ(f.reads[fandisk.sha256], 1);
  EXPECT_EQ(again.value()->plan.refinements.size(), PlanSession(spot.glb, spot.layout_json, -1)->refinements.size());
  EXPECT_FALSE(again.value()->scene.empty());
  again = HotArtifacts::Entry();
  // spot was used last: the rocker arm pushes fandisk out, not spot.
  ASSERT_TRUE(f.Get(cache, rocker).ok());
  EXPECT_LE(cache.stats().bytes, bound);
  EXPECT_EQ(cache.stats().evictions, 1u);
  ASSERT_TRUE(f.Get(cache, spot).ok());
  EXPECT_EQ(f.reads[spot.sha256], 1) << "the most recently used entry stays";
  ASSERT_TRUE(f.Get(cache, fandisk).ok());
  EXPECT_EQ(f.reads[fandisk.sha256], 2) << "the least recently used entry went";
  const HotArtifactsStats s = cache.stats();
  EXPECT_LE(s.bytes, bound);
  EXPECT_EQ(s.loads, 4u);
  EXPECT_EQ(s.hits, 2u);
}

TEST_F(HotArtifactsTest, AnEntryASessionHoldsIsSharedBeyondTheBound) {
  const Artifact spot = Stored(*blobs_, "spot.obj");
  HotArtifacts cache(0);  // keeps nothing by itself
  Fixture f(*blobs_);
  auto held = f.Get(cache, spot);
  ASSERT_TRUE(held.ok());
  auto second = f.Get(cache, spot);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second.value().get(), held.value().get()) << "one copy for every session of the artifact";
  EXPECT_EQ(f.reads[spot.sha256], 1);
  EXPECT_EQ(cache.stats().bytes, 0u);
  held = HotArtifacts::Entry();
  second = HotArtifacts::Entry();
  ASSERT_TRUE(f.Get(cache, spot).ok());
  EXPECT_EQ(f.reads[spot.sha256], 2) << "gone with the last session that held it";
}

TEST_F(HotArtifactsTest, ACorruptArtifactIsRefusedAtLoadAndNeverKept) {
  const Artifact spot = Stored(*blobs_, "spot.obj");
  const std::string path = blobs_->root() + "/" + spot.sha256.substr(0, 2) + "/" + spot.sha256;
  {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(spot.glb.size() / 2));
    file.put(static_cast<char>(spot.glb[spot.glb.size() / 2] ^ 0x5a));
  }
  HotArtifacts cache(uint64_t{64} << 20);
  Fixture f(*blobs_);
  for (int session = 0; session < 2; ++session) {
    auto entry = f.Get(cache, spot);
    ASSERT_FALSE(entry.ok());
    EXPECT_EQ(entry.status().code(), StatusCode::kDataLoss) << entry.status().ToString();
  }
  EXPECT_EQ(f.reads[spot.sha256], 2) << "a refused load keeps nothing: the next session reads (and refuses) again";
  EXPECT_EQ(cache.stats().entries, 0u);
}

TEST_F(HotArtifactsTest, AnotherLayoutOfTheSameBytesIsPlannedOnItsOwn) {
  const Artifact spot = Stored(*blobs_, "spot.obj");
  HotArtifacts cache(uint64_t{64} << 20);
  Fixture f(*blobs_);
  ASSERT_TRUE(f.Get(cache, spot).ok());
  Artifact wrong = spot;
  wrong.layout_json = "{not json";
  auto refused = f.Get(cache, wrong);
  EXPECT_EQ(refused.status().code(), StatusCode::kDataLoss) << refused.status().ToString();
  auto kept = f.Get(cache, spot);
  ASSERT_TRUE(kept.ok());
  EXPECT_EQ(kept.value()->layout_json, spot.layout_json);
}

TEST(CutPlan, IsPlanSessionWithMaxLevel) {
  auto settings = ResolveSettings(EncodeSettings{});
  ASSERT_TRUE(settings.ok());
  auto r = ProcessSource(test_util::ModelPath("gltf/2CylinderEngine.glb"), settings.value(), nullptr);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  auto full = PlanSession(r->glb, r->summary.layout_json, -1);
  ASSERT_TRUE(full.ok());
  for (int32_t level : {0, 1, 3, 1000}) {
    auto direct = PlanSession(r->glb, r->summary.layout_json, level);
    ASSERT_TRUE(direct.ok());
    const SessionPlan cut = CutPlan(full.value(), level);
    EXPECT_EQ(cut.levels, direct->levels) << level;
    EXPECT_EQ(cut.reliable_bytes, direct->reliable_bytes) << level;
    EXPECT_EQ(cut.unreliable_bytes, direct->unreliable_bytes) << level;
    ASSERT_EQ(cut.refinements.size(), direct->refinements.size()) << level;
    for (size_t i = 0; i < cut.refinements.size(); ++i) {
      EXPECT_EQ(cut.refinements[i].primitive, direct->refinements[i].primitive);
      EXPECT_EQ(cut.refinements[i].refinement, direct->refinements[i].refinement);
      EXPECT_EQ(cut.refinements[i].datagrams, direct->refinements[i].datagrams);
    }
    ASSERT_EQ(cut.primitives.size(), direct->primitives.size());
    for (size_t i = 0; i < cut.primitives.size(); ++i) {
      EXPECT_EQ(cut.primitives[i].refinements, direct->primitives[i].refinements);
    }
  }
}

}  // namespace
}  // namespace meshstream
