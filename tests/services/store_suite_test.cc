// The store suite (tests/services/store_suite.h): what every Store backend
// must do, on a real store. Backends instantiate it in their own files
// (store_sqlite_test.cc, store_pg_test.cc). The page-token helpers shared by
// the backends are tested here too.
#include "tests/services/store_suite.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "services/store/blob_store.h"
#include "services/store/page_token.h"

namespace meshstream {
namespace {

// --- helpers -------------------------------------------------------------------

const uint8_t* Data(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }
std::vector<uint8_t> Bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }
std::string Sha(const std::string& s) { return Sha256Hex(Data(s), s.size()); }

StatusOr<std::string> PutBlob(Store& store, const std::string& content) {
  MS_ASSIGN_OR_RETURN(std::unique_ptr<BlobSink> sink, store.NewBlob());
  MS_RETURN_IF_ERROR(sink->Append(Data(content), content.size()));
  return sink->Commit();
}

NewVersion MakeVersion(const std::string& tenant, const std::string& asset, const std::string& source_sha256) {
  NewVersion v;
  v.tenant = tenant;
  v.asset = asset;
  v.source = SourceFile{"model.glb", source_sha256, 1234};
  v.options_json = R"({"levels":4})";
  return v;
}

ArtifactSummary MakeSummary(const std::string& artifact_sha256) {
  ArtifactSummary a;
  a.artifact_sha256 = artifact_sha256;
  a.progressive_bytes = (uint64_t{1} << 40) + 3;
  a.encoder = "meshstream-progressive/1 test-build";
  a.vertices = 7680;
  a.faces = 15000;
  a.levels = 4;
  a.level_vertices = {12, 480, 1920, 7680};
  a.reliable_bytes = 4096;
  a.unreliable_bytes = (uint64_t{1} << 33) + 17;
  a.layout_json = R"({"primitives":[{"base":[0,812],"stream":[812,40960]}],"name":"Größe"})";
  a.warnings_json = R"(["a \"quoted\" warning","second"])";
  return a;
}

void ExpectSameSummary(const ArtifactSummary& got, const ArtifactSummary& want) {
  EXPECT_EQ(got.artifact_sha256, want.artifact_sha256);
  EXPECT_EQ(got.progressive_bytes, want.progressive_bytes);
  EXPECT_EQ(got.encoder, want.encoder);
  EXPECT_EQ(got.vertices, want.vertices);
  EXPECT_EQ(got.faces, want.faces);
  EXPECT_EQ(got.levels, want.levels);
  EXPECT_EQ(got.level_vertices, want.level_vertices);
  EXPECT_EQ(got.reliable_bytes, want.reliable_bytes);
  EXPECT_EQ(got.unreliable_bytes, want.unreliable_bytes);
  EXPECT_EQ(got.layout_json, want.layout_json);
  EXPECT_EQ(got.warnings_json, want.warnings_json);
}

void ExpectSameVersion(const VersionRecord& got, const VersionRecord& want) {
  EXPECT_EQ(got.tenant, want.tenant);
  EXPECT_EQ(got.asset, want.asset);
  EXPECT_EQ(got.version, want.version);
  EXPECT_EQ(got.state, want.state);
  EXPECT_EQ(got.source.name, want.source.name);
  EXPECT_EQ(got.source.sha256, want.source.sha256);
  EXPECT_EQ(got.source.size, want.source.size);
  ASSERT_EQ(got.resources.size(), want.resources.size());
  for (size_t i = 0; i < got.resources.size(); ++i) {
    EXPECT_EQ(got.resources[i].name, want.resources[i].name) << i;
    EXPECT_EQ(got.resources[i].sha256, want.resources[i].sha256) << i;
    EXPECT_EQ(got.resources[i].size, want.resources[i].size) << i;
  }
  EXPECT_EQ(got.options_json, want.options_json);
  EXPECT_EQ(got.comment, want.comment);
  EXPECT_EQ(got.labels, want.labels);
  EXPECT_EQ(got.created_ms, want.created_ms);
  EXPECT_EQ(got.job_id, want.job_id);
  EXPECT_EQ(got.error, want.error);
  ExpectSameSummary(got.artifact, want.artifact);
}

std::string ReplaceAll(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

bool Contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// Walks every page of ListAssets at `page_size`, checking each page's shape.
std::vector<std::string> AllAssetNames(Store& store, const std::string& tenant, int32_t page_size) {
  const int32_t effective = EffectivePageSize(page_size).value();
  std::vector<std::string> names;
  std::string token;
  for (int pages = 0; pages < 10000; ++pages) {
    auto page = store.ListAssets(tenant, page_size, token);
    if (!page.ok()) {
      ADD_FAILURE() << page.status().ToString();
      break;
    }
    EXPECT_LE(page->items.size(), static_cast<size_t>(effective));
    if (!page->next_page_token.empty()) {
      EXPECT_EQ(page->items.size(), static_cast<size_t>(effective)) << "only the last page may be short";
    }
    EXPECT_TRUE(!page->items.empty() || (pages == 0 && page->next_page_token.empty())) << "an empty page";
    for (const AssetRecord& a : page->items) {
      EXPECT_EQ(a.tenant, tenant);
      names.push_back(a.name);
    }
    if (page->next_page_token.empty()) break;
    token = page->next_page_token;
  }
  return names;
}

std::vector<int64_t> AllVersionNumbers(Store& store, const std::string& tenant, const std::string& asset,
                                       int32_t page_size) {
  const int32_t effective = EffectivePageSize(page_size).value();
  std::vector<int64_t> numbers;
  std::string token;
  for (int pages = 0; pages < 10000; ++pages) {
    auto page = store.ListVersions(tenant, asset, page_size, token);
    if (!page.ok()) {
      ADD_FAILURE() << page.status().ToString();
      break;
    }
    EXPECT_LE(page->items.size(), static_cast<size_t>(effective));
    if (!page->next_page_token.empty()) {
      EXPECT_EQ(page->items.size(), static_cast<size_t>(effective));
    }
    EXPECT_FALSE(page->items.empty());
    for (const VersionRecord& v : page->items) {
      EXPECT_EQ(v.asset, asset);
      numbers.push_back(v.version);
    }
    if (page->next_page_token.empty()) break;
    token = page->next_page_token;
  }
  return numbers;
}

constexpr int64_t kLease = 60000;

// --- page tokens (backend-independent helpers) ------------------------------

TEST(PageToken, RoundTripsItsCursorForItsKindOnly) {
  for (const std::string& cursor : {std::string("a"), std::string("model-07.v2"), std::string(128, 'z'),
                                   std::string("with\0nul", 8)}) {
    const std::string token = EncodePageToken("assets", cursor);
    EXPECT_EQ(token.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"),
              std::string::npos)
        << token;
    auto decoded = DecodePageToken("assets", token);
    ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
    EXPECT_EQ(decoded.value(), cursor);
    auto other = DecodePageToken("versions", token);
    ASSERT_FALSE(other.ok());
    EXPECT_EQ(other.status().code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(other.status().message(), "page_token: not a token this server issued");
  }
  EXPECT_EQ(DecodePageToken("assets", "").value(), "");
}

TEST(PageToken, GarbledAndHandMadeTokensAreRefused) {
  const std::string good = EncodeAssetsPageToken("model");
  std::vector<std::string> bad = {"x", "abc", "!!!!", "====", good + "=", good.substr(0, good.size() - 1),
                                  std::string(kMaxPageTokenChars + 4, 'A'), "bW9kZWw"};  // base64url("model")
  for (size_t i = 0; i < good.size(); ++i) {
    std::string flipped = good;
    flipped[i] = flipped[i] == 'A' ? 'B' : 'A';
    bad.push_back(flipped);
  }
  for (const std::string& token : bad) {
    auto decoded = DecodeAssetsPageToken(token);
    EXPECT_FALSE(decoded.ok()) << token;
    if (!decoded.ok()) {
      EXPECT_EQ(decoded.status().code(), StatusCode::kInvalidArgument) << token;
    }
  }
  // Well-formed tokens whose cursors the listing could never have issued.
  EXPECT_FALSE(DecodeAssetsPageToken(EncodePageToken(kAssetsPageKind, "../x")).ok());
  for (const std::string cursor : {"", "0", "-1", "07", "1x", "99999999999999999999"}) {
    EXPECT_FALSE(DecodeVersionsPageToken(EncodePageToken(kVersionsPageKind, cursor)).ok()) << cursor;
  }
  EXPECT_EQ(DecodeVersionsPageToken(EncodeVersionsPageToken(41)).value(), 41);
  EXPECT_EQ(DecodeVersionsPageToken("").value(), 0);
  EXPECT_EQ(DecodeAssetsPageToken("").value(), "");
}

TEST(PageToken, PageSizesAreDefaultedClampedAndChecked) {
  EXPECT_EQ(EffectivePageSize(0).value(), kDefaultPageSize);
  EXPECT_EQ(EffectivePageSize(1).value(), 1);
  EXPECT_EQ(EffectivePageSize(kMaxPageSize).value(), kMaxPageSize);
  EXPECT_EQ(EffectivePageSize(kMaxPageSize + 1).value(), kMaxPageSize);
  EXPECT_EQ(EffectivePageSize(INT32_MAX).value(), kMaxPageSize);
  for (const int32_t negative : {-1, INT32_MIN}) {
    auto size = EffectivePageSize(negative);
    ASSERT_FALSE(size.ok());
    EXPECT_EQ(size.status().code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(size.status().message(), "page_size: must not be negative");
  }
}

// --- blobs ---------------------------------------------------------------------

TEST_P(StoreSuite, BlobsAreStoredUnderTheirDigestAndReadBackChecked) {
  const std::string content = "the bytes of a mesh, in two chunks";
  MS_ASSERT_OK_AND_ASSIGN(std::unique_ptr<BlobSink> sink, store().NewBlob());
  MS_ASSERT_OK(sink->Append(Data(content), 10));
  MS_ASSERT_OK(sink->Append(Data(content) + 10, content.size() - 10));
  EXPECT_EQ(sink->size(), content.size());
  EXPECT_FALSE(store().HasBlob(Sha(content)).value());  // nothing visible before Commit
  MS_ASSERT_OK_AND_ASSIGN(const std::string digest, sink->Commit(Sha(content)));
  EXPECT_EQ(digest, Sha(content));
  EXPECT_TRUE(store().HasBlob(digest).value());
  MS_ASSERT_OK_AND_ASSIGN(const std::vector<uint8_t> read, store().GetBlob(digest, content.size()));
  EXPECT_EQ(read, Bytes(content));
  EXPECT_CODE(store().GetBlob(digest, content.size() - 1), StatusCode::kResourceExhausted);
  // The same bytes again: the same name, no error.
  EXPECT_EQ(PutBlob(store(), content).value(), digest);
  MS_ASSERT_OK_AND_ASSIGN(const std::string empty, PutBlob(store(), ""));
  EXPECT_EQ(empty, Sha(""));
  EXPECT_TRUE(store().GetBlob(empty, 0).value().empty());

  const std::string unknown(64, 'c');
  EXPECT_FALSE(store().HasBlob(unknown).value());
  EXPECT_CODE(store().GetBlob(unknown, 1 << 20), StatusCode::kNotFound);
  for (const std::string& bad : {std::string(), std::string("nope"), std::string("../../etc/passwd"),
                                 std::string(64, 'C'), std::string(63, 'c')}) {
    EXPECT_CODE(store().HasBlob(bad), StatusCode::kInvalidArgument);
    EXPECT_CODE(store().GetBlob(bad, 1 << 20), StatusCode::kInvalidArgument);
  }
}

TEST_P(StoreSuite, ABlobWithAnotherDigestThanAnnouncedIsDataLossAndNotStored) {
  const std::string content = "uploaded bytes";
  const std::string announced = Sha("other bytes");
  MS_ASSERT_OK_AND_ASSIGN(std::unique_ptr<BlobSink> sink, store().NewBlob());
  MS_ASSERT_OK(sink->Append(Data(content), content.size()));
  auto digest = sink->Commit(announced);
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), StatusCode::kDataLoss);
  EXPECT_FALSE(store().HasBlob(Sha(content)).value());
  EXPECT_FALSE(store().HasBlob(announced).value());
  // A sink dropped without Commit stores nothing either.
  {
    MS_ASSERT_OK_AND_ASSIGN(std::unique_ptr<BlobSink> dropped, store().NewBlob());
    MS_ASSERT_OK(dropped->Append(Data(content), content.size()));
  }
  EXPECT_FALSE(store().HasBlob(Sha(content)).value());
}

// --- versions ------------------------------------------------------------------

TEST_P(StoreSuite, VersionsAreNumberedPerAssetAndPerTenant) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  std::vector<int64_t> chair, table, other_chair;
  for (int i = 0; i < 3; ++i) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
    chair.push_back(v.version);
  }
  for (int i = 0; i < 2; ++i) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "table", src)));
    table.push_back(v.version);
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord w, store().CreateVersion(MakeVersion("globex", "chair", src)));
    other_chair.push_back(w.version);
  }
  EXPECT_EQ(chair, (std::vector<int64_t>{1, 2, 3}));
  EXPECT_EQ(table, (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(other_chair, (std::vector<int64_t>{1, 2}));

  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord latest, store().GetVersion("acme", "chair", 0));
  EXPECT_EQ(latest.version, 3);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord second, store().GetVersion("acme", "chair", 2));
  EXPECT_EQ(second.version, 2);
  EXPECT_EQ(second.state, VersionState::kProcessing);
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> assets, store().ListAssets("acme", 0, ""));
  ASSERT_EQ(assets.items.size(), 2u);
  EXPECT_EQ(assets.items[0].name, "chair");
  EXPECT_EQ(assets.items[0].latest_version, 3);
  EXPECT_EQ(assets.items[1].name, "table");
  EXPECT_EQ(assets.items[1].latest_version, 2);
  EXPECT_GT(assets.items[0].updated_ms, 0);

  Reopen();  // numbering continues after a restart
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord fourth, store().CreateVersion(MakeVersion("acme", "chair", src)));
  EXPECT_EQ(fourth.version, 4);
}

