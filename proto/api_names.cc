#include "proto/api_names.h"

#include "codec/core/utf8.h"
#include "importers/import.h"

namespace meshstream {

namespace {

constexpr size_t kShownBytes = 64;

bool IsControl(unsigned char c) { return c < 0x20 || c == 0x7f; }

// The rules shared by resource names and main file names; `what` starts the
// message ("resource name", "filename").
Status CheckCommon(const std::string& what, const std::string& name, size_t max_bytes) {
  auto refuse = [&](const std::string& why) { return InvalidArgument(what + " '" + PrintableName(name) + "': " + why); };
  if (name.empty()) return refuse("empty");
  if (name.size() > max_bytes) {
    return refuse(std::to_string(name.size()) + " bytes exceed " + std::to_string(max_bytes));
  }
  if (name.find('\0') != std::string::npos) return refuse("holds a NUL byte");
  if (!IsValidUtf8(name)) return refuse("not valid UTF-8");
  for (char c : name) {
    if (IsControl(static_cast<unsigned char>(c))) return refuse("holds a control character");
  }
  if (name.find('\\') != std::string::npos) return refuse("holds a backslash (use '/')");
  if (name.front() == '/') return refuse("an absolute path");
  const unsigned char first = static_cast<unsigned char>(name[0]);
  if (name.size() >= 2 && name[1] == ':' && ((first >= 'A' && first <= 'Z') || (first >= 'a' && first <= 'z'))) {
    return refuse("starts with a drive letter");
  }
  return Status::Ok();
}

}  // namespace

std::string PrintableName(const std::string& name) {
  std::string shown = ToValidUtf8(name.substr(0, kShownBytes));
  for (char& c : shown) {
    if (IsControl(static_cast<unsigned char>(c))) c = '?';
  }
  if (name.size() > kShownBytes) shown += "...";
  return shown;
}

Status CheckResourceName(const std::string& name) {
  const std::string what = "resource name";
  MS_RETURN_IF_ERROR(CheckCommon(what, name, kMaxResourceNameBytes));
  size_t start = 0;
  while (true) {
    const size_t slash = name.find('/', start);
    const std::string segment = name.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    auto refuse = [&](const std::string& why) { return InvalidArgument(what + " '" + PrintableName(name) + "': " + why); };
    if (segment.empty()) return refuse("empty segments ('//' or a trailing '/') are not allowed");
    if (segment == ".") return refuse("'.' segments are not allowed");
    if (segment == "..") return refuse("'..' segments are not allowed");
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  return Status::Ok();
}

Status CheckMainFilename(const std::string& filename) {
  const std::string what = "filename";
  MS_RETURN_IF_ERROR(CheckCommon(what, filename, kMaxMainFilenameBytes));
  auto refuse = [&](const std::string& why) { return InvalidArgument(what + " '" + PrintableName(filename) + "': " + why); };
  if (filename.find('/') != std::string::npos) return refuse("a plain file name may not hold '/'");
  if (filename == "." || filename == "..") return refuse("not a file name");
  const std::string ext = FileExtension(filename);
  if (ext != ".gltf" && ext != ".glb" && ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl") {
    return refuse("the extension must be .gltf .glb .obj .ply .off or .stl (it chooses the format)");
  }
  return Status::Ok();
}

bool IsValidName(const std::string& name) {
  if (name.empty() || name.size() > kMaxNameBytes) return false;
  if (name == "." || name == "..") return false;  // they would name folders (uploads/<tenant>/)
  for (const char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

Status CheckName(const std::string& field, const std::string& name) {
  if (IsValidName(name)) return Status::Ok();
  if (name.empty()) return InvalidArgument(field + ": must not be empty");
  if (name.size() > kMaxNameBytes) {
    return InvalidArgument(field + ": " + std::to_string(name.size()) + " characters, at most " +
                           std::to_string(kMaxNameBytes));
  }
  if (name == "." || name == "..") return InvalidArgument(field + ": '" + name + "' is not a name");
  return InvalidArgument(field + ": only letters, digits, '.', '_' and '-' are allowed");
}

}  // namespace meshstream
