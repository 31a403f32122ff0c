// A version's sources written into a private work folder: names checked
// before anything touches the disk, blobs read verified and capped, the
// folder gone with its WorkFolder.
#include "services/pipeline/materialize.h"

#include <sys/stat.h>

#include <atomic>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "proto/api_names.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/store/blob_store.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

namespace fs = std::filesystem;
using test_util::ModelPath;
using test_util::TempDir;

// Only blobs: what MaterializeVersion uses of a Store.
class BlobOnlyStore : public Store {
 public:
  std::string Put(const std::vector<uint8_t>& bytes) {
    const std::string d = Sha256Hex(bytes.data(), bytes.size());
    blobs_[d] = bytes;
    return d;
  }
  void Corrupt(const std::string& digest) { blobs_[digest][0] ^= 1; }
  std::atomic<int> reads{0};

  std::string backend() const override { return "blobs"; }
  StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() override { return Unsupported("blobs only"); }
  StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& sha256, uint64_t max_bytes) override {
    ++reads;
    auto it = blobs_.find(sha256);
    if (it == blobs_.end()) return NotFound("blob " + sha256 + " does not exist");
    if (it->second.size() > max_bytes) return ResourceExhausted("blob is above the cap");
    if (Sha256Hex(it->second.data(), it->second.size()) != sha256) return DataLoss("blob " + sha256 + " is damaged");
    return it->second;
  }
  StatusOr<bool> DoHasBlob(const std::string& sha256) override { return blobs_.count(sha256) > 0; }
  StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t) override { return Unsupported("blobs only"); }
  StatusOr<uint64_t> DoUploadSize(const std::string&, const std::string&) override { return Unsupported("blobs only"); }
  Status DoAppendUpload(const std::string&, const std::string&, uint64_t, const uint8_t*, size_t) override {
    return Unsupported("blobs only");
  }
  StatusOr<std::string> DoCommitUpload(const std::string&, const std::string&, const std::string&) override {
    return Unsupported("blobs only");
  }
  Status DoDiscardUpload(const std::string&, const std::string&) override { return Unsupported("blobs only"); }
  StatusOr<uint64_t> DoExpireUploads(int64_t) override { return Unsupported("blobs only"); }
  StatusOr<VersionRecord> DoCreateVersion(const NewVersion&) override { return Unsupported("blobs only"); }
  StatusOr<VersionRecord> DoGetVersion(const std::string&, const std::string&, int64_t) override {
    return Unsupported("blobs only");
  }
  StatusOr<VersionRecord> DoGetLatestReadyVersion(const std::string&, const std::string&) override {
    return Unsupported("blobs only");
  }
  StatusOr<PageRows<AssetRecord>> DoListAssets(const std::string&, const std::string&, int64_t) override {
    return Unsupported("blobs only");
  }
  StatusOr<PageRows<VersionRecord>> DoListVersions(const std::string&, const std::string&, int64_t,
                                                   int64_t) override {
    return Unsupported("blobs only");
  }
  StatusOr<JobRecord> DoGetJob(const std::string&, const std::string&) override { return Unsupported("blobs only"); }
  StatusOr<std::optional<JobRecord>> DoClaimJob(const std::string&, int64_t, int64_t) override {
    return Unsupported("blobs only");
  }
  Status DoRenewLease(const std::string&, const std::string&, int64_t, int64_t, double, const std::string&) override {
    return Unsupported("blobs only");
  }
  Status DoCompleteJob(const std::string&, const std::string&, const ArtifactSummary&) override {
    return Unsupported("blobs only");
  }
  Status DoFailJob(const std::string&, const std::string&, const std::string&) override { return Unsupported("blobs only"); }
  StatusOr<int64_t> DoCountUnfinishedJobs() override { return Unsupported("blobs only"); }
  StatusOr<int64_t> DoReleaseAllLeases() override { return Unsupported("blobs only"); }
  StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string&) override { return Unsupported("blobs only"); }
  Status DoPutArtifact(const std::string&, const ArtifactSummary&) override { return Unsupported("blobs only"); }
  StatusOr<TokenRecord> DoCreateToken(const std::string&, bool, const std::string&) override {
    return Unsupported("blobs only");
  }
  StatusOr<TokenRecord> DoFindToken(const std::string&) override { return Unsupported("blobs only"); }
  StatusOr<std::vector<TokenRecord>> DoListTokens() override { return Unsupported("blobs only"); }
  Status DoRevokeToken(const std::string&) override { return Unsupported("blobs only"); }

 private:
  std::map<std::string, std::vector<uint8_t>> blobs_;
};

std::vector<uint8_t> Bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

