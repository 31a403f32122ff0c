// FileBlobStore on a real folder: content addressing, durability by rename,
// verification on every read, hostile names, leftovers of a crash.
#include "services/store/blob_store.h"

#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "testing/test_util.h"

namespace meshstream {
namespace {

namespace fs = std::filesystem;
using test_util::TempDir;

std::vector<uint8_t> Bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

FileBlobStore MustOpen(const std::string& dir) {
  auto store = FileBlobStore::Open(dir);
  EXPECT_TRUE(store.ok()) << store.status().ToString();
  return std::move(store).value();
}

size_t FilesUnder(const std::string& dir) {
  size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

TEST(BlobStore, Sha256MatchesTheStandardVectors) {
  EXPECT_EQ(Sha256Hex(nullptr, 0), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  const auto abc = Bytes("abc");
  EXPECT_EQ(Sha256Hex(abc.data(), abc.size()), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(BlobStore, PutThenGetGivesTheBytesUnderTheirDigestOnce) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const auto data = Bytes("a mesh, more or less");
  auto digest = store.Put(data.data(), data.size());
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(digest.value(), Sha256Hex(data.data(), data.size()));
  EXPECT_TRUE(store.Contains(digest.value()));
  EXPECT_TRUE(fs::is_regular_file(store.root() + "/" + digest->substr(0, 2) + "/" + digest.value()));
  auto again = store.Put(data.data(), data.size());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value(), digest.value());
  EXPECT_EQ(FilesUnder(store.root()), 1u);  // stored once, no temporary file left
  auto read = store.Get(digest.value(), 1 << 20);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read.value(), data);
}

TEST(BlobStore, AChunkedWriterGivesTheSameBlob) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  std::vector<uint8_t> data(300000);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 7 + i / 251);
  auto writer = store.NewWriter();
  ASSERT_TRUE(writer.ok());
  for (size_t at = 0; at < data.size(); at += 65536) {
    ASSERT_TRUE(writer->Append(data.data() + at, std::min<size_t>(65536, data.size() - at)).ok());
  }
  EXPECT_EQ(writer->size(), data.size());
  EXPECT_FALSE(store.Contains(Sha256Hex(data.data(), data.size())));  // nothing visible before Commit
  auto digest = writer->Commit(Sha256Hex(data.data(), data.size()));
  ASSERT_TRUE(digest.ok()) << digest.status().ToString();
  EXPECT_EQ(store.Get(digest.value(), data.size()).value(), data);
  EXPECT_FALSE(writer->Commit().ok());  // once only
}

TEST(BlobStore, AWrongAnnouncedDigestStoresNothing) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const auto data = Bytes("uploaded bytes");
  const std::string claimed(64, 'a');
  {
    auto writer = store.NewWriter();
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->Append(data.data(), data.size()).ok());
    auto digest = writer->Commit(claimed);
    ASSERT_FALSE(digest.ok());
    EXPECT_EQ(digest.status().code(), StatusCode::kDataLoss);
    EXPECT_NE(digest.status().message().find(claimed), std::string::npos);
  }
  EXPECT_FALSE(store.Contains(Sha256Hex(data.data(), data.size())));
  EXPECT_FALSE(store.Contains(claimed));
  EXPECT_EQ(FilesUnder(store.root()), 0u);
}

TEST(BlobStore, AnAbandonedWriterLeavesNoFile) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  {
    auto writer = store.NewWriter();
    ASSERT_TRUE(writer.ok());
    const auto data = Bytes("half an upload");
    ASSERT_TRUE(writer->Append(data.data(), data.size()).ok());
    EXPECT_EQ(FilesUnder(store.root()), 1u);  // the temporary file
  }
  EXPECT_EQ(FilesUnder(store.root()), 0u);
}

TEST(BlobStore, DamagedBytesAreDataLossNeverWrongBytes) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const auto data = Bytes("bytes that a disk will damage");
  const std::string digest = store.Put(data.data(), data.size()).value();
  const std::string path = store.root() + "/" + digest.substr(0, 2) + "/" + digest;
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(3);
    f.put('X');
  }
  auto flipped = store.Get(digest, 1 << 20);
  ASSERT_FALSE(flipped.ok());
  EXPECT_EQ(flipped.status().code(), StatusCode::kDataLoss);
  fs::resize_file(path, 5);
  EXPECT_EQ(store.Get(digest, 1 << 20).status().code(), StatusCode::kDataLoss);
}

TEST(BlobStore, NamesThatAreNotDigestsNeverBecomePaths) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  for (const std::string& name : {std::string("../../etc/passwd"), std::string(63, 'a'), std::string(65, 'a'),
                                  std::string(64, 'A'), std::string(62, 'a') + "/."}) {
    EXPECT_EQ(store.Get(name, 1 << 20).status().code(), StatusCode::kInvalidArgument) << name;
    EXPECT_FALSE(store.Contains(name)) << name;
    EXPECT_EQ(store.Remove(name).code(), StatusCode::kInvalidArgument) << name;
  }
  EXPECT_EQ(store.Get(std::string(64, 'b'), 1 << 20).status().code(), StatusCode::kNotFound);
}

TEST(BlobStore, ReadsAreCappedBeforeAllocating) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const std::vector<uint8_t> data(4096, 7);
  const std::string digest = store.Put(data.data(), data.size()).value();
  EXPECT_EQ(store.Get(digest, 4095).status().code(), StatusCode::kResourceExhausted);
  EXPECT_TRUE(store.Get(digest, 4096).ok());
}

TEST(BlobStore, OpenRemovesWhatACrashLeftBehind) {
  TempDir dir;
  { const FileBlobStore store = MustOpen(dir.path()); }
  test_util::WriteText(dir.path() + "/blobs/tmp/0123.part", "half-written");
  test_util::WriteText(dir.path() + "/blobs/tmp/4567.part", "");
  const FileBlobStore store = MustOpen(dir.path());
  EXPECT_EQ(store.removed_temporary_files(), 2u);
  EXPECT_EQ(FilesUnder(store.root()), 0u);
}

TEST(BlobStore, RemoveDeletesOneBlob) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const auto a = Bytes("a"), b = Bytes("b");
  const std::string da = store.Put(a.data(), a.size()).value(), db = store.Put(b.data(), b.size()).value();
  ASSERT_TRUE(store.Remove(da).ok());
  EXPECT_FALSE(store.Contains(da));
  EXPECT_TRUE(store.Contains(db));
  EXPECT_EQ(store.Remove(da).code(), StatusCode::kNotFound);
}

TEST(BlobStore, WritersOfTheSameBytesAtOnceBothSucceed) {
  TempDir dir;
  const FileBlobStore store = MustOpen(dir.path());
  const std::vector<uint8_t> data(1 << 16, 42);
  std::vector<std::string> digests(8);
  std::vector<std::thread> threads;
  for (size_t t = 0; t < digests.size(); ++t) {
    threads.emplace_back([&, t] {
      auto d = store.Put(data.data(), data.size());
      digests[t] = d.ok() ? d.value() : d.status().ToString();
    });
  }
  for (std::thread& t : threads) t.join();
  for (const std::string& d : digests) EXPECT_EQ(d, Sha256Hex(data.data(), data.size()));
  EXPECT_EQ(FilesUnder(store.root()), 1u);
  EXPECT_EQ(store.Get(digests[0], data.size()).value(), data);
}

}  // namespace
}  // namespace meshstream