TEST_P(StoreSuite, AVersionRoundTripsEveryFieldAndGetsAPendingJob) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "a .gltf"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string bin, PutBlob(store(), "its buffer"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string png, PutBlob(store(), "its texture"));
  NewVersion v = MakeVersion("acme", "lamp", src);
  v.source = SourceFile{"Lamp Model.gltf", src, 7};
  v.resources = {SourceFile{"buffers/lamp.bin", bin, 10}, SourceFile{"textures/Größe.png", png, 11},
                 SourceFile{"again/lamp.bin", bin, 10}};
  v.options_json = R"({"grid_bits":14,"levels":6})";
  v.comment = "first import — with \"quotes\", a 'tick' and a\nnewline";
  v.labels = {{"team", "lighting"}, {"état", "brouillon"}, {"empty", ""}};
  const int64_t before = NowMs();
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord created, store().CreateVersion(v));
  EXPECT_EQ(created.tenant, "acme");
  EXPECT_EQ(created.asset, "lamp");
  EXPECT_EQ(created.version, 1);
  EXPECT_EQ(created.state, VersionState::kProcessing);
  EXPECT_GE(created.created_ms, before);
  EXPECT_LE(created.created_ms, NowMs());
  EXPECT_FALSE(created.job_id.empty());
  EXPECT_TRUE(IsValidName(created.job_id)) << created.job_id;
  EXPECT_TRUE(created.error.empty());
  EXPECT_TRUE(created.artifact.artifact_sha256.empty());

  VersionRecord want;
  want.tenant = v.tenant;
  want.asset = v.asset;
  want.version = 1;
  want.state = VersionState::kProcessing;
  want.source = v.source;
  want.resources = v.resources;
  want.options_json = v.options_json;
  want.comment = v.comment;
  want.labels = v.labels;
  want.created_ms = created.created_ms;
  want.job_id = created.job_id;
  ExpectSameVersion(created, want);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord read, store().GetVersion("acme", "lamp", 1));
  ExpectSameVersion(read, want);

  MS_ASSERT_OK_AND_ASSIGN(const JobRecord job, store().GetJob("acme", created.job_id));
  EXPECT_EQ(job.id, created.job_id);
  EXPECT_EQ(job.tenant, "acme");
  EXPECT_EQ(job.asset, "lamp");
  EXPECT_EQ(job.version, 1);
  EXPECT_EQ(job.state, JobState::kPending);
  EXPECT_EQ(job.attempts, 0);
  EXPECT_TRUE(job.lease_owner.empty());
  EXPECT_GE(job.created_ms, before);

  Reopen();
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord reread, store().GetVersion("acme", "lamp", 0));
  ExpectSameVersion(reread, want);
  MS_ASSERT_OK_AND_ASSIGN(const Page<VersionRecord> listed, store().ListVersions("acme", "lamp", 0, ""));
  ASSERT_EQ(listed.items.size(), 1u);
  ExpectSameVersion(listed.items[0], want);
}

TEST_P(StoreSuite, AVersionNamingAMissingBlobIsFailedPreconditionAndChangesNothing) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "present"));
  const std::string missing = Sha("never stored");
  auto no_source = store().CreateVersion(MakeVersion("acme", "ghost", missing));
  ASSERT_FALSE(no_source.ok());
  EXPECT_EQ(no_source.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(Contains(no_source.status().message(), missing)) << no_source.status().message();

  NewVersion v = MakeVersion("acme", "ghost", src);
  v.resources = {SourceFile{"a.bin", src, 7}, SourceFile{"b.bin", missing, 3}};
  auto no_resource = store().CreateVersion(v);
  ASSERT_FALSE(no_resource.ok());
  EXPECT_EQ(no_resource.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(Contains(no_resource.status().message(), missing)) << no_resource.status().message();

  EXPECT_CODE(store().GetVersion("acme", "ghost", 0), StatusCode::kNotFound);
  EXPECT_TRUE(store().ListAssets("acme", 0, "").value().items.empty());
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 0);
  EXPECT_FALSE(store().ClaimJob("w", NowMs(), kLease).value().has_value());
  // The failed attempts used no version number.
  EXPECT_EQ(store().CreateVersion(MakeVersion("acme", "ghost", src)).value().version, 1);
}