SourceFile Stored(BlobOnlyStore& store, const std::string& name, const std::vector<uint8_t>& bytes) {
  return SourceFile{name, store.Put(bytes), bytes.size()};
}

mode_t ModeOf(const std::string& path) {
  struct stat st;
  EXPECT_EQ(lstat(path.c_str(), &st), 0) << path;
  return st.st_mode & 0777;
}

size_t EntriesIn(const std::string& dir) {
  size_t n = 0;
  for (auto it = fs::directory_iterator(dir); it != fs::directory_iterator(); ++it) ++n;
  return n;
}

TEST(PipelineMaterialize, WritesEveryFileUnderItsNameInAPrivateFolderRemovedAfterwards) {
  BlobOnlyStore store;
  TempDir parent;
  VersionRecord v;
  v.source = Stored(store, "scene.gltf", Bytes("{\"asset\":{\"version\":\"2.0\"}}"));
  v.resources = {Stored(store, "scene.bin", Bytes("binary")), Stored(store, "textures/wood.png", Bytes("png")),
                 Stored(store, "textures/deep/er/bark.jpg", Bytes("")), Stored(store, "текстуры/дерево.png", Bytes("ктх"))};
  std::string path;
  {
    auto folder = MaterializeVersion(store, v, parent.path());
    ASSERT_TRUE(folder.ok()) << folder.status().ToString();
    path = folder->path();
    EXPECT_EQ(fs::path(path).parent_path(), fs::path(parent.path()));
    EXPECT_EQ(folder->main_path(), path + "/scene.gltf");
    EXPECT_EQ(ModeOf(path), 0700u);
    EXPECT_EQ(test_util::ReadText(folder->main_path()), "{\"asset\":{\"version\":\"2.0\"}}");
    EXPECT_EQ(ModeOf(folder->main_path()), 0600u);
    EXPECT_EQ(test_util::ReadText(path + "/scene.bin"), "binary");
    EXPECT_EQ(test_util::ReadText(path + "/textures/wood.png"), "png");
    EXPECT_EQ(ModeOf(path + "/textures"), 0700u);
    EXPECT_TRUE(fs::is_regular_file(path + "/textures/deep/er/bark.jpg"));
    EXPECT_EQ(test_util::ReadText(path + "/текстуры/дерево.png"), "ктх");
    EXPECT_EQ(folder->bytes_written(), 27u + 6 + 3 + 0 + 6);
    // Moving hands the folder over; only the last owner removes it.
    WorkFolder moved = std::move(folder).value();
    EXPECT_TRUE(fs::is_directory(path));
    WorkFolder again;
    again = std::move(moved);
    EXPECT_TRUE(fs::is_directory(path));
    EXPECT_EQ(again.path(), path);
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(EntriesIn(parent.path()), 0u);
}

TEST(PipelineMaterialize, BadNamesAreRefusedBeforeAnythingIsRead) {
  BlobOnlyStore store;
  TempDir parent;
  const SourceFile main = Stored(store, "scene.gltf", Bytes("{}"));
  const SourceFile bin = Stored(store, "scene.bin", Bytes("bin"));
  auto refused = [&](const SourceFile& m, const std::vector<SourceFile>& resources) {
    VersionRecord v;
    v.source = m;
    v.resources = resources;
    store.reads = 0;
    auto r = MaterializeVersion(store, v, parent.path());
    EXPECT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument) << r.status().ToString();
    EXPECT_EQ(store.reads.load(), 0);
    EXPECT_EQ(EntriesIn(parent.path()), 0u);  // nothing left behind
    return r.ok() ? std::string() : r.status().message();
  };
  for (const std::string name : {"../a.bin", "/etc/passwd", "a/../../b", "a\\b", "C:x", "", ".", "a//b"}) {
    SourceFile r = bin;
    r.name = name;
    EXPECT_EQ(refused(main, {r}), CheckResourceName(name).message()) << name;
  }
  SourceFile nul = bin;
  nul.name = std::string("a\0b", 3);
  EXPECT_NE(refused(main, {nul}).find("NUL"), std::string::npos);
  SourceFile bad_main = main;
  bad_main.name = "../scene.gltf";
  EXPECT_EQ(refused(bad_main, {}).rfind("filename '../scene.gltf'", 0), 0u);
  bad_main.name = "scene.fbx";
  EXPECT_EQ(refused(bad_main, {}).rfind("filename 'scene.fbx'", 0), 0u);
  EXPECT_NE(refused(main, {bin, bin}).find("given twice"), std::string::npos);
  SourceFile shadow = bin;
  shadow.name = "scene.gltf";
  EXPECT_NE(refused(main, {shadow}).find("given twice (or the main file's name)"), std::string::npos);
}

