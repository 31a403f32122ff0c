// Ingest over the store's one contract (docs/design/store.md, "One contract, two
// backends"): IngestUpload on a real embedded store, through a decorator
// that watches what ingest hands the store. Every byte of an upload reaches
// the store's sink or resumable upload once and is hashed there only: ingest
// passes on the announced digest (never one of its own) and names the
// digest the store computed. Names, digests and text are refused by the
// store's checks, with the store's messages.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "services/ingest/ingest_upload.h"
#include "services/store/blob_store.h"
#include "services/store/sqlite_store.h"
#include "testing/test_util.h"
#include "tests/services/store_suite.h"

namespace meshstream {
namespace {

const uint8_t* Data(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }
std::string Sha(const std::string& s) { return Sha256Hex(Data(s), s.size()); }
std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// A real store behind a decorator that records what reaches it.
class WatchedStore final : public Store {
 public:
  explicit WatchedStore(std::unique_ptr<Store> inner) : inner_(std::move(inner)) {}
  std::string backend() const override { return inner_->backend(); }

  std::atomic<uint64_t> sink_bytes{0};    // bytes appended to blob sinks
  std::atomic<uint64_t> upload_bytes{0};  // bytes appended to resumable uploads
  std::vector<std::string> commits;       // the expected digest of every sink Commit and CommitUpload

 private:
  class Sink final : public BlobSink {
   public:
    Sink(WatchedStore* store, std::unique_ptr<BlobSink> inner) : store_(store), inner_(std::move(inner)) {}
    uint64_t size() const override { return inner_->size(); }

   private:
    Status DoAppend(const uint8_t* data, size_t size) override {
      store_->sink_bytes += size;
      return inner_->Append(data, size);
    }
    StatusOr<std::string> DoCommit(const std::string& expected) override {
      store_->commits.push_back(expected);
      return inner_->Commit(expected);
    }
    WatchedStore* store_;
    std::unique_ptr<BlobSink> inner_;
  };

  StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() override {
    MS_ASSIGN_OR_RETURN(std::unique_ptr<BlobSink> sink, inner_->NewBlob());
    return std::unique_ptr<BlobSink>(new Sink(this, std::move(sink)));
  }
  StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& d, uint64_t max) override {
    return inner_->GetBlob(d, max);
  }
  StatusOr<bool> DoHasBlob(const std::string& d) override { return inner_->HasBlob(d); }
  StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t age) override { return inner_->RemoveOrphanBlobs(age); }
  StatusOr<uint64_t> DoUploadSize(const std::string& t, const std::string& u) override {
    return inner_->UploadSize(t, u);
  }
  Status DoAppendUpload(const std::string& t, const std::string& u, uint64_t offset, const uint8_t* data,
                        size_t size) override {
    upload_bytes += size;
    return inner_->AppendUpload(t, u, offset, data, size);
  }
  StatusOr<std::string> DoCommitUpload(const std::string& t, const std::string& u, const std::string& e) override {
    commits.push_back(e);
    return inner_->CommitUpload(t, u, e);
  }
  Status DoDiscardUpload(const std::string& t, const std::string& u) override { return inner_->DiscardUpload(t, u); }
  StatusOr<uint64_t> DoExpireUploads(int64_t idle) override { return inner_->ExpireUploads(idle); }
  StatusOr<VersionRecord> DoCreateVersion(const NewVersion& v) override { return inner_->CreateVersion(v); }
  StatusOr<VersionRecord> DoGetVersion(const std::string& t, const std::string& a, int64_t v) override {
    return inner_->GetVersion(t, a, v);
  }
  StatusOr<VersionRecord> DoGetLatestReadyVersion(const std::string& t, const std::string& a) override {
    return inner_->GetLatestReadyVersion(t, a);
  }
  StatusOr<PageRows<AssetRecord>> DoListAssets(const std::string&, const std::string&, int64_t) override {
    return Unsupported("not used by ingest");
  }
  StatusOr<PageRows<VersionRecord>> DoListVersions(const std::string&, const std::string&, int64_t,
                                                   int64_t) override {
    return Unsupported("not used by ingest");
  }
  StatusOr<JobRecord> DoGetJob(const std::string& t, const std::string& j) override { return inner_->GetJob(t, j); }
  StatusOr<std::optional<JobRecord>> DoClaimJob(const std::string&, int64_t, int64_t) override {
    return Unsupported("not used by ingest");
  }
  Status DoRenewLease(const std::string&, const std::string&, int64_t, int64_t, double, const std::string&) override {
    return Unsupported("not used by ingest");
  }
  Status DoCompleteJob(const std::string&, const std::string&, const ArtifactSummary&) override {
    return Unsupported("not used by ingest");
  }
  Status DoFailJob(const std::string&, const std::string&, const std::string&) override {
    return Unsupported("not used by ingest");
  }
  StatusOr<int64_t> DoReleaseAllLeases() override { return Unsupported("not used by ingest"); }
  StatusOr<int64_t> DoCountUnfinishedJobs() override { return inner_->CountUnfinishedJobs(); }
  StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string&) override {
    return Unsupported("not used by ingest");
  }
  Status DoPutArtifact(const std::string&, const ArtifactSummary&) override { return Unsupported("not used by ingest"); }
  StatusOr<TokenRecord> DoCreateToken(const std::string&, bool, const std::string&) override {
    return Unsupported("not used by ingest");
  }
  StatusOr<TokenRecord> DoFindToken(const std::string&) override { return Unsupported("not used by ingest"); }
  StatusOr<std::vector<TokenRecord>> DoListTokens() override { return Unsupported("not used by ingest"); }
  Status DoRevokeToken(const std::string&) override { return Unsupported("not used by ingest"); }

  std::unique_ptr<Store> inner_;
};