TEST_P(StoreSuite, BadNamesAndArgumentsAreInvalidArgumentNamingTheField) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  const std::string long_name(129, 'a');
  const auto expect_field = [](const Status& status, const std::string& field, const std::string& what) {
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << what << ": " << status.ToString();
    EXPECT_TRUE(Contains(status.message(), field)) << what << ": " << status.message();
  };
  expect_field(StatusOf(store().CreateVersion(MakeVersion("", "chair", src))), "tenant", "empty tenant");
  expect_field(StatusOf(store().CreateVersion(MakeVersion("ac me", "chair", src))), "tenant", "tenant with space");
  expect_field(StatusOf(store().CreateVersion(MakeVersion("acme", "a/b", src))), "asset", "asset with slash");
  expect_field(StatusOf(store().CreateVersion(MakeVersion("acme", long_name, src))), "asset", "long asset");
  expect_field(StatusOf(store().CreateVersion(MakeVersion("acme", "chair", "not-a-digest"))), "sha256",
               "source digest");
  NewVersion bad_resource = MakeVersion("acme", "chair", src);
  bad_resource.resources = {SourceFile{"x.bin", "ABC", 1}};
  expect_field(StatusOf(store().CreateVersion(bad_resource)), "sha256", "resource digest");
  expect_field(StatusOf(store().GetVersion("../x", "chair", 0)), "tenant", "GetVersion tenant");
  expect_field(StatusOf(store().GetVersion("acme", "", 0)), "asset", "GetVersion asset");
  expect_field(StatusOf(store().GetVersion("acme", "chair", -1)), "version", "negative version");
  expect_field(StatusOf(store().GetLatestReadyVersion("acme", "é")), "asset", "GetLatestReadyVersion asset");
  expect_field(StatusOf(store().ListAssets("", 0, "")), "tenant", "ListAssets tenant");
  expect_field(StatusOf(store().ListVersions("acme", "a\nb", 0, "")), "asset", "ListVersions asset");
  expect_field(StatusOf(store().GetJob("acme", "job id")), "job_id", "GetJob id");
  expect_field(StatusOf(store().GetJob("t/", "abc")), "tenant", "GetJob tenant");
  expect_field(StatusOf(store().UploadSize("acme", "../../etc/passwd")), "upload_id", "UploadSize id");
  expect_field(store().AppendUpload("", "u1", 0, Data("x"), 1), "tenant", "AppendUpload tenant");
  expect_field(StatusOf(store().CommitUpload("acme", "", "")), "upload_id", "CommitUpload id");
  expect_field(store().DiscardUpload("acme", "u\\1"), "upload_id", "DiscardUpload id");
  expect_field(StatusOf(store().CreateToken("", false, Sha("token"))), "tenant", "CreateToken tenant");
  EXPECT_CODE(store().HasBlob("XYZ"), StatusCode::kInvalidArgument);
  // Nothing was created by any of them.
  EXPECT_TRUE(store().ListAssets("acme", 0, "").value().items.empty());
}

TEST_P(StoreSuite, VersionZeroIsTheLatestAndUnknownOnesAreNotFound) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  EXPECT_CODE(store().GetVersion("acme", "chair", 0), StatusCode::kNotFound);
  EXPECT_CODE(store().GetVersion("acme", "chair", 1), StatusCode::kNotFound);
  EXPECT_CODE(store().ListVersions("acme", "chair", 0, ""), StatusCode::kNotFound);
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));
  EXPECT_EQ(store().GetVersion("acme", "chair", 0).value().version, 2);
  EXPECT_EQ(store().GetVersion("acme", "chair", 1).value().version, 1);
  EXPECT_CODE(store().GetVersion("acme", "chair", 3), StatusCode::kNotFound);
  EXPECT_CODE(store().GetVersion("acme", "Chair", 0), StatusCode::kNotFound);  // names are case-sensitive
}

// Claims the job of `v` (the only claimable one) and completes or fails it.
void FinishVersion(Store& store, const VersionRecord& v, bool ready, const std::string& artifact) {
  auto claimed = store.ClaimJob("finisher", NowMs(), kLease);
  ASSERT_TRUE(claimed.ok()) << claimed.status().ToString();
  ASSERT_TRUE(claimed->has_value());
  ASSERT_EQ(claimed->value().id, v.job_id);
  if (ready) {
    MS_ASSERT_OK(store.CompleteJob(v.job_id, "finisher", MakeSummary(artifact)));
  } else {
    MS_ASSERT_OK(store.FailJob(v.job_id, "finisher", "the importer refused it"));
  }
}

TEST_P(StoreSuite, TheLatestReadyVersionSkipsProcessingAndFailedOnes) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v1, store().CreateVersion(MakeVersion("acme", "chair", src)));
  EXPECT_CODE(store().GetLatestReadyVersion("acme", "chair"), StatusCode::kNotFound);
  EXPECT_CODE(store().GetLatestReadyVersion("acme", "nothing"), StatusCode::kNotFound);
  FinishVersion(store(), v1, true, art);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v2, store().CreateVersion(MakeVersion("acme", "chair", src)));
  FinishVersion(store(), v2, false, art);
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));  // v3 stays PROCESSING
  EXPECT_EQ(store().GetVersion("acme", "chair", 0).value().version, 3);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord ready, store().GetLatestReadyVersion("acme", "chair"));
  EXPECT_EQ(ready.version, 1);
  EXPECT_EQ(ready.state, VersionState::kReady);
  ExpectSameSummary(ready.artifact, MakeSummary(art));
}

TEST_P(StoreSuite, AnotherTenantSeesNothingAndLearnsNothing) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord mine, store().CreateVersion(MakeVersion("acme", "secret", src)));
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("globex", "public", src)));
  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 0, Data("hello"), 5));

  // The answer for another tenant's object is exactly the answer for a missing one.
  const auto same_as_missing = [&](const Status& theirs, const Status& missing, const std::string& missing_name,
                                   const std::string& real_name) {
    EXPECT_EQ(theirs.code(), StatusCode::kNotFound) << theirs.ToString();
    EXPECT_EQ(theirs.code(), missing.code());
    EXPECT_EQ(theirs.message(), ReplaceAll(missing.message(), missing_name, real_name));
    EXPECT_FALSE(Contains(theirs.message(), "acme")) << theirs.message();
  };
  same_as_missing(StatusOf(store().GetVersion("globex", "secret", 0)),
                  StatusOf(store().GetVersion("acme", "nothere", 0)), "nothere", "secret");
  same_as_missing(StatusOf(store().GetVersion("globex", "secret", 1)),
                  StatusOf(store().GetVersion("acme", "nothere", 1)), "nothere", "secret");
  same_as_missing(StatusOf(store().GetLatestReadyVersion("globex", "secret")),
                  StatusOf(store().GetLatestReadyVersion("acme", "nothere")), "nothere", "secret");
  same_as_missing(StatusOf(store().ListVersions("globex", "secret", 0, "")),
                  StatusOf(store().ListVersions("acme", "nothere", 0, "")), "nothere", "secret");
  const std::string fake_job(32, 'f');
  same_as_missing(StatusOf(store().GetJob("globex", mine.job_id)), StatusOf(store().GetJob("acme", fake_job)),
                  fake_job, mine.job_id);
  same_as_missing(StatusOf(store().UploadSize("globex", "up1")), StatusOf(store().UploadSize("acme", "up2")), "up2",
                  "up1");
  same_as_missing(StatusOf(store().CommitUpload("globex", "up1", "")),
                  StatusOf(store().CommitUpload("acme", "up2", "")), "up2", "up1");
  same_as_missing(store().DiscardUpload("globex", "up1"), store().DiscardUpload("acme", "up2"), "up2", "up1");

  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> theirs, store().ListAssets("globex", 0, ""));
  ASSERT_EQ(theirs.items.size(), 1u);
  EXPECT_EQ(theirs.items[0].name, "public");
  EXPECT_TRUE(store().ListAssets("initech", 0, "").value().items.empty());
  // An append at 0 by the other tenant starts its own upload; acme's is untouched.
  MS_ASSERT_OK(store().AppendUpload("globex", "up1", 0, Data("xy"), 2));
  EXPECT_EQ(store().UploadSize("globex", "up1").value(), 2u);
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 5u);
  EXPECT_EQ(store().CommitUpload("acme", "up1", "").value(), Sha("hello"));
}

// --- pagination ----------------------------------------------------------------

TEST_P(StoreSuite, AssetPagesListEveryAssetOnceInByteOrderAtEverySize) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  std::vector<std::string> names = {"B", "a", "_c", "-d", ".e", "9f", "Zz", "z"};
  for (int i = 0; names.size() < 55; ++i) names.push_back("asset-" + std::to_string(100 + i * 7));
  for (const std::string& name : names) MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", name, src)));
  for (const char* name : {"a", "zz", "other"}) {
    MS_ASSERT_OK(store().CreateVersion(MakeVersion("globex", name, src)));
  }
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());  // byte order: '-' < '.' < digits < upper < '_' < lower

  for (const int32_t size : {1, 7, 0, 50, 54, 55, 56, kMaxPageSize, 1 << 30}) {
    EXPECT_EQ(AllAssetNames(store(), "acme", size), sorted) << "page size " << size;
  }
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> first, store().ListAssets("acme", 0, ""));
  EXPECT_EQ(first.items.size(), static_cast<size_t>(kDefaultPageSize));
  EXPECT_FALSE(first.next_page_token.empty());
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> all, store().ListAssets("acme", 55, ""));
  EXPECT_EQ(all.items.size(), 55u);
  EXPECT_TRUE(all.next_page_token.empty()) << "no empty page after an exactly full one";

  // A token is a position, not a snapshot: an asset added behind it shows up.
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> one, store().ListAssets("acme", 1, ""));
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "zzz-late", src)));
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> rest, store().ListAssets("acme", kMaxPageSize, one.next_page_token));
  EXPECT_EQ(rest.items.size(), 55u);
  EXPECT_EQ(rest.items.back().name, "zzz-late");
  // Tokens survive a restart.
  Reopen();
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> after, store().ListAssets("acme", 3, one.next_page_token));
  ASSERT_EQ(after.items.size(), 3u);
  EXPECT_EQ(after.items[0].name, sorted[1]);
}

TEST_P(StoreSuite, VersionPagesListEveryVersionOnceInOrder) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  for (int i = 0; i < 9; ++i) MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "table", src)));
  const std::vector<int64_t> all = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  for (const int32_t size : {1, 2, 4, 8, 9, 10, 0, 1 << 30}) {
    EXPECT_EQ(AllVersionNumbers(store(), "acme", "chair", size), all) << "page size " << size;
  }
  EXPECT_EQ(AllVersionNumbers(store(), "acme", "table", 1), (std::vector<int64_t>{1}));
}

