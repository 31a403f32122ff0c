#include "services/pipeline/materialize.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <set>
#include <vector>

#include "proto/api_names.h"

namespace meshstream {

namespace {

std::string ErrnoText(int e) { return std::strerror(e); }

std::string SystemTempDir() {
  const char* env = std::getenv("TMPDIR");
  if (env != nullptr && env[0] == '/') return env;
  return "/tmp";
}

Status Collision(const std::string& name, const std::string& why) {
  return InvalidArgument("resource name '" + PrintableName(name) + "': " + why);
}

}  // namespace

WorkFolder::~WorkFolder() { Remove(); }

WorkFolder::WorkFolder(WorkFolder&& other) noexcept
    : path_(std::move(other.path_)), main_path_(std::move(other.main_path_)), bytes_written_(other.bytes_written_) {
  other.path_.clear();
  other.main_path_.clear();
}

WorkFolder& WorkFolder::operator=(WorkFolder&& other) noexcept {
  if (this != &other) {
    Remove();
    path_ = std::move(other.path_);
    main_path_ = std::move(other.main_path_);
    bytes_written_ = other.bytes_written_;
    other.path_.clear();
    other.main_path_.clear();
  }
  return *this;
}

void WorkFolder::Remove() {
  if (path_.empty()) return;
  std::error_code ec;  // the non-throwing overload; it does not follow links
  std::filesystem::remove_all(path_, ec);
  path_.clear();
  main_path_.clear();
}

StatusOr<WorkFolder> WorkFolder::Create(const std::string& parent) {
  const std::string base = parent.empty() ? SystemTempDir() : parent;
  std::string pattern = base + "/meshstream-job-XXXXXX";
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  if (mkdtemp(buf.data()) == nullptr) {
    return IoError(base + ": cannot make a work folder: " + ErrnoText(errno));
  }
  WorkFolder folder;
  folder.path_ = buf.data();
  return folder;
}

Status WorkFolder::WriteFile(const std::string& name, const uint8_t* data, size_t size) {
  // Folders first, one segment at a time, each ours (no link can be there:
  // the work folder is 0700 and only this object writes into it).
  size_t slash = name.find('/');
  while (slash != std::string::npos) {
    const std::string dir = path_ + "/" + name.substr(0, slash);
    if (mkdir(dir.c_str(), 0700) != 0) {
      const int e = errno;
      struct stat st;
      if (e != EEXIST) return IoError(PrintableName(name) + ": cannot make its folder: " + ErrnoText(e));
      if (lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
        return Collision(name, "'" + PrintableName(name.substr(0, slash)) + "' is also a file");
      }
    }
    slash = name.find('/', slash + 1);
  }
  const std::string file = path_ + "/" + name;
  const int fd = open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int e = errno;
    if (e == EEXIST) return Collision(name, "given twice, or also a folder of another name");
    return IoError(PrintableName(name) + ": cannot create: " + ErrnoText(e));
  }
  size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : EIO;
      close(fd);
      return IoError(PrintableName(name) + ": cannot write: " + ErrnoText(e));
    }
    done += static_cast<size_t>(n);
  }
  if (close(fd) != 0) return IoError(PrintableName(name) + ": cannot close: " + ErrnoText(errno));
  bytes_written_ += size;
  return Status::Ok();
}

StatusOr<WorkFolder> MaterializeVersion(Store& store, const VersionRecord& version, const std::string& parent,
                                        uint64_t max_source_bytes) {
  // Every name and the total size are checked before anything is read.
  MS_RETURN_IF_ERROR(CheckMainFilename(version.source.name));
  std::set<std::string> names = {version.source.name};
  uint64_t total = version.source.size;
  for (const SourceFile& r : version.resources) {
    MS_RETURN_IF_ERROR(CheckResourceName(r.name));
    if (!names.insert(r.name).second) return Collision(r.name, "given twice (or the main file's name)");
    total += r.size;
    if (total < r.size) total = UINT64_MAX;
  }
  if (total > max_source_bytes) {
    return ResourceExhausted("the source's files hold " + std::to_string(total) + " bytes, above the limit of " +
                             std::to_string(max_source_bytes));
  }
  MS_ASSIGN_OR_RETURN(WorkFolder folder, WorkFolder::Create(parent));
  auto write = [&](const SourceFile& f) -> Status {
    // Capped at the recorded size: a larger blob is a record that lies.
    auto bytes = store.GetBlob(f.sha256, f.size);
    if (!bytes.ok() && bytes.status().code() == StatusCode::kResourceExhausted) {
      return DataLoss(PrintableName(f.name) + ": blob " + f.sha256 + " is larger than the " + std::to_string(f.size) +
                      " bytes the version records");
    }
    if (!bytes.ok()) return bytes.status().WithContext(PrintableName(f.name));
    if (bytes->size() != f.size) {
      return DataLoss(PrintableName(f.name) + ": blob " + f.sha256 + " holds " + std::to_string(bytes->size()) +
                      " bytes, the version records " + std::to_string(f.size));
    }
    return folder.WriteFile(f.name, bytes->data(), bytes->size());
  };
  MS_RETURN_IF_ERROR(write(version.source));
  for (const SourceFile& r : version.resources) MS_RETURN_IF_ERROR(write(r));
  folder.main_path_ = folder.path_ + "/" + version.source.name;
  return folder;
}

}  // namespace meshstream
