// The embedded store's files (services/store/sqlite_store.h): blobs in a
// FileBlobStore folder, and the bytes of resumable uploads in
// <dir>/uploads/<tenant>/<upload_id>.part with their acknowledged size in the
// `uploads` table.
#include "services/store/sqlite_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <functional>
#include <unordered_set>
#include <utility>

#include "services/store/file_util.h"
#include "services/store/sqlite_db.h"
#include "services/store/store_records.h"

namespace meshstream {

namespace {

int64_t MtimeMs(const struct stat& st) {
  return static_cast<int64_t>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
}

// The blob sink of the embedded store: a FileBlobStore writer, which hashes
// the bytes as they are written.
class FileBlobSink final : public BlobSink {
 public:
  explicit FileBlobSink(BlobWriter writer) : writer_(std::move(writer)) {}
  uint64_t size() const override { return writer_.size(); }

 private:
  Status DoAppend(const uint8_t* data, size_t size) override { return writer_.Append(data, size); }
  StatusOr<std::string> DoCommit(const std::string& expected_sha256) override {
    return writer_.Commit(expected_sha256);
  }

  BlobWriter writer_;
};

}  // namespace

// --- blobs -------------------------------------------------------------------

StatusOr<std::unique_ptr<BlobSink>> SqliteStore::DoNewBlob() {
  MS_RETURN_IF_ERROR(CheckExclusive("NewBlob"));
  MS_ASSIGN_OR_RETURN(BlobWriter writer, blobs_->NewWriter());
  return std::unique_ptr<BlobSink>(new FileBlobSink(std::move(writer)));
}

StatusOr<std::vector<uint8_t>> SqliteStore::DoGetBlob(const std::string& sha256, uint64_t max_bytes) {
  MS_RETURN_IF_ERROR(CheckExclusive("GetBlob"));
  return blobs_->Get(sha256, max_bytes);
}

StatusOr<bool> SqliteStore::DoHasBlob(const std::string& sha256) {
  MS_RETURN_IF_ERROR(CheckExclusive("HasBlob"));
  return blobs_->Contains(sha256);
}

StatusOr<uint64_t> SqliteStore::DoRemoveOrphanBlobs(int64_t min_age_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("RemoveOrphanBlobs"));
  // Walk the folder without the lock: blobs old enough to go if no row names them.
  std::vector<std::string> candidates;
  const int64_t cutoff_ms = NowMs() - min_age_ms;
  MS_ASSIGN_OR_RETURN(const std::vector<std::string> prefixes, ListFolder(blobs_->root()));
  for (const std::string& prefix : prefixes) {
    if (prefix.size() != 2) continue;  // the prefix folders, not tmp/
    const std::string folder = blobs_->root() + "/" + prefix;
    struct stat st {};
    if (stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) continue;
    MS_ASSIGN_OR_RETURN(const std::vector<std::string> names, ListFolder(folder));
    for (const std::string& name : names) {
      if (!IsSha256Hex(name) || name.compare(0, 2, prefix) != 0) continue;
      const std::string path = folder + "/" + name;
      if (stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && MtimeMs(st) <= cutoff_ms) {
        candidates.push_back(name);
      }
    }
  }
  if (candidates.empty()) return uint64_t{0};

  // Under the lock, so no CreateVersion, CompleteJob or PutArtifact (which
  // check their blobs under it) can start naming a blob while it goes.
  std::lock_guard<std::mutex> lock(mu_);
  std::unordered_set<std::string> named;
  {
    Stmt s(db_,
           "SELECT source_sha256 FROM versions UNION SELECT artifact_sha256 FROM versions "
           "UNION SELECT sha256 FROM version_resources UNION SELECT artifact_sha256 FROM artifacts");
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      named.insert(s.Text(0));
    }
  }
  uint64_t removed = 0;
  for (const std::string& digest : candidates) {
    if (named.count(digest) != 0) continue;
    // A writer of the same bytes may have renamed a fresh copy over it since.
    struct stat st {};
    const std::string path = blobs_->root() + "/" + digest.substr(0, 2) + "/" + digest;
    if (stat(path.c_str(), &st) != 0 || MtimeMs(st) > cutoff_ms) continue;
    const Status status = blobs_->Remove(digest);
    if (status.ok()) {
      ++removed;
    } else if (status.code() != StatusCode::kNotFound) {
      return status;
    }
  }
  return removed;
}