TEST_P(StoreSuite, MalformedPageArgumentsAreInvalidArgument) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  for (int i = 0; i < 3; ++i) {
    MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "asset" + std::to_string(i), src)));
    MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "asset0", src)));
  }
  MS_ASSERT_OK_AND_ASSIGN(const Page<AssetRecord> assets, store().ListAssets("acme", 1, ""));
  MS_ASSERT_OK_AND_ASSIGN(const Page<VersionRecord> versions, store().ListVersions("acme", "asset0", 1, ""));
  ASSERT_FALSE(assets.next_page_token.empty());
  ASSERT_FALSE(versions.next_page_token.empty());

  const auto expect_invalid = [](const Status& status, const std::string& field, const std::string& what) {
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << what << ": " << status.ToString();
    EXPECT_TRUE(Contains(status.message(), field)) << what << ": " << status.message();
  };
  for (const int32_t negative : {-1, -1000, INT32_MIN}) {
    expect_invalid(StatusOf(store().ListAssets("acme", negative, "")), "page_size", "assets, negative size");
    expect_invalid(StatusOf(store().ListVersions("acme", "asset0", negative, "")), "page_size",
                   "versions, negative size");
  }
  std::string flipped = assets.next_page_token;
  flipped[flipped.size() / 2] = flipped[flipped.size() / 2] == 'x' ? 'y' : 'x';
  for (const std::string& garbage : {std::string("garbage"), std::string("%%%"), std::string(5000, 'A'), flipped,
                                    std::string("bmFtZQ")}) {
    expect_invalid(StatusOf(store().ListAssets("acme", 1, garbage)), "page_token", "assets, " + garbage.substr(0, 20));
    expect_invalid(StatusOf(store().ListVersions("acme", "asset0", 1, garbage)), "page_token",
                   "versions, " + garbage.substr(0, 20));
  }
  expect_invalid(StatusOf(store().ListAssets("acme", 1, versions.next_page_token)), "page_token",
                 "a versions token for assets");
  expect_invalid(StatusOf(store().ListVersions("acme", "asset0", 1, assets.next_page_token)), "page_token",
                 "an assets token for versions");
  // The real tokens still work.
  MS_EXPECT_OK(store().ListAssets("acme", 1, assets.next_page_token));
  MS_EXPECT_OK(store().ListVersions("acme", "asset0", 1, versions.next_page_token));
}

// --- jobs ------------------------------------------------------------------------

TEST_P(StoreSuite, JobsAreClaimedOldestFirst) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  std::vector<VersionRecord> created;
  for (const auto& [tenant, asset] : std::vector<std::pair<std::string, std::string>>{
           {"acme", "chair"}, {"globex", "lamp"}, {"acme", "chair"}, {"acme", "table"}, {"initech", "a"}}) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion(tenant, asset, src)));
    created.push_back(v);
  }
  const int64_t now = NowMs();
  for (const VersionRecord& v : created) {
    MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> job, store().ClaimJob("worker-1", now, kLease));
    ASSERT_TRUE(job.has_value());
    EXPECT_EQ(job->id, v.job_id);
    EXPECT_EQ(job->tenant, v.tenant);
    EXPECT_EQ(job->asset, v.asset);
    EXPECT_EQ(job->version, v.version);
    EXPECT_EQ(job->state, JobState::kRunning);
    EXPECT_EQ(job->attempts, 1);
    EXPECT_EQ(job->lease_owner, "worker-1");
    EXPECT_EQ(job->lease_expires_ms, now + kLease);
    MS_ASSERT_OK_AND_ASSIGN(const JobRecord stored, store().GetJob(v.tenant, v.job_id));
    EXPECT_EQ(stored.state, JobState::kRunning);
    EXPECT_EQ(stored.lease_owner, "worker-1");
  }
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> none, store().ClaimJob("worker-1", now, kLease));
  EXPECT_FALSE(none.has_value());
  EXPECT_CODE(store().ClaimJob("", now, kLease), StatusCode::kInvalidArgument);
  EXPECT_CODE(store().ClaimJob("w", now, 0), StatusCode::kInvalidArgument);
}

TEST_P(StoreSuite, ConcurrentClaimersNeverGetTheSameJob) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  std::set<std::string> created;
  for (int i = 0; i < 24; ++i) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v,
                            store().CreateVersion(MakeVersion("acme", "asset" + std::to_string(i % 5), src)));
    created.insert(v.job_id);
  }
  std::mutex mu;
  std::vector<std::string> claimed;
  std::vector<std::string> errors;
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      const std::string worker = "worker-" + std::to_string(t);
      for (size_t claims = 0;; ++claims) {
        if (claims > created.size()) {  // a job handed out twice, or never finished: stop
          std::lock_guard<std::mutex> lock(mu);
          errors.push_back(worker + " claimed more jobs than exist");
          return;
        }
        auto job = store().ClaimJob(worker, NowMs(), kLease);
        std::lock_guard<std::mutex> lock(mu);
        if (!job.ok()) {
          errors.push_back(job.status().ToString());
          return;
        }
        if (!job->has_value()) return;
        claimed.push_back(job->value().id);
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_TRUE(errors.empty()) << (errors.empty() ? std::string() : errors.front());
  EXPECT_EQ(claimed.size(), created.size());
  EXPECT_EQ(std::set<std::string>(claimed.begin(), claimed.end()), created);
}

TEST_P(StoreSuite, AnExpiredLeaseIsTakenOverAndTheFirstWorkerIsAborted) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
  const int64_t now = NowMs();
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> first, store().ClaimJob("w1", now, 100));
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->attempts, 1);
  // Still leased: nobody else gets it.
  EXPECT_FALSE(store().ClaimJob("w2", now + 50, 100).value().has_value());
  // The holder may renew while nobody took the job, even after it expired.
  MS_ASSERT_OK(store().RenewLease(v.job_id, "w1", now + 120, 100, 0.25, "importing"));
  EXPECT_FALSE(store().ClaimJob("w2", now + 150, 100).value().has_value());
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> second, store().ClaimJob("w2", now + 300, kLease));
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(second->id, v.job_id);
  EXPECT_EQ(second->attempts, 2);
  EXPECT_EQ(second->lease_owner, "w2");
  EXPECT_EQ(second->state, JobState::kRunning);
  EXPECT_EQ(second->lease_expires_ms, now + 300 + kLease);

  const auto expect_aborted = [&](const Status& status, const std::string& what) {
    EXPECT_EQ(status.code(), StatusCode::kAborted) << what << ": " << status.ToString();
    EXPECT_EQ(status.message(), "job " + v.job_id + ": the lease is held by another worker") << what;
  };
  expect_aborted(store().RenewLease(v.job_id, "w1", now + 310, 100, 0.5, "still here"), "renew");
  expect_aborted(store().CompleteJob(v.job_id, "w1", MakeSummary(art)), "complete");
  expect_aborted(store().FailJob(v.job_id, "w1", "gave up"), "fail");
  EXPECT_CODE(store().RenewLease(std::string(32, 'f'), "w1", now, 100, 0.5, ""), StatusCode::kNotFound);
  EXPECT_CODE(store().RenewLease(v.job_id, "w2", now, 100, 1.5, ""), StatusCode::kInvalidArgument);

  // The new holder's progress is recorded; the first worker's was not.
  MS_ASSERT_OK(store().RenewLease(v.job_id, "w2", now + 400, kLease, 0.5, "encoding"));
  MS_ASSERT_OK_AND_ASSIGN(const JobRecord job, store().GetJob("acme", v.job_id));
  EXPECT_EQ(job.progress, 0.5);
  EXPECT_EQ(job.message, "encoding");
  EXPECT_EQ(job.lease_owner, "w2");
  EXPECT_EQ(job.lease_expires_ms, now + 400 + kLease);
  EXPECT_EQ(job.attempts, 2);
  MS_ASSERT_OK(store().CompleteJob(v.job_id, "w2", MakeSummary(art)));
  EXPECT_EQ(store().GetVersion("acme", "chair", 1).value().state, VersionState::kReady);
  // Finished: neither worker can change it again, and it is never claimed again.
  // A finished job is ABORTED for its own worker too (a worker treats
  // ABORTED as a lost lease and stops), on every backend.
  const std::string over = "job " + v.job_id + ": already SUCCEEDED, the lease is over";
  for (const Status& late : {store().CompleteJob(v.job_id, "w2", MakeSummary(art)),
                             store().FailJob(v.job_id, "w2", "late"),
                             store().RenewLease(v.job_id, "w2", now + 500, kLease, 0.5, "late")}) {
    EXPECT_EQ(late.code(), StatusCode::kAborted) << late.ToString();
    EXPECT_EQ(late.message(), over);
  }
  expect_aborted(store().FailJob(v.job_id, "w1", "late"), "fail after completion");
  EXPECT_FALSE(store().ClaimJob("w3", now + 10 * kLease, kLease).value().has_value());
  EXPECT_EQ(store().GetVersion("acme", "chair", 1).value().state, VersionState::kReady);
}