TEST(PipelineMaterialize, AFileWhereAFolderMustGoIsRefusedAndCleanedUp) {
  BlobOnlyStore store;
  TempDir parent;
  VersionRecord v;
  v.source = Stored(store, "scene.gltf", Bytes("{}"));
  v.resources = {Stored(store, "textures", Bytes("a file")), Stored(store, "textures/wood.png", Bytes("png"))};
  auto r = MaterializeVersion(store, v, parent.path());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(r.status().message(), "resource name 'textures/wood.png': 'textures' is also a file");
  v.resources = {Stored(store, "textures/wood.png", Bytes("png")), Stored(store, "textures", Bytes("a file"))};
  r = MaterializeVersion(store, v, parent.path());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message(), "resource name 'textures': given twice, or also a folder of another name");
  EXPECT_EQ(EntriesIn(parent.path()), 0u);
}

TEST(PipelineMaterialize, BlobsAreReadVerifiedAndCapped) {
  BlobOnlyStore store;
  TempDir parent;
  VersionRecord v;
  v.source = Stored(store, "model.obj", Bytes("v 0 0 0\n"));
  // A record whose size is not the blob's.
  VersionRecord lying = v;
  lying.source.size = 3;
  auto r = MaterializeVersion(store, lying, parent.path());
  EXPECT_EQ(r.status().code(), StatusCode::kDataLoss) << r.status().ToString();
  lying.source.size = 100;
  r = MaterializeVersion(store, lying, parent.path());
  EXPECT_EQ(r.status().code(), StatusCode::kDataLoss) << r.status().ToString();
  // A missing blob, a damaged one.
  VersionRecord missing = v;
  missing.resources = {SourceFile{"a.bin", std::string(64, 'a'), 1}};
  r = MaterializeVersion(store, missing, parent.path());
  EXPECT_EQ(r.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(r.status().message().rfind("a.bin: ", 0), 0u) << r.status().message();
  VersionRecord damaged = v;
  damaged.resources = {Stored(store, "b.bin", Bytes("bytes"))};
  store.Corrupt(damaged.resources[0].sha256);
  r = MaterializeVersion(store, damaged, parent.path());
  EXPECT_EQ(r.status().code(), StatusCode::kDataLoss);
  // Above the cap, on the recorded sizes, before any read.
  VersionRecord big = v;
  big.resources = {Stored(store, "c.bin", std::vector<uint8_t>(1000, 7))};
  store.reads = 0;
  r = MaterializeVersion(store, big, parent.path(), 1000);
  EXPECT_EQ(r.status().code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(store.reads.load(), 0);
  EXPECT_TRUE(MaterializeVersion(store, big, parent.path(), 1008).ok());
  EXPECT_EQ(EntriesIn(parent.path()), 0u);
  // A parent that does not exist.
  r = MaterializeVersion(store, v, parent.File("absent"));
  EXPECT_EQ(r.status().code(), StatusCode::kIoError);
}

TEST(PipelineMaterialize, AMaterializedGltfWithItsBinProcesses) {
  BlobOnlyStore store;
  TempDir parent;
  const std::string dir = ModelPath("gltf/draco-2CylinderEngine");
  auto gltf = ReadFileBytes(dir + "/2CylinderEngine.gltf", uint64_t{1} << 30);
  auto bin = ReadFileBytes(dir + "/2CylinderEngine.bin", uint64_t{1} << 30);
  ASSERT_TRUE(gltf.ok() && bin.ok());
  VersionRecord v;
  v.source = Stored(store, "engine.gltf", gltf.value());
  v.resources = {Stored(store, "2CylinderEngine.bin", bin.value())};
  auto folder = MaterializeVersion(store, v, parent.path());
  ASSERT_TRUE(folder.ok()) << folder.status().ToString();
  auto processed = ProcessSource(folder->main_path(), DefaultSettings(), nullptr);
  ASSERT_TRUE(processed.ok()) << processed.status().ToString();
  auto direct = ProcessSource(dir + "/2CylinderEngine.gltf", DefaultSettings(), nullptr);
  ASSERT_TRUE(direct.ok());
  EXPECT_EQ(processed->summary.artifact_sha256, direct->summary.artifact_sha256);
  // Without its .bin the importer says what is missing, by its name.
  VersionRecord alone = v;
  alone.resources.clear();
  auto lonely = MaterializeVersion(store, alone, parent.path());
  ASSERT_TRUE(lonely.ok());
  auto failed = ProcessSource(lonely->main_path(), DefaultSettings(), nullptr);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.status().message().find(lonely->path()), std::string::npos) << failed.status().message();
  EXPECT_NE(failed.status().message().find("2CylinderEngine.bin"), std::string::npos) << failed.status().message();
}

}  // namespace
}  // namespace meshstream
