#include "services/store/file_util.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace meshstream {

Status Errno(const std::string& what) { return IoError(what + ": " + std::strerror(errno)); }

StatusOr<bool> MakeFolder(const std::string& path) {
  if (mkdir(path.c_str(), 0750) == 0) return true;
  if (errno != EEXIST) return Errno(path);
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return Errno(path);
  if (!S_ISDIR(st.st_mode)) return IoError(path + ": exists and is not a folder");
  return false;
}

Status SyncFolder(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return Errno(path);
  const int rc = fsync(fd);
  close(fd);
  if (rc != 0) return Errno(path + ": fsync");
  return Status::Ok();
}

Status WriteAll(int fd, const uint8_t* data, size_t size, const std::string& path) {
  while (size > 0) {
    const ssize_t n = write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return Errno(path);
    }
    data += n;
    size -= static_cast<size_t>(n);
  }
  return Status::Ok();
}

StatusOr<std::vector<std::string>> ListFolder(const std::string& path) {
  DIR* dir = opendir(path.c_str());
  if (dir == nullptr) return Errno(path);
  std::vector<std::string> names;
  errno = 0;
  while (const dirent* entry = readdir(dir)) {
    const std::string name = entry->d_name;
    if (name != "." && name != "..") names.push_back(name);
  }
  const int error = errno;
  closedir(dir);
  if (error != 0) {
    errno = error;
    return Errno(path);
  }
  return names;
}

}  // namespace meshstream