TEST_P(StoreSuite, ReleaseAllLeasesReturnsRunningJobsToPending) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  std::vector<VersionRecord> v;
  for (int i = 0; i < 3; ++i) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord created, store().CreateVersion(MakeVersion("acme", "chair", src)));
    v.push_back(created);
  }
  const int64_t now = NowMs();
  EXPECT_EQ(store().ReleaseAllLeases().value(), 0);
  ASSERT_EQ(store().ClaimJob("w1", now, kLease).value()->id, v[0].job_id);
  ASSERT_EQ(store().ClaimJob("w1", now, kLease).value()->id, v[1].job_id);
  MS_ASSERT_OK(store().CompleteJob(v[1].job_id, "w1", MakeSummary(art)));
  EXPECT_EQ(store().ReleaseAllLeases().value(), 1);  // v[0]; v[1] is finished, v[2] pending

  MS_ASSERT_OK_AND_ASSIGN(const JobRecord released, store().GetJob("acme", v[0].job_id));
  EXPECT_EQ(released.state, JobState::kPending);
  EXPECT_EQ(released.lease_owner, "");
  EXPECT_EQ(released.attempts, 1);
  EXPECT_EQ(store().RenewLease(v[0].job_id, "w1", now, kLease, 0.5, "").code(), StatusCode::kAborted);
  EXPECT_EQ(store().GetJob("acme", v[1].job_id).value().state, JobState::kSucceeded);
  // Claimable again at once, oldest first, without waiting for the lease.
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> again, store().ClaimJob("w2", now, kLease));
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->id, v[0].job_id);
  EXPECT_EQ(again->attempts, 2);
  EXPECT_EQ(store().ClaimJob("w2", now, kLease).value()->id, v[2].job_id);
  EXPECT_FALSE(store().ClaimJob("w2", now, kLease).value().has_value());
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 2);
}

TEST_P(StoreSuite, CompleteJobMakesTheVersionReadyWithItsSummary) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "a progressive glb"));
  NewVersion nv = MakeVersion("acme", "chair", src);
  nv.labels = {{"k", "v"}};
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(nv));
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> job, store().ClaimJob("w", NowMs(), kLease));
  ASSERT_TRUE(job.has_value());
  // The artifact must be stored first.
  ArtifactSummary missing = MakeSummary(Sha("not stored"));
  EXPECT_CODE(store().CompleteJob(v.job_id, "w", missing), StatusCode::kFailedPrecondition);
  EXPECT_CODE(store().CompleteJob(v.job_id, "w", MakeSummary("nothex")), StatusCode::kInvalidArgument);
  EXPECT_EQ(store().GetVersion("acme", "chair", 1).value().state, VersionState::kProcessing);

  const ArtifactSummary summary = MakeSummary(art);
  MS_ASSERT_OK(store().CompleteJob(v.job_id, "w", summary));
  for (int pass = 0; pass < 2; ++pass) {
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord ready, store().GetVersion("acme", "chair", 1));
    EXPECT_EQ(ready.state, VersionState::kReady);
    ExpectSameSummary(ready.artifact, summary);
    EXPECT_EQ(ready.labels, nv.labels);
    EXPECT_EQ(ready.source.sha256, src);
    EXPECT_TRUE(ready.error.empty());
    MS_ASSERT_OK_AND_ASSIGN(const JobRecord done, store().GetJob("acme", v.job_id));
    EXPECT_EQ(done.state, JobState::kSucceeded);
    EXPECT_EQ(store().CountUnfinishedJobs().value(), 0);
    Reopen();
  }
}

TEST_P(StoreSuite, FailJobMarksTheVersionFailedWithTheMessage) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
  ASSERT_TRUE(store().ClaimJob("w", NowMs(), kLease).value().has_value());
  const std::string message = "accessors[3]: count 900 exceeds bufferView 2";
  MS_ASSERT_OK(store().FailJob(v.job_id, "w", message));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord failed, store().GetVersion("acme", "chair", 0));
  EXPECT_EQ(failed.state, VersionState::kFailed);
  EXPECT_EQ(failed.error, message);
  EXPECT_TRUE(failed.artifact.artifact_sha256.empty());
  MS_ASSERT_OK_AND_ASSIGN(const JobRecord job, store().GetJob("acme", v.job_id));
  EXPECT_EQ(job.state, JobState::kFailed);
  EXPECT_EQ(job.message, message);
  EXPECT_FALSE(store().ClaimJob("w2", NowMs() + 10 * kLease, kLease).value().has_value());
}

TEST_P(StoreSuite, CountUnfinishedJobsCountsPendingAndRunningOnes) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 0);
  for (int i = 0; i < 3; ++i) MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 3);
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> a, store().ClaimJob("w", NowMs(), kLease));
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 3);
  MS_ASSERT_OK(store().CompleteJob(a->id, "w", MakeSummary(art)));
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 2);
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> b, store().ClaimJob("w", NowMs(), kLease));
  MS_ASSERT_OK(store().FailJob(b->id, "w", "no"));
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 1);
  Reopen();
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 1);
}

// --- the artifact cache --------------------------------------------------------

TEST_P(StoreSuite, TheArtifactCacheKeepsTheFirstResultForAKey) {
  const std::string key = "sources=" + Sha("a") + ";options=" + Sha("{}") + ";encoder=meshstream-progressive/1";
  EXPECT_FALSE(store().FindArtifact(key).value().has_value());
  EXPECT_CODE(store().PutArtifact(key, MakeSummary(Sha("not stored"))), StatusCode::kFailedPrecondition);
  EXPECT_FALSE(store().FindArtifact(key).value().has_value());
  EXPECT_CODE(store().FindArtifact(""), StatusCode::kInvalidArgument);

  MS_ASSERT_OK_AND_ASSIGN(const std::string art1, PutBlob(store(), "first result"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art2, PutBlob(store(), "second result"));
  const ArtifactSummary first = MakeSummary(art1);
  ArtifactSummary second = MakeSummary(art2);
  second.vertices = 1;
  MS_ASSERT_OK(store().PutArtifact(key, first));
  MS_ASSERT_OK(store().PutArtifact(key, first));   // idempotent
  MS_ASSERT_OK(store().PutArtifact(key, second));  // keeps the existing row
  MS_ASSERT_OK(store().PutArtifact(key + "-other", second));
  for (int pass = 0; pass < 2; ++pass) {
    MS_ASSERT_OK_AND_ASSIGN(const std::optional<ArtifactSummary> found, store().FindArtifact(key));
    ASSERT_TRUE(found.has_value());
    ExpectSameSummary(*found, first);
    MS_ASSERT_OK_AND_ASSIGN(const std::optional<ArtifactSummary> other, store().FindArtifact(key + "-other"));
    ASSERT_TRUE(other.has_value());
    ExpectSameSummary(*other, second);
    Reopen();
  }
}

// --- uploads -------------------------------------------------------------------

TEST_P(StoreSuite, UploadsAppendOnlyAtTheirDurableSize) {
  EXPECT_CODE(store().UploadSize("acme", "up1"), StatusCode::kNotFound);
  const Status too_far = store().AppendUpload("acme", "up1", 5, Data("hello"), 5);
  EXPECT_EQ(too_far.code(), StatusCode::kFailedPrecondition) << too_far.ToString();
  EXPECT_CODE(store().UploadSize("acme", "up1"), StatusCode::kNotFound);

  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 0, Data("hello "), 6));
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 6u);
  const Status behind = store().AppendUpload("acme", "up1", 3, Data("xx"), 2);
  EXPECT_EQ(behind.code(), StatusCode::kFailedPrecondition) << behind.ToString();
  EXPECT_TRUE(Contains(behind.message(), "6")) << behind.message();
  EXPECT_TRUE(Contains(behind.message(), "3")) << behind.message();
  const Status ahead = store().AppendUpload("acme", "up1", 1234, Data("xx"), 2);
  EXPECT_EQ(ahead.code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(Contains(ahead.message(), "6") && Contains(ahead.message(), "1234")) << ahead.message();
  const Status restart = store().AppendUpload("acme", "up1", 0, Data("xx"), 2);
  EXPECT_EQ(restart.code(), StatusCode::kFailedPrecondition) << "0 creates only a new upload";
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 6u);

  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 6, Data("world"), 5));
  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 11, nullptr, 0));  // an empty append is fine
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 11u);
  Reopen();
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 11u);
  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 11, Data("!"), 1));
  MS_ASSERT_OK_AND_ASSIGN(const std::string digest, store().CommitUpload("acme", "up1", Sha("hello world!")));
  EXPECT_EQ(digest, Sha("hello world!"));
  EXPECT_EQ(store().GetBlob(digest, 100).value(), Bytes("hello world!"));
  EXPECT_CODE(store().UploadSize("acme", "up1"), StatusCode::kNotFound);
  EXPECT_CODE(store().CommitUpload("acme", "up1", ""), StatusCode::kNotFound);
  // The id is free again.
  MS_ASSERT_OK(store().AppendUpload("acme", "up1", 0, Data("again"), 5));
  EXPECT_EQ(store().UploadSize("acme", "up1").value(), 5u);
}