// --- uploads -------------------------------------------------------------------

std::string SqliteStore::UploadPath(const std::string& tenant, const std::string& upload_id) const {
  return dir_ + "/uploads/" + tenant + "/" + upload_id + ".part";
}

std::mutex& SqliteStore::UploadLock(const std::string& tenant, const std::string& upload_id) {
  const size_t h = std::hash<std::string>()(tenant) * 31 + std::hash<std::string>()(upload_id);
  return upload_locks_[h % upload_locks_.size()];
}

Status SqliteStore::RemoveUploadFile(const std::string& tenant, const std::string& upload_id) const {
  const std::string path = UploadPath(tenant, upload_id);
  if (unlink(path.c_str()) != 0 && errno != ENOENT) return Errno(path);
  return Status::Ok();
}

StatusOr<std::optional<uint64_t>> SqliteStore::UploadRowLocked(const std::string& tenant,
                                                                const std::string& upload_id) {
  Stmt s(db_, "SELECT size FROM uploads WHERE tenant = ? AND upload_id = ?");
  s.Bind(tenant, upload_id);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return std::optional<uint64_t>();
  return std::optional<uint64_t>(static_cast<uint64_t>(s.Int(0)));
}

Status SqliteStore::DeleteUploadRowLocked(const std::string& tenant, const std::string& upload_id) {
  Stmt s(db_, "DELETE FROM uploads WHERE tenant = ? AND upload_id = ?");
  s.Bind(tenant, upload_id);
  return s.Run();
}

StatusOr<uint64_t> SqliteStore::DoUploadSize(const std::string& tenant, const std::string& upload_id) {
  std::lock_guard<std::mutex> lock(mu_);
  MS_ASSIGN_OR_RETURN(const std::optional<uint64_t> size, UploadRowLocked(tenant, upload_id));
  if (!size) return UploadNotFound(upload_id);
  return *size;
}

Status SqliteStore::DoAppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                                 const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckExclusive("AppendUpload"));
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  std::optional<uint64_t> durable;
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(durable, UploadRowLocked(tenant, upload_id));
  }
  const uint64_t have = durable.value_or(0);
  if (offset != have) {
    return UploadOffsetMismatch(upload_id, have, offset);
  }

  const std::string folder = dir_ + "/uploads/" + tenant;
  MS_ASSIGN_OR_RETURN(const bool new_folder, MakeFolder(folder));
  if (new_folder) MS_RETURN_IF_ERROR(SyncFolder(dir_ + "/uploads"));
  const std::string path = UploadPath(tenant, upload_id);
  // A file may exist without a row (a crash before the first row): reused.
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0640);
  if (fd < 0) return Errno(path);
  // Bytes past the durable size were never acknowledged (a crash between
  // write and commit): the client sends them again.
  Status written = Status::Ok();
  if (ftruncate(fd, static_cast<off_t>(offset)) != 0) written = Errno(path + ": truncate");
  uint64_t at = offset;
  while (written.ok() && at < offset + size) {
    const ssize_t n = pwrite(fd, data + (at - offset), offset + size - at, static_cast<off_t>(at));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      written = Errno(path);
      break;
    }
    at += static_cast<uint64_t>(n);
  }
  if (written.ok() && fsync(fd) != 0) written = Errno(path + ": fsync");
  close(fd);
  MS_RETURN_IF_ERROR(written);
  if (!durable) MS_RETURN_IF_ERROR(SyncFolder(folder));  // the file's name is durable before its row

  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "INSERT OR REPLACE INTO uploads (tenant, upload_id, size, updated_ms) VALUES (?, ?, ?, ?)");
  s.Bind(tenant, upload_id, offset + size, NowMs());
  return s.Run();
}

