#include "importers/import.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "importers/gltf_import.h"
#include "importers/mesh_io.h"

namespace meshstream {

std::string FileExtension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

std::string FileBaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string FileFolder(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

std::string FileStem(const std::string& path) {
  std::string name = FileBaseName(path);
  const size_t dot = name.find_last_of('.');
  if (dot != std::string::npos && dot > 0) name.resize(dot);
  return name;
}

StatusOr<std::vector<uint8_t>> ReadFileBytes(const std::string& path, uint64_t max_bytes) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) {
    if (errno == ENOENT) return NotFound(path + ": no such file");
    return IoError(path + ": cannot open: " + std::strerror(errno));
  }
  if (std::fseek(file.get(), 0, SEEK_END) != 0) return IoError(path + ": cannot seek (not a regular file?)");
  const long size = std::ftell(file.get());
  if (size < 0) return IoError(path + ": cannot tell the file's size (not a regular file?)");
  if (static_cast<uint64_t>(size) > max_bytes) {
    return ResourceExhausted(path + ": " + std::to_string(size) + " bytes is above the input cap of " +
                             std::to_string(max_bytes) + " bytes");
  }
  std::rewind(file.get());
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  if (size > 0 && std::fread(bytes.data(), 1, bytes.size(), file.get()) != bytes.size()) {
    return IoError(path + ": short read");
  }
  return bytes;
}

Status WriteFileBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  // Write to a temporary name first so that a failed write never leaves half a file.
  const std::string tmp = path + ".tmp";
  {
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(tmp.c_str(), "wb"), &std::fclose);
    if (!file) return IoError(path + ": cannot create: " + std::strerror(errno));
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file.get()) != bytes.size()) {
      std::remove(tmp.c_str());
      return IoError(path + ": write failed: " + std::strerror(errno));
    }
    if (std::fflush(file.get()) != 0) {
      std::remove(tmp.c_str());
      return IoError(path + ": write failed: " + std::strerror(errno));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return IoError(path + ": cannot rename into place: " + std::strerror(errno));
  }
  return Status::Ok();
}

StatusOr<Scene> ImportFile(const std::string& path, const ImportOptions& options) {
  const std::string ext = FileExtension(path);
  if (ext == ".gltf" || ext == ".glb") return ImportGltfFile(path, options);
  if (ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl") {
    return ImportMeshFile(path, options);
  }
  return Unsupported(path + ": unknown file type '" + ext +
                     "' (supported: .gltf .glb .obj .ply .off .stl)");
}

}  // namespace meshstream