TEST_P(StoreSuite, CommittingAnUploadChecksItsDigest) {
  // Larger than any one buffer a backend might use, sent in uneven chunks.
  std::string big(3 * 1024 * 1024 + 17, '\0');
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 31 + i / 4093);
  size_t at = 0;
  for (const size_t chunk : {size_t{1}, size_t{65536}, size_t{1 << 20}, size_t{1 << 21}}) {
    const size_t n = std::min(chunk, big.size() - at);
    MS_ASSERT_OK(store().AppendUpload("acme", "big", at, Data(big) + at, n));
    at += n;
  }
  MS_ASSERT_OK(store().AppendUpload("acme", "big", at, Data(big) + at, big.size() - at));
  MS_ASSERT_OK_AND_ASSIGN(const std::string digest, store().CommitUpload("acme", "big", Sha(big)));
  EXPECT_EQ(digest, Sha(big));
  EXPECT_EQ(store().GetBlob(digest, big.size()).value(), Bytes(big));

  MS_ASSERT_OK(store().AppendUpload("acme", "liar", 0, Data("abc"), 3));
  auto mismatch = store().CommitUpload("acme", "liar", Sha("abd"));
  ASSERT_FALSE(mismatch.ok());
  EXPECT_EQ(mismatch.status().code(), StatusCode::kDataLoss);
  EXPECT_CODE(store().UploadSize("acme", "liar"), StatusCode::kNotFound);  // discarded
  EXPECT_FALSE(store().HasBlob(Sha("abc")).value());
  EXPECT_FALSE(store().HasBlob(Sha("abd")).value());

  MS_ASSERT_OK(store().AppendUpload("acme", "unchecked", 0, nullptr, 0));
  EXPECT_EQ(store().UploadSize("acme", "unchecked").value(), 0u);
  EXPECT_EQ(store().CommitUpload("acme", "unchecked", "").value(), Sha(""));
  MS_ASSERT_OK(store().AppendUpload("acme", "badly", 0, Data("x"), 1));
  EXPECT_CODE(store().CommitUpload("acme", "badly", "XYZ"), StatusCode::kInvalidArgument);
  EXPECT_EQ(store().UploadSize("acme", "badly").value(), 1u);  // a bad argument discards nothing

  MS_ASSERT_OK(store().DiscardUpload("acme", "badly"));
  EXPECT_CODE(store().UploadSize("acme", "badly"), StatusCode::kNotFound);
  EXPECT_CODE(store().DiscardUpload("acme", "badly"), StatusCode::kNotFound);
}

TEST_P(StoreSuite, IdleUploadsExpire) {
  MS_ASSERT_OK(store().AppendUpload("acme", "a", 0, Data("aaa"), 3));
  MS_ASSERT_OK(store().AppendUpload("globex", "b", 0, Data("bb"), 2));
  EXPECT_EQ(store().ExpireUploads(3600 * 1000).value(), 0u);
  EXPECT_EQ(store().UploadSize("acme", "a").value(), 3u);
  EXPECT_EQ(store().UploadSize("globex", "b").value(), 2u);
  EXPECT_CODE(store().ExpireUploads(-1), StatusCode::kInvalidArgument);
  EXPECT_EQ(store().ExpireUploads(0).value(), 2u);
  EXPECT_CODE(store().UploadSize("acme", "a"), StatusCode::kNotFound);
  EXPECT_CODE(store().UploadSize("globex", "b"), StatusCode::kNotFound);
  EXPECT_EQ(store().ExpireUploads(0).value(), 0u);
  MS_ASSERT_OK(store().AppendUpload("acme", "a", 0, Data("new"), 3));  // starts over
  EXPECT_EQ(store().UploadSize("acme", "a").value(), 3u);
}

// --- tokens --------------------------------------------------------------------

TEST_P(StoreSuite, TokensAreFoundByTheirHashUntilRevoked) {
  const std::string hash_a = Sha("secret token a"), hash_b = Sha("secret token b");
  EXPECT_CODE(store().FindToken(hash_a), StatusCode::kNotFound);
  EXPECT_TRUE(store().ListTokens().value().empty());
  MS_ASSERT_OK_AND_ASSIGN(const TokenRecord a, store().CreateToken("acme", false, hash_a));
  MS_ASSERT_OK_AND_ASSIGN(const TokenRecord b, store().CreateToken("acme", true, hash_b));
  EXPECT_EQ(a.id.size(), 16u);
  EXPECT_EQ(a.id.find_first_not_of("0123456789abcdef"), std::string::npos) << a.id;
  EXPECT_NE(a.id, b.id);
  EXPECT_EQ(a.tenant, "acme");
  EXPECT_FALSE(a.read_only);
  EXPECT_TRUE(b.read_only);
  EXPECT_FALSE(a.revoked);
  EXPECT_GT(a.created_ms, 0);
  EXPECT_CODE(store().CreateToken("globex", false, hash_a), StatusCode::kAlreadyExists);

  MS_ASSERT_OK_AND_ASSIGN(const TokenRecord found, store().FindToken(hash_a));
  EXPECT_EQ(found.id, a.id);
  EXPECT_EQ(found.tenant, "acme");
  EXPECT_FALSE(found.read_only);
  EXPECT_EQ(found.created_ms, a.created_ms);
  EXPECT_TRUE(store().FindToken(hash_b).value().read_only);

  MS_ASSERT_OK(store().RevokeToken(a.id));
  EXPECT_CODE(store().FindToken(hash_a), StatusCode::kNotFound);
  MS_EXPECT_OK(store().FindToken(hash_b));
  MS_ASSERT_OK(store().RevokeToken(a.id));  // twice is fine
  EXPECT_CODE(store().RevokeToken("0123456789abcdef"), StatusCode::kNotFound);

  Reopen();
  EXPECT_CODE(store().FindToken(hash_a), StatusCode::kNotFound);
  EXPECT_EQ(store().FindToken(hash_b).value().id, b.id);
  MS_ASSERT_OK_AND_ASSIGN(const std::vector<TokenRecord> tokens, store().ListTokens());
  ASSERT_EQ(tokens.size(), 2u);
  std::map<std::string, TokenRecord> by_id;
  for (const TokenRecord& t : tokens) by_id[t.id] = t;
  ASSERT_EQ(by_id.count(a.id), 1u);
  ASSERT_EQ(by_id.count(b.id), 1u);
  EXPECT_TRUE(by_id[a.id].revoked);
  EXPECT_FALSE(by_id[b.id].revoked);
  EXPECT_TRUE(by_id[b.id].read_only);
  EXPECT_EQ(by_id[b.id].tenant, "acme");
}

// --- orphan blobs --------------------------------------------------------------

TEST_P(StoreSuite, RemoveOrphanBlobsRemovesOnlyOldBlobsNoRowNames) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string res, PutBlob(store(), "resource"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact of a version"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string cached, PutBlob(store(), "artifact in the cache only"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string failed_src, PutBlob(store(), "source of a failed version"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string pending_src, PutBlob(store(), "source of a pending version"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string orphan, PutBlob(store(), "nobody names me"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string orphan2, PutBlob(store(), "nor me"));

  NewVersion nv = MakeVersion("acme", "chair", src);
  nv.resources = {SourceFile{"a.bin", res, 8}};
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord ready, store().CreateVersion(nv));
  FinishVersion(store(), ready, true, art);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord failed, store().CreateVersion(MakeVersion("acme", "lamp", failed_src)));
  FinishVersion(store(), failed, false, art);
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("globex", "x", pending_src)));
  MS_ASSERT_OK(store().PutArtifact("key", MakeSummary(cached)));
  MS_ASSERT_OK(store().AppendUpload("acme", "up", 0, Data("upload bytes"), 12));

  EXPECT_CODE(store().RemoveOrphanBlobs(-1), StatusCode::kInvalidArgument);
  EXPECT_EQ(store().RemoveOrphanBlobs(3600 * 1000).value(), 0u) << "the orphans are too young";
  EXPECT_TRUE(store().HasBlob(orphan).value());
  EXPECT_EQ(store().RemoveOrphanBlobs(0).value(), 2u);
  EXPECT_FALSE(store().HasBlob(orphan).value());
  EXPECT_FALSE(store().HasBlob(orphan2).value());
  for (const std::string& kept : {src, res, art, cached, failed_src, pending_src}) {
    EXPECT_TRUE(store().HasBlob(kept).value()) << kept;
    MS_EXPECT_OK(store().GetBlob(kept, 1 << 20));
  }
  EXPECT_EQ(store().UploadSize("acme", "up").value(), 12u);  // uploads are not blobs
  EXPECT_EQ(store().RemoveOrphanBlobs(0).value(), 0u);
  Reopen();
  EXPECT_EQ(store().RemoveOrphanBlobs(0).value(), 0u);
  EXPECT_TRUE(store().HasBlob(src).value());
}

// --- one contract: the refusals both backends decide alike ---------------------

TEST_P(StoreSuite, AFailedJobIsAbortedForItsWorkerAsASucceededOneIs) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
  ASSERT_TRUE(store().ClaimJob("w", NowMs(), kLease).value().has_value());
  MS_ASSERT_OK(store().FailJob(v.job_id, "w", "broken"));
  const std::string over = "job " + v.job_id + ": already FAILED, the lease is over";
  for (const Status& late : {store().CompleteJob(v.job_id, "w", MakeSummary(art)), store().FailJob(v.job_id, "w", "x"),
                             store().RenewLease(v.job_id, "w", NowMs(), kLease, 0.5, "")}) {
    EXPECT_EQ(late.code(), StatusCode::kAborted) << late.ToString();
    EXPECT_EQ(late.message(), over);
  }
  const std::string unknown(32, 'e');
  for (const Status& missing : {store().CompleteJob(unknown, "w", MakeSummary(art)), store().FailJob(unknown, "w", "x"),
                                store().RenewLease(unknown, "w", NowMs(), kLease, 0.5, "")}) {
    EXPECT_EQ(missing.code(), StatusCode::kNotFound) << missing.ToString();
    EXPECT_EQ(missing.message(), "job " + unknown + " does not exist");
  }
  EXPECT_EQ(store().GetVersion("acme", "chair", 1).value().state, VersionState::kFailed);
}

