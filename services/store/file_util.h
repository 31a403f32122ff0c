// POSIX file helpers the stores share: errors as Status naming the path,
// folders made and fsync'd, whole writes, folder listings. No exceptions.
#ifndef MESHSTREAM_SERVICES_STORE_FILE_UTIL_H_
#define MESHSTREAM_SERVICES_STORE_FILE_UTIL_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

// IoError "<what>: <strerror(errno)>".
Status Errno(const std::string& what);
// Creates `path` (one level, mode 0750); true when it did not exist before.
// IoError when it exists and is not a folder.
StatusOr<bool> MakeFolder(const std::string& path);
// fsync of a folder, so that a rename or a new name in it is durable.
Status SyncFolder(const std::string& path);
// write() until every byte is written (EINTR retried).
Status WriteAll(int fd, const uint8_t* data, size_t size, const std::string& path);
// The names in folder `path` but "." and "..".
StatusOr<std::vector<std::string>> ListFolder(const std::string& path);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_FILE_UTIL_H_
