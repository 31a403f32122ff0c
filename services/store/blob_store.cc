#include "services/store/blob_store.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "services/store/file_util.h"

namespace meshstream {

namespace {

namespace fs = std::filesystem;


}  // namespace

Status BlobNotFound(const std::string& sha256) { return NotFound("blob " + sha256 + " does not exist"); }

Status BlobTooLarge(const std::string& sha256, uint64_t size, uint64_t max_bytes) {
  return ResourceExhausted("blob " + sha256 + " has " + std::to_string(size) + " bytes, more than " +
                           std::to_string(max_bytes));
}

Status BlobDamaged(const std::string& sha256) {
  return DataLoss("blob " + sha256 + " does not match its digest (the stored bytes are damaged)");
}

Status DigestMismatch(const std::string& actual, const std::string& expected) {
  return DataLoss("the bytes have SHA-256 " + actual + ", not the " + expected + " announced; nothing stored");
}

struct BlobWriter::State {
  std::string root;      // <dir>/blobs
  std::string temp;      // its temporary file
  int fd = -1;
  uint64_t size = 0;
  Sha256Hasher hash;
  bool committed = false;

  ~State() {
    if (fd >= 0) close(fd);
    if (!committed && !temp.empty()) unlink(temp.c_str());
  }
};

BlobWriter::BlobWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}
BlobWriter::BlobWriter(BlobWriter&&) noexcept = default;
BlobWriter& BlobWriter::operator=(BlobWriter&&) noexcept = default;
BlobWriter::~BlobWriter() = default;

uint64_t BlobWriter::size() const { return state_ ? state_->size : 0; }

Status BlobWriter::Append(const uint8_t* data, size_t size) {
  if (!state_ || state_->fd < 0) return Internal("blob writer: append after commit");
  MS_RETURN_IF_ERROR(WriteAll(state_->fd, data, size, state_->temp));
  state_->hash.Update(data, size);
  state_->size += size;
  return Status::Ok();
}

StatusOr<std::string> BlobWriter::Commit(const std::string& expected_sha256) {
  if (!state_ || state_->fd < 0) return Internal("blob writer: committed twice");
  const std::string digest = state_->hash.FinishHex();
  if (!expected_sha256.empty() && expected_sha256 != digest) {
    return DigestMismatch(digest, expected_sha256);
  }
  if (fsync(state_->fd) != 0) return Errno(state_->temp + ": fsync");
  close(state_->fd);
  state_->fd = -1;
  const std::string folder = state_->root + "/" + digest.substr(0, 2);
  MS_RETURN_IF_ERROR(MakeFolder(folder).status());
  const std::string target = folder + "/" + digest;
  if (rename(state_->temp.c_str(), target.c_str()) != 0) return Errno(target);
  state_->committed = true;
  MS_RETURN_IF_ERROR(SyncFolder(folder));
  MS_RETURN_IF_ERROR(SyncFolder(state_->root));
  return digest;
}

StatusOr<FileBlobStore> FileBlobStore::Open(const std::string& dir) {
  MS_RETURN_IF_ERROR(InitSodium());
  FileBlobStore store;
  MS_RETURN_IF_ERROR(MakeFolder(dir).status());
  store.root_ = dir + "/blobs";
  MS_RETURN_IF_ERROR(MakeFolder(store.root_).status());
  MS_RETURN_IF_ERROR(MakeFolder(store.root_ + "/tmp").status());
  // What a crash left behind: never visible under a digest, safe to remove.
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(store.root_ + "/tmp", ec)) {
    if (entry.path().extension() == ".part" && fs::remove(entry.path(), ec)) ++store.removed_temporary_;
  }
  if (ec) return IoError(store.root_ + "/tmp: " + ec.message());
  return store;
}

std::string FileBlobStore::PathOf(const std::string& digest) const {
  return root_ + "/" + digest.substr(0, 2) + "/" + digest;
}

StatusOr<BlobWriter> FileBlobStore::NewWriter() const {
  auto state = std::make_unique<BlobWriter::State>();
  state->root = root_;
  state->temp = root_ + "/tmp/" + RandomHex(16) + ".part";
  state->fd = open(state->temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0640);
  if (state->fd < 0) return Errno(state->temp);
  return BlobWriter(std::move(state));
}

StatusOr<std::string> FileBlobStore::Put(const uint8_t* data, size_t size) const {
  MS_ASSIGN_OR_RETURN(BlobWriter writer, NewWriter());
  MS_RETURN_IF_ERROR(writer.Append(data, size));
  return writer.Commit();
}

bool FileBlobStore::Contains(const std::string& digest) const {
  struct stat st {};
  return IsSha256Hex(digest) && stat(PathOf(digest).c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

StatusOr<std::vector<uint8_t>> FileBlobStore::Get(const std::string& digest, uint64_t max_bytes) const {
  if (!IsSha256Hex(digest)) return InvalidArgument("blob name '" + digest + "' is not a SHA-256 in hex");
  const std::string path = PathOf(digest);
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return errno == ENOENT ? BlobNotFound(digest) : Errno(path);
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    return IoError(path + ": not a regular file");
  }
  if (static_cast<uint64_t>(st.st_size) > max_bytes) {
    close(fd);
    return BlobTooLarge(digest, static_cast<uint64_t>(st.st_size), max_bytes);
  }
  std::vector<uint8_t> bytes(static_cast<size_t>(st.st_size));
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = read(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<size_t>(n);
  }
  close(fd);
  if (done != bytes.size()) return DataLoss("blob " + digest + " is shorter than its file size");
  if (Sha256Hex(bytes.data(), bytes.size()) != digest) {
    return BlobDamaged(digest);
  }
  return bytes;
}

Status FileBlobStore::Remove(const std::string& digest) const {
  if (!IsSha256Hex(digest)) return InvalidArgument("blob name '" + digest + "' is not a SHA-256 in hex");
  if (unlink(PathOf(digest).c_str()) != 0) {
    return errno == ENOENT ? BlobNotFound(digest) : Errno(PathOf(digest));
  }
  return Status::Ok();
}

}  // namespace meshstream