TEST_P(StoreSuite, AVersionNoLongerProcessingIsFailedPreconditionAndNothingChanges) {
  ASSERT_TRUE(backend_.set_version_state) << "the backend has no hook to change a row";
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  for (const bool complete : {true, false}) {
    SCOPED_TRACE(complete ? "CompleteJob" : "FailJob");
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
    ASSERT_EQ(store().ClaimJob("w", NowMs(), kLease).value()->id, v.job_id);
    // Someone marks the version READY behind the store's back.
    MS_ASSERT_OK(backend_.set_version_state("acme", "chair", v.version, static_cast<int64_t>(VersionState::kReady)));
    const Status s = complete ? store().CompleteJob(v.job_id, "w", MakeSummary(art))
                              : store().FailJob(v.job_id, "w", "broken");
    EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition) << s.ToString();
    EXPECT_EQ(s.message(), "job " + v.job_id + ": its version is not PROCESSING any more");
    // The job's change was rolled back with the version's.
    MS_ASSERT_OK_AND_ASSIGN(const JobRecord job, store().GetJob("acme", v.job_id));
    EXPECT_EQ(job.state, JobState::kRunning);
    EXPECT_EQ(job.lease_owner, "w");
    MS_ASSERT_OK_AND_ASSIGN(const VersionRecord after, store().GetVersion("acme", "chair", v.version));
    EXPECT_EQ(after.state, VersionState::kReady);
    EXPECT_TRUE(after.error.empty());
    EXPECT_TRUE(after.artifact.artifact_sha256.empty());
  }
}

TEST_P(StoreSuite, AStoredStateThatIsNoKnownValueIsDataLoss) {
  ASSERT_TRUE(backend_.set_version_state && backend_.set_job_state) << "the backend has no hook to change a row";
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
  MS_ASSERT_OK(backend_.set_version_state("acme", "chair", 1, 7));
  MS_ASSERT_OK(backend_.set_job_state(v.job_id, 0));
  ExpectStatus(store().GetVersion("acme", "chair", 1), StatusCode::kDataLoss, "versions row has the unknown state 7");
  ExpectStatus(store().GetVersion("acme", "chair", 0), StatusCode::kDataLoss, "versions row has the unknown state 7");
  ExpectStatus(store().ListVersions("acme", "chair", 0, ""), StatusCode::kDataLoss,
               "versions row has the unknown state 7");
  ExpectStatus(store().GetJob("acme", v.job_id), StatusCode::kDataLoss, "jobs row has the unknown state 0");
  MS_ASSERT_OK(backend_.set_job_state(v.job_id, static_cast<int64_t>(JobState::kRunning)));
  MS_ASSERT_OK(backend_.set_job_state(v.job_id, -3));
  ExpectStatus(store().RenewLease(v.job_id, "w", NowMs(), kLease, 0.5, ""), StatusCode::kDataLoss,
               "jobs row has the unknown state -3");
}

TEST_P(StoreSuite, NulBytesAndBadUtf8AreInvalidArgumentNamingTheField) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  const std::string nul("cut\0here", 8), bad_utf8 = "\xC3\x28", overlong = "\xC0\xAF", surrogate = "\xED\xA0\x80";
  for (const std::string& text : {nul, bad_utf8, overlong, surrogate}) {
    const std::string why = text == nul ? "contains a NUL byte" : "is not valid UTF-8";
    NewVersion v = MakeVersion("acme", "chair", src);
    v.comment = text;
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "comment: " + why);
    v = MakeVersion("acme", "chair", src);
    v.source.name = "a" + text + ".glb";
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "source.name: " + why);
    v = MakeVersion("acme", "chair", src);
    v.resources = {SourceFile{"ok.bin", src, 6}, SourceFile{text, src, 6}};
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "resources[1].name: " + why);
    v = MakeVersion("acme", "chair", src);
    v.options_json = text;
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "options_json: " + why);
    v = MakeVersion("acme", "chair", src);
    v.labels = {{"k", text}};
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "labels[k]: " + why);
    v = MakeVersion("acme", "chair", src);
    v.labels = {{text, "v"}};
    ExpectStatus(store().CreateVersion(v), StatusCode::kInvalidArgument, "labels: a key: " + why);
    ExpectStatus(store().ClaimJob("w" + text, NowMs(), kLease), StatusCode::kInvalidArgument, "worker: " + why);
    ExpectStatus(store().FindArtifact("key" + text), StatusCode::kInvalidArgument, "cache_key: " + why);
    ExpectStatus(store().FindToken(text), StatusCode::kInvalidArgument, "token_hash: " + why);
    ExpectStatus(store().CreateToken("acme", false, text), StatusCode::kInvalidArgument, "token_hash: " + why);
    ArtifactSummary summary = MakeSummary(art);
    summary.encoder = text;
    ExpectStatus(store().PutArtifact("key", summary), StatusCode::kInvalidArgument, "summary.encoder: " + why);
  }
  NewVersion empty_name = MakeVersion("acme", "chair", src);
  empty_name.source.name = "";
  ExpectStatus(store().CreateVersion(empty_name), StatusCode::kInvalidArgument, "source.name: must not be empty");
  NewVersion empty_key = MakeVersion("acme", "chair", src);
  empty_key.labels = {{"", "v"}};
  ExpectStatus(store().CreateVersion(empty_key), StatusCode::kInvalidArgument, "labels: a key must not be empty");
  // Nothing was stored by any of them.
  EXPECT_TRUE(store().ListAssets("acme", 0, "").value().items.empty());
  EXPECT_FALSE(store().FindArtifact("key").value().has_value());
  EXPECT_TRUE(store().ListTokens().value().empty());

  // Text of a running job: the message of a renewal or a failure.
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, store().CreateVersion(MakeVersion("acme", "chair", src)));
  ASSERT_TRUE(store().ClaimJob("w", NowMs(), kLease).value().has_value());
  ExpectStatus(store().RenewLease(v.job_id, "w", NowMs(), kLease, 0.5, nul), StatusCode::kInvalidArgument,
               "message: contains a NUL byte");
  ExpectStatus(store().FailJob(v.job_id, "w", bad_utf8), StatusCode::kInvalidArgument, "message: is not valid UTF-8");
  EXPECT_EQ(store().GetJob("acme", v.job_id).value().state, JobState::kRunning);
  // Valid UTF-8 of every length, quotes and SQL are stored as they are.
  NewVersion quoted = MakeVersion("acme", "quoted", src);
  quoted.comment = "it's \"fine\"; DROP TABLE versions; -- \xC3\xBC \xE2\x82\xAC \xF0\x9F\x98\x80";
  quoted.labels = {{"o'k", "v\"1"}, {"\xE2\x82\xAC", ""}};
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord stored, store().CreateVersion(quoted));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord back, store().GetVersion("acme", "quoted", stored.version));
  EXPECT_EQ(back.comment, quoted.comment);
  EXPECT_EQ(back.labels, quoted.labels);
}

TEST_P(StoreSuite, LimitsAreInvalidArgumentNamingTheField) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  const uint64_t too_big = uint64_t{1} << 63;
  // Names: 128 characters at most, no "." or "..".
  MS_EXPECT_OK(store().CreateVersion(MakeVersion("acme", std::string(128, 'n'), src)));
  ExpectStatus(store().CreateVersion(MakeVersion("acme", std::string(129, 'n'), src)), StatusCode::kInvalidArgument,
               "asset: 129 characters, at most 128");
  ExpectStatus(store().GetVersion("..", "chair", 0), StatusCode::kInvalidArgument, "tenant: '..' is not a name");
  ExpectStatus(store().UploadSize("acme", "."), StatusCode::kInvalidArgument, "upload_id: '.' is not a name");
  ExpectStatus(store().RevokeToken("not a token id"), StatusCode::kInvalidArgument,
               "id: only letters, digits, '.', '_' and '-' are allowed");
  // Keys: 1024 bytes at most.
  MS_EXPECT_OK(store().FindArtifact(std::string(1024, 'k')));
  ExpectStatus(store().FindArtifact(std::string(1025, 'k')), StatusCode::kInvalidArgument,
               "cache_key: 1025 bytes, at most 1024");
  ExpectStatus(store().ClaimJob(std::string(1025, 'w'), NowMs(), kLease), StatusCode::kInvalidArgument,
               "worker: 1025 bytes, at most 1024");
  // Sizes the database keeps as signed 64-bit integers.
  NewVersion huge = MakeVersion("acme", "chair", src);
  huge.source.size = too_big;
  ExpectStatus(store().CreateVersion(huge), StatusCode::kInvalidArgument,
               "source.size: 9223372036854775808 does not fit a 64-bit signed integer");
  huge = MakeVersion("acme", "chair", src);
  huge.resources = {SourceFile{"a.bin", src, too_big}};
  ExpectStatus(store().CreateVersion(huge), StatusCode::kInvalidArgument,
               "resources[0].size: 9223372036854775808 does not fit a 64-bit signed integer");
  ArtifactSummary summary = MakeSummary(art);
  summary.unreliable_bytes = too_big;
  ExpectStatus(store().PutArtifact("key", summary), StatusCode::kInvalidArgument,
               "summary.unreliable_bytes: 9223372036854775808 does not fit a 64-bit signed integer");
  summary = MakeSummary(art);
  summary.faces = -1;
  ExpectStatus(store().PutArtifact("key", summary), StatusCode::kInvalidArgument, "summary.faces: -1 is negative");
  ExpectStatus(store().PutArtifact("key", MakeSummary("ABC")), StatusCode::kInvalidArgument,
               "summary.artifact_sha256: not a SHA-256 (64 lower-case hex digits)");
  // Uploads: an offset plus size beyond int64, null bytes with a size.
  ExpectStatus(store().AppendUpload("acme", "up", too_big, Data("x"), 1), StatusCode::kInvalidArgument,
               "offset: 9223372036854775808 does not fit a 64-bit signed integer");
  ExpectStatus(store().AppendUpload("acme", "up", too_big - 1, Data("xy"), 2), StatusCode::kInvalidArgument,
               "offset: offset plus size overflows a 64-bit signed integer");
  ExpectStatus(store().AppendUpload("acme", "up", 0, nullptr, 3), StatusCode::kInvalidArgument,
               "data: null with 3 bytes");
  EXPECT_CODE(store().UploadSize("acme", "up"), StatusCode::kNotFound);
  // Leases: a clock and a length that add up, a progress within 0..1.
  const int64_t now = NowMs();
  ExpectStatus(store().ClaimJob("w", -1, kLease), StatusCode::kInvalidArgument, "now_ms: -1 is negative");
  ExpectStatus(store().ClaimJob("w", now, 0), StatusCode::kInvalidArgument, "lease_ms: 0 is not positive");
  ExpectStatus(store().ClaimJob("w", INT64_MAX - 5, 10), StatusCode::kInvalidArgument,
               "lease_ms: now_ms + lease_ms overflows");
  ExpectStatus(store().RenewLease("job", "w", now, kLease, std::nan(""), ""), StatusCode::kInvalidArgument,
               "progress: must be between 0 and 1");
  ExpectStatus(store().RenewLease("job", "w", now, kLease, -0.1, ""), StatusCode::kInvalidArgument,
               "progress: must be between 0 and 1");
  ExpectStatus(store().RemoveOrphanBlobs(-1), StatusCode::kInvalidArgument, "min_age_ms: -1 is negative");
  ExpectStatus(store().ExpireUploads(-2), StatusCode::kInvalidArgument, "max_idle_ms: -2 is negative");
  ExpectStatus(store().GetVersion("acme", "chair", -1), StatusCode::kInvalidArgument, "version: -1 is negative");
  // Digests: 64 lower-case hex digits, named by their field.
  ExpectStatus(store().GetBlob(std::string(64, 'A'), 1), StatusCode::kInvalidArgument,
               "sha256: not a SHA-256 (64 lower-case hex digits)");
  ExpectStatus(store().CommitUpload("acme", "up", "xyz"), StatusCode::kInvalidArgument,
               "expected_sha256: not a SHA-256 (64 lower-case hex digits)");
  NewVersion bad_digest = MakeVersion("acme", "chair", "'; DROP TABLE blobs; --");
  ExpectStatus(store().CreateVersion(bad_digest), StatusCode::kInvalidArgument,
               "source.sha256: not a SHA-256 (64 lower-case hex digits)");
  MS_ASSERT_OK_AND_ASSIGN(std::unique_ptr<BlobSink> sink, store().NewBlob());
  ExpectStatus(sink->Append(nullptr, 1), StatusCode::kInvalidArgument, "data: null with 1 bytes");
  MS_ASSERT_OK(sink->Append(Data("abc"), 3));
  ExpectStatus(sink->Commit("nothex"), StatusCode::kInvalidArgument,
               "expected_sha256: not a SHA-256 (64 lower-case hex digits)");
}