class StoreIngest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto inner = SqliteStore::Open(dir_.path() + "/store");
    ASSERT_TRUE(inner.ok()) << inner.status().ToString();
    store_ = std::make_unique<WatchedStore>(std::move(inner).value());
  }

  IngestMeta Meta(const std::string& bytes, const std::string& sha256 = "") {
    IngestMeta meta;
    meta.asset = "chair";
    meta.filename = "chair.glb";
    meta.size = bytes.size();
    meta.sha256 = sha256;
    return meta;
  }

  // Begin, the bytes in chunks of `chunk`, Finish.
  StatusOr<VersionRecord> Ingest(const IngestMeta& meta, const std::string& bytes, size_t chunk = 7) {
    IngestUpload upload(store_.get(), Principal{"acme", false}, IngestLimits{});
    MS_RETURN_IF_ERROR(upload.Begin(meta));
    for (size_t at = meta.write_offset; at < bytes.size(); at += chunk) {
      MS_RETURN_IF_ERROR(upload.Chunk(Data(bytes) + at, std::min(chunk, bytes.size() - at)));
    }
    return upload.Finish();
  }

  test_util::TempDir dir_;
  std::unique_ptr<WatchedStore> store_;
};

TEST_F(StoreIngest, EveryByteReachesTheStoreOnceAndTheVersionNamesTheStoresDigest) {
  const std::string bytes(1000, 'm');
  // No digest announced: ingest asks the sink for none and names what the sink computed.
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, Ingest(Meta(bytes), bytes));
  EXPECT_EQ(store_->sink_bytes.load(), bytes.size());
  ASSERT_EQ(store_->commits.size(), 1u);
  EXPECT_EQ(store_->commits[0], "") << "ingest computed a digest of its own";
  EXPECT_EQ(v.source.sha256, Sha(bytes));
  // An announced digest, in upper case: passed on lower-cased, checked by the sink.
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord w, Ingest(Meta(bytes, Upper(Sha(bytes))), bytes));
  ASSERT_EQ(store_->commits.size(), 2u);
  EXPECT_EQ(store_->commits[1], Sha(bytes));
  EXPECT_EQ(w.source.sha256, Sha(bytes));
  EXPECT_EQ(store_->sink_bytes.load(), 2 * bytes.size());
}