StatusOr<std::string> SqliteStore::DoCommitUpload(const std::string& tenant, const std::string& upload_id,
                                                const std::string& expected_sha256) {
  MS_RETURN_IF_ERROR(CheckExclusive("CommitUpload"));
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  std::optional<uint64_t> size;
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(size, UploadRowLocked(tenant, upload_id));
  }
  if (!size) return UploadNotFound(upload_id);

  // FileBlobStore has no way to adopt a file, so the bytes are copied into a
  // blob writer, which hashes them and makes the blob durable.
  const std::string path = UploadPath(tenant, upload_id);
  MS_ASSIGN_OR_RETURN(BlobWriter writer, blobs_->NewWriter());
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  Status copied = Status::Ok();
  if (fd < 0) copied = errno == ENOENT ? DataLoss("upload " + upload_id + ": its file is missing") : Errno(path);
  std::vector<uint8_t> buffer(fd >= 0 ? 1 << 20 : 0);
  uint64_t done = 0;
  while (copied.ok() && done < *size) {
    const size_t want = static_cast<size_t>(std::min<uint64_t>(buffer.size(), *size - done));
    const ssize_t n = pread(fd, buffer.data(), want, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      copied = Errno(path);
    } else if (n == 0) {
      copied = DataLoss("upload " + upload_id + ": the file has " + std::to_string(done) + " bytes, fewer than the " +
                        std::to_string(*size) + " acknowledged");
    } else {
      copied = writer.Append(buffer.data(), static_cast<size_t>(n));
      done += static_cast<uint64_t>(n);
    }
  }
  if (fd >= 0) close(fd);
  StatusOr<std::string> digest = copied.ok() ? writer.Commit(expected_sha256) : StatusOr<std::string>(copied);
  if (!digest.ok() && digest.status().code() != StatusCode::kDataLoss) return digest.status();  // retry may work

  // Committed, or bytes that can never become the announced blob: the upload goes.
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_RETURN_IF_ERROR(DeleteUploadRowLocked(tenant, upload_id));
  }
  MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
  if (!digest.ok()) {
    return UploadDiscarded(upload_id, digest.status());
  }
  return digest;
}

Status SqliteStore::DoDiscardUpload(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckExclusive("DiscardUpload"));
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(const std::optional<uint64_t> size, UploadRowLocked(tenant, upload_id));
    if (!size) return UploadNotFound(upload_id);
    MS_RETURN_IF_ERROR(DeleteUploadRowLocked(tenant, upload_id));
  }
  return RemoveUploadFile(tenant, upload_id);
}

StatusOr<uint64_t> SqliteStore::DoExpireUploads(int64_t max_idle_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("ExpireUploads"));
  const int64_t cutoff_ms = NowMs() - max_idle_ms;
  std::vector<std::pair<std::string, std::string>> idle;
  {
    std::lock_guard<std::mutex> lock(mu_);
    Stmt s(db_, "SELECT tenant, upload_id FROM uploads WHERE updated_ms <= ?");
    s.Bind(cutoff_ms);
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      idle.emplace_back(s.Text(0), s.Text(1));
    }
  }
  uint64_t removed = 0;
  for (const auto& [tenant, upload_id] : idle) {
    std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
    {
      std::lock_guard<std::mutex> lock(mu_);
      // Still idle? An append may have come in since the query.
      Stmt s(db_, "DELETE FROM uploads WHERE tenant = ? AND upload_id = ? AND updated_ms <= ?");
      s.Bind(tenant, upload_id, cutoff_ms);
      MS_RETURN_IF_ERROR(s.Run());
      if (s.Changes() == 0) continue;
    }
    MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
    ++removed;
  }

  // Files without a row: a crash between writing the first bytes and their
  // row, or between removing a row and its file. Not counted as uploads.
  MS_ASSIGN_OR_RETURN(const std::vector<std::string> tenants, ListFolder(dir_ + "/uploads"));
  for (const std::string& tenant : tenants) {
    const std::string folder = dir_ + "/uploads/" + tenant;
    struct stat st {};
    if (!IsValidName(tenant) || stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) continue;
    MS_ASSIGN_OR_RETURN(const std::vector<std::string> files, ListFolder(folder));
    for (const std::string& file : files) {
      constexpr size_t kSuffix = sizeof ".part" - 1;
      if (file.size() <= kSuffix || file.compare(file.size() - kSuffix, kSuffix, ".part") != 0) continue;
      const std::string upload_id = file.substr(0, file.size() - kSuffix);
      if (!IsValidName(upload_id) || stat((folder + "/" + file).c_str(), &st) != 0 || MtimeMs(st) > cutoff_ms) {
        continue;
      }
      std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
      std::optional<uint64_t> row;
      {
        std::lock_guard<std::mutex> lock(mu_);
        MS_ASSIGN_OR_RETURN(row, UploadRowLocked(tenant, upload_id));
      }
      if (!row) MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
    }
  }
  return removed;
}

}  // namespace meshstream