TEST_P(StoreSuite, WhatABackendRefusesIsWordedOnce) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  const std::string missing = Sha("never stored");
  ExpectStatus(store().GetVersion("acme", "chair", 0), StatusCode::kNotFound, "asset chair does not exist");
  ExpectStatus(store().ListVersions("acme", "chair", 0, ""), StatusCode::kNotFound, "asset chair does not exist");
  ExpectStatus(store().GetLatestReadyVersion("acme", "chair"), StatusCode::kNotFound,
               "asset chair does not exist");
  MS_ASSERT_OK(store().CreateVersion(MakeVersion("acme", "chair", src)));
  ExpectStatus(store().GetVersion("acme", "chair", 5), StatusCode::kNotFound, "asset chair has no version 5");
  ExpectStatus(store().GetLatestReadyVersion("acme", "chair"), StatusCode::kNotFound,
               "asset chair has no READY version");
  ExpectStatus(store().GetJob("acme", "nojob"), StatusCode::kNotFound, "job nojob does not exist");
  ExpectStatus(store().UploadSize("acme", "up"), StatusCode::kNotFound, "upload up does not exist");
  ExpectStatus(store().DiscardUpload("acme", "up"), StatusCode::kNotFound, "upload up does not exist");
  ExpectStatus(store().CommitUpload("acme", "up", ""), StatusCode::kNotFound, "upload up does not exist");
  ExpectStatus(store().GetBlob(missing, 10), StatusCode::kNotFound, "blob " + missing + " does not exist");
  ExpectStatus(store().GetBlob(src, 2), StatusCode::kResourceExhausted,
               "blob " + src + " has 6 bytes, more than 2");
  ExpectStatus(store().RevokeToken("0123456789abcdef"), StatusCode::kNotFound, "token 0123456789abcdef does not exist");
  ExpectStatus(store().FindToken(Sha("t")), StatusCode::kNotFound, "no live token has this hash");
  MS_ASSERT_OK(store().CreateToken("acme", false, Sha("t")));
  ExpectStatus(store().CreateToken("acme", false, Sha("t")), StatusCode::kAlreadyExists,
               "token_hash: a token with this hash exists");
  ExpectStatus(store().CreateVersion(MakeVersion("acme", "chair", missing)), StatusCode::kFailedPrecondition,
               "source.sha256: blob " + missing + " does not exist (store the bytes first)");
  ExpectStatus(store().PutArtifact("key", MakeSummary(missing)), StatusCode::kFailedPrecondition,
               "summary.artifact_sha256: blob " + missing + " does not exist (store the bytes first)");
  MS_ASSERT_OK(store().AppendUpload("acme", "up", 0, Data("abc"), 3));
  ExpectStatus(store().AppendUpload("acme", "up", 1, Data("x"), 1), StatusCode::kFailedPrecondition,
               "upload up has 3 durable bytes; an append must start there, not at offset 1");
  ExpectStatus(store().AppendUpload("acme", "fresh", 4, Data("x"), 1), StatusCode::kFailedPrecondition,
               "upload fresh has 0 durable bytes; an append must start there, not at offset 4");
  ExpectStatus(store().CommitUpload("acme", "up", Sha("abd")), StatusCode::kDataLoss,
               "upload up: the bytes have SHA-256 " + Sha("abc") + ", not the " + Sha("abd") +
                   " announced; nothing stored; the upload is discarded");
  MS_ASSERT_OK_AND_ASSIGN(std::unique_ptr<BlobSink> sink, store().NewBlob());
  MS_ASSERT_OK(sink->Append(Data("abc"), 3));
  ExpectStatus(sink->Commit(Sha("abd")), StatusCode::kDataLoss,
               "the bytes have SHA-256 " + Sha("abc") + ", not the " + Sha("abd") + " announced; nothing stored");
  const std::string bad_token = EncodePageToken(kVersionsPageKind, "3");
  ExpectStatus(store().ListAssets("acme", 1, bad_token), StatusCode::kInvalidArgument,
               "page_token: not a token this server issued");
  ExpectStatus(store().ListVersions("acme", "chair", 1, "!"), StatusCode::kInvalidArgument,
               "page_token: not a token this server issued");
  ExpectStatus(store().ListAssets("acme", -1, ""), StatusCode::kInvalidArgument, "page_size: must not be negative");
}

// --- restarts ------------------------------------------------------------------

TEST_P(StoreSuite, EverythingSurvivesAReopen) {
  MS_ASSERT_OK_AND_ASSIGN(const std::string src, PutBlob(store(), "source"));
  MS_ASSERT_OK_AND_ASSIGN(const std::string art, PutBlob(store(), "artifact"));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v1, store().CreateVersion(MakeVersion("acme", "chair", src)));
  FinishVersion(store(), v1, true, art);
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v2, store().CreateVersion(MakeVersion("acme", "chair", src)));
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v3, store().CreateVersion(MakeVersion("acme", "chair", src)));
  const int64_t now = NowMs();
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> running, store().ClaimJob("w", now, kLease));
  ASSERT_TRUE(running.has_value());
  EXPECT_EQ(running->id, v2.job_id);
  MS_ASSERT_OK(store().RenewLease(v2.job_id, "w", now, kLease, 0.75, "levels"));
  MS_ASSERT_OK(store().PutArtifact("key", MakeSummary(art)));
  MS_ASSERT_OK_AND_ASSIGN(const TokenRecord token, store().CreateToken("acme", true, Sha("tok")));
  MS_ASSERT_OK(store().AppendUpload("acme", "up", 0, Data("partial"), 7));

  Reopen();
  EXPECT_EQ(store().backend().empty(), false);
  EXPECT_EQ(store().GetBlob(src, 100).value(), Bytes("source"));
  EXPECT_EQ(store().GetVersion("acme", "chair", 0).value().version, 3);
  EXPECT_EQ(store().GetLatestReadyVersion("acme", "chair").value().version, 1);
  ExpectSameSummary(store().GetVersion("acme", "chair", 1).value().artifact, MakeSummary(art));
  MS_ASSERT_OK_AND_ASSIGN(const JobRecord job, store().GetJob("acme", v2.job_id));
  EXPECT_EQ(job.state, JobState::kRunning);
  EXPECT_EQ(job.lease_owner, "w");
  EXPECT_EQ(job.progress, 0.75);
  EXPECT_EQ(job.message, "levels");
  EXPECT_EQ(store().CountUnfinishedJobs().value(), 2);
  // The live lease is kept: the next claim is v3's pending job, then nothing.
  MS_ASSERT_OK_AND_ASSIGN(const std::optional<JobRecord> next, store().ClaimJob("w2", now + 1, kLease));
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->id, v3.job_id);
  EXPECT_FALSE(store().ClaimJob("w2", now + 1, kLease).value().has_value());
  // The worker that held the lease before the restart still holds it.
  MS_ASSERT_OK(store().CompleteJob(v2.job_id, "w", MakeSummary(art)));
  EXPECT_TRUE(store().FindArtifact("key").value().has_value());
  EXPECT_EQ(store().FindToken(Sha("tok")).value().id, token.id);
  EXPECT_EQ(store().UploadSize("acme", "up").value(), 7u);
  EXPECT_EQ(store().ListAssets("acme", 0, "").value().items.size(), 1u);
}

}  // namespace
}  // namespace meshstream