TEST_F(StoreIngest, AResourceIsHashedByItsSinkAndAWrongDigestStoresNothing) {
  const std::string gltf = R"({"asset":{"version":"2.0"},"buffers":[{"uri":"a.bin","byteLength":4}]})";
  const std::string bin = "abcd";
  IngestMeta meta = Meta(gltf);
  meta.filename = "scene.gltf";
  IngestUpload upload(store_.get(), Principal{"acme", false}, IngestLimits{});
  MS_ASSERT_OK(upload.Begin(meta));
  MS_ASSERT_OK(upload.Chunk(Data(gltf), gltf.size()));
  MS_ASSERT_OK(upload.BeginResource(ResourceMeta{"a.bin", bin.size(), Sha("abce")}));
  MS_ASSERT_OK(upload.Chunk(Data(bin), bin.size()));
  auto finished = upload.Finish();
  ASSERT_FALSE(finished.ok());
  EXPECT_EQ(finished.status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(finished.status().message(), "resource 'a.bin': the bytes have SHA-256 " + Sha(bin) + ", not the " +
                                             Sha("abce") + " announced; nothing stored");
  EXPECT_FALSE(store_->HasBlob(Sha(bin)).value());
  EXPECT_EQ(store_->sink_bytes.load(), gltf.size() + bin.size());
  EXPECT_EQ(store_->CountUnfinishedJobs().value(), 0);
}

TEST_F(StoreIngest, AWrongMainDigestIsDataLossAndNoVersion) {
  const std::string bytes = "the main file";
  auto refused = Ingest(Meta(bytes, Sha("other")), bytes);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(refused.status().message(), "chair.glb: the bytes have SHA-256 " + Sha(bytes) + ", not the " +
                                            Sha("other") + " announced; nothing stored");
  EXPECT_FALSE(store_->HasBlob(Sha(bytes)).value());
  EXPECT_EQ(store_->CountUnfinishedJobs().value(), 0);
}

TEST_F(StoreIngest, AResumableUploadIsHashedOnceAtCommitAndDiscardedWhenItsDigestIsWrong) {
  const std::string bytes(5000, 'r');
  IngestMeta meta = Meta(bytes, Sha(bytes));
  meta.upload_id = "up-1";
  // The first call breaks off after 2000 bytes; the second resumes there.
  {
    IngestUpload first(store_.get(), Principal{"acme", false}, IngestLimits{});
    MS_ASSERT_OK(first.Begin(meta));
    MS_ASSERT_OK(first.Chunk(Data(bytes), 2000));
  }
  meta.write_offset = 2000;
  MS_ASSERT_OK_AND_ASSIGN(const VersionRecord v, Ingest(meta, bytes, 1000));
  EXPECT_EQ(v.source.sha256, Sha(bytes));
  EXPECT_EQ(store_->upload_bytes.load(), bytes.size());
  EXPECT_EQ(store_->sink_bytes.load(), 0u);
  ASSERT_EQ(store_->commits.size(), 1u);
  EXPECT_EQ(store_->commits[0], Sha(bytes));

  IngestMeta liar = Meta(bytes, Sha("not these bytes"));
  liar.upload_id = "up-2";
  auto refused = Ingest(liar, bytes, 4096);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kDataLoss) << refused.status().ToString();
  EXPECT_EQ(store_->UploadSize("acme", "up-2").status().code(), StatusCode::kNotFound) << "discarded";
}

TEST_F(StoreIngest, RequestsAreRefusedWithTheStoresChecksBeforeAnyByteIsStored) {
  const std::string bytes = "x";
  const auto refused = [&](IngestMeta meta, const std::string& message) {
    IngestUpload upload(store_.get(), Principal{"acme", false}, IngestLimits{});
    const Status s = upload.Begin(meta);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << s.ToString();
    EXPECT_EQ(s.message(), message);
  };
  IngestMeta m = Meta(bytes, "xyz");
  refused(m, "sha256: not a SHA-256 (64 lower-case hex digits)");
  m = Meta(bytes);
  m.asset = "a b";
  refused(m, "asset: only letters, digits, '.', '_' and '-' are allowed");
  m = Meta(bytes);
  m.comment = std::string("a\0b", 3);
  refused(m, "comment: contains a NUL byte");
  m = Meta(bytes);
  m.labels = {{"k", "\xC3\x28"}};
  refused(m, "labels[k]: is not valid UTF-8");
  m = Meta(bytes);
  m.labels = {{"\xFF", "v"}};
  refused(m, "labels: a key: is not valid UTF-8");
  m = Meta(bytes);
  m.upload_id = "..";
  refused(m, "upload_id: '..' is not a name");
  EXPECT_EQ(store_->sink_bytes.load() + store_->upload_bytes.load(), 0u);
}

}  // namespace
}  // namespace meshstream
